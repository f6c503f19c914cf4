"""The transient roll quantities in the CasADi refinement (docs/model.md §6.6 and §11).

A step response's peak is the maximum over time of a sum of modal exponentials: it has no
closed form in the design, and CasADi has no eigendecomposition. The refinement therefore
takes the quantities from the numpy code every engine shares (:func:`hisopt.evaluation.transient.
transient_quantities`, the evaluator's own numbers) through a CasADi callback, with
derivatives by finite differences: all ``2 n_var + 1`` designs of one Jacobian form one
vectorised batch. Central differences of step ``h`` in scaled design units (one-sided at a
bound of the box) err by about ``h^2`` times the quantity's curvature plus its numerical
noise over ``h``. The noise is not rounding alone: a step peak carries the relative error of
the eigendecomposition's poles and residues, up to some 1e-9 for lightly damped designs, so
``h = 1e-5`` can give slopes off by 100 % where a quantity barely depends on a variable
(measured on ``Rv``). ``h = 1e-3`` (0.1 % of each range) keeps the noise's share near 1e-3
and the truncation near 1e-6 of a slope, ample for IPOPT's quasi-Newton steps; the values
themselves are the evaluator's.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from hisopt.optim.gradient.casadi_model import JacobianCallback

if TYPE_CHECKING:
    from hisopt.specification.design_space import DesignSpace

STEP = 1e-3
"""[-] Finite-difference step in scaled design units (the box is [0, 1] per variable)."""


def difference_designs(u: np.ndarray, step: float = STEP) -> tuple[np.ndarray, np.ndarray]:
    """The scaled designs a Jacobian needs, ``(1 + 2 n, n)`` (``u``, then ``u + s_i e_i`` and
    ``u - s_i e_i`` per variable), and each variable's total spread ``(n,)``: central where
    ``u`` is at least ``step`` inside the box, one-sided (doubled step) at a bound."""
    n = u.size
    at_top, at_bottom = u + step > 1.0, u - step < 0.0
    up = np.where(at_top, 0.0, np.where(at_bottom, 2 * step, step))
    down = np.where(at_bottom, 0.0, np.where(at_top, 2 * step, step))
    eye = np.eye(n)
    designs = np.vstack([u[None, :], u + up[:, None] * eye, u - down[:, None] * eye])
    return designs, up + down


class TransientCallback(ca.Callback):
    """``u -> transient quantities (k,)`` of scaled designs ``x = lower + span * u``.

    Parameters
    ----------
    problem : DesignSpace
        the single-case problem (a scenario's, for a load case)
    names : Sequence[str]
        transient quantity names, in output order
    lower, span : np.ndarray
        [variable units] scaling of the design, shape ``(n_var,)``
    """

    def __init__(self, problem: DesignSpace, names: Sequence[str], lower: np.ndarray, span: np.ndarray):
        ca.Callback.__init__(self)
        self.problem, self.names = problem, list(names)
        self.lower, self.span = np.asarray(lower, dtype=float), np.asarray(span, dtype=float)
        self._cache: dict[bytes, tuple[np.ndarray, np.ndarray | None]] = {}
        self._jacobian: Any = None
        self.construct("transient", {"enable_fd": False})

    # -- CasADi callback interface --
    def get_n_in(self) -> int:
        return 1

    def get_n_out(self) -> int:
        return 1

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(self.lower.size, 1)

    def get_sparsity_out(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(len(self.names), 1)

    def eval(self, arg: Sequence[Any]) -> list[Any]:
        return [self.evaluate(np.array(arg[0]).ravel(), jacobian=False)[0]]

    def has_jacobian(self, *args: Any) -> bool:
        return True

    def get_jacobian(self, name: str, inames: Sequence[str], onames: Sequence[str], opts: Mapping[str, Any]) -> ca.Function:
        self._jacobian = JacobianCallback(name, self, opts)
        return self._jacobian

    # -- numbers --
    def values(self, u: np.ndarray) -> np.ndarray:
        """The quantities of the scaled designs ``u`` ``(m, n_var)``, ``(m, k)``."""
        from hisopt.evaluation.transient import transient_quantities

        x = self.lower + self.span * np.clip(u, 0.0, 1.0)
        model = self.problem.model(x)
        handling = self.problem.spec.handling
        q = transient_quantities(model, model.car, self.names, handling.step_g, handling.gravity_moment)
        return np.column_stack([q[name] for name in self.names])

    def evaluate(self, u: np.ndarray, jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """Quantities ``(k,)`` and, if asked, their Jacobian ``(k, n_var)`` in scaled units."""
        key = np.asarray(u, dtype=float).tobytes()
        hit = self._cache.get(key)
        if hit is not None and (hit[1] is not None or not jacobian):
            return hit
        if jacobian:
            designs, spread = difference_designs(np.asarray(u, dtype=float))
            v = self.values(designs)
            n = u.size
            result = (v[0], ((v[1 : 1 + n] - v[1 + n :]) / spread[:, None]).T)
        else:
            result = (self.values(np.asarray(u, dtype=float)[None, :])[0], None)
        self._cache[key] = result  # IPOPT revisits an iterate for its derivatives
        while len(self._cache) > 8:
            self._cache.pop(next(iter(self._cache)))
        return result
