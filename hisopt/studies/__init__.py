"""Studies over many designs: sensitivity sweeps and feasible regions, response spectra, the
layout screening table and the layout study at equal handling (docs/model.md §9, §12-§13)."""
