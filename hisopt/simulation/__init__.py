"""Time domain: the nonlinear model (gas springs), simulation, drop tests and the
identification of modes from measured records (docs/model.md §10)."""
