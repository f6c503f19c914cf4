"""Evaluating designs: the batched evaluator, its poles and residues, error-controlled
quadrature, peak search, transient roll, load cases, the reference it is tested on, and the
parallel backends (docs/model.md §5-§6, §14)."""
