"""The car coupled to its HIS: dynamic stiffness, exact lumped state space, outputs, modes
and the laden operating point (docs/model.md §2-§4)."""
