"""Gradient refinement of a front: the CasADi model of the evaluator's physics and the
IPOPT problems solved on it (docs/model.md §7)."""
