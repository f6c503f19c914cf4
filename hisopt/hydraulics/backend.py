"""The few operations of the physics core whose spelling differs between numpy and CasADi.

Every law (:mod:`hisopt.hydraulics.laws`) and every network assembly
(:mod:`hisopt.hydraulics.network`) is plain arithmetic on its arguments, so the same function
serves floats, numpy arrays batched over designs and frequencies, and CasADi symbols. What
arithmetic cannot spell is here, dispatched on the argument's type:

- elementary functions (``sqrt``, ``cosh``, ``sinh``, ``fabs``, ``sign``), which numpy would apply to a
  CasADi value only with a warning;
- complex numbers: numpy has them; CasADi does not, so a complex CasADi value is a
  :class:`Complex` pair of real expressions with the arithmetic operators and the principal
  square root, ``cosh`` and ``sinh`` (the distributed pipe's transfer matrix needs them);
- dense matrices from entry lists (:func:`assemble`), products (:func:`matmul`) and linear
  solves (:func:`solve`), batched over leading axes for numpy, 2-D for CasADi.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np


def is_casadi(x: Any) -> bool:
    """True for CasADi values (``SX``, ``MX``, ``DM``) and :class:`Complex` pairs of them."""
    if isinstance(x, Complex):
        return is_casadi(x.re) or is_casadi(x.im)
    return type(x).__module__.startswith("casadi")


def _ca() -> Any:
    import casadi

    return casadi


@dataclass(frozen=True)
class Complex:
    """A complex CasADi value as ``re + j im`` (both real CasADi expressions or floats)."""

    re: Any
    im: Any

    def __add__(self, other: Any) -> Complex:
        o = as_complex(other)
        return Complex(self.re + o.re, self.im + o.im)

    __radd__ = __add__

    def __sub__(self, other: Any) -> Complex:
        o = as_complex(other)
        return Complex(self.re - o.re, self.im - o.im)

    def __rsub__(self, other: Any) -> Complex:
        return as_complex(other) - self

    def __neg__(self) -> Complex:
        return Complex(-self.re, -self.im)

    def __mul__(self, other: Any) -> Complex:
        o = as_complex(other)
        return Complex(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)

    __rmul__ = __mul__

    def __truediv__(self, other: Any) -> Complex:
        o = as_complex(other)
        m = o.re * o.re + o.im * o.im
        return Complex((self.re * o.re + self.im * o.im) / m, (self.im * o.re - self.re * o.im) / m)

    def __rtruediv__(self, other: Any) -> Complex:
        return as_complex(other) / self


def as_complex(x: Any) -> Complex:
    """``x`` as a :class:`Complex` pair (a real value gets a zero imaginary part)."""
    if isinstance(x, Complex):
        return x
    if isinstance(x, complex):
        return Complex(x.real, x.imag)
    return Complex(x, 0.0)


def sqrt(x: Any) -> Any:
    """Square root; complex arguments take the principal branch (``Re >= 0``)."""
    if isinstance(x, Complex):
        ca = _ca()
        r = ca.sqrt(x.re * x.re + x.im * x.im)
        # sign(0) = 0 would lose the root of a negative real number: take +j there.
        sign = ca.if_else(x.im < 0, -1.0, 1.0)
        return Complex(ca.sqrt((r + x.re) / 2), sign * ca.sqrt((r - x.re) / 2))
    if is_casadi(x):
        return _ca().sqrt(x)
    return np.sqrt(x)


def cosh(x: Any) -> Any:
    """Hyperbolic cosine (``cosh(a + jb) = cosh a cos b + j sinh a sin b``)."""
    if isinstance(x, Complex):
        ca = _ca()
        return Complex(ca.cosh(x.re) * ca.cos(x.im), ca.sinh(x.re) * ca.sin(x.im))
    if is_casadi(x):
        return _ca().cosh(x)
    return np.cosh(x)


def sinh(x: Any) -> Any:
    """Hyperbolic sine (``sinh(a + jb) = sinh a cos b + j cosh a sin b``)."""
    if isinstance(x, Complex):
        ca = _ca()
        return Complex(ca.sinh(x.re) * ca.cos(x.im), ca.cosh(x.re) * ca.sin(x.im))
    if is_casadi(x):
        return _ca().sinh(x)
    return np.sinh(x)


def fmax(a: Any, b: Any) -> Any:
    """The larger of two real arguments (elementwise)."""
    if is_casadi(a) or is_casadi(b):
        return _ca().fmax(a, b)
    return np.maximum(a, b)


def fmin(a: Any, b: Any) -> Any:
    """The smaller of two real arguments (elementwise)."""
    if is_casadi(a) or is_casadi(b):
        return _ca().fmin(a, b)
    return np.minimum(a, b)


def where(condition: Any, a: Any, b: Any) -> Any:
    """``a`` where ``condition`` holds, else ``b`` (elementwise; CasADi's ``if_else``, whose
    unchosen branch adds exactly zero to the value and to its derivatives)."""
    if is_casadi(condition) or is_casadi(a) or is_casadi(b):
        return _ca().if_else(condition, a, b)
    return np.where(condition, a, b)


def exp(x: Any) -> Any:
    """Exponential of a real argument."""
    if is_casadi(x):
        return _ca().exp(x)
    return np.exp(x)


def fabs(x: Any) -> Any:
    """Absolute value of a real argument."""
    if is_casadi(x):
        return _ca().fabs(x)
    return np.abs(x)


def sign(x: Any) -> Any:
    """``-1``, ``0`` or ``1`` by the sign of a real argument (its derivative is 0 everywhere)."""
    if is_casadi(x):
        return _ca().sign(x)
    return np.sign(x)


def jomega(omega: Any) -> Any:
    """The Laplace variable ``s = j omega`` for a real angular frequency [rad/s]."""
    if is_casadi(omega):
        return Complex(0.0, omega)
    return 1j * np.asarray(omega, dtype=float)


# --- matrices ---------------------------------------------------------------------------------
Entry = tuple[int, int, Any]
"""``(row, column, value)``: values of equal positions add up."""


def assemble(shape: tuple[int, int], entries: Iterable[Entry], batch: Sequence[int] = (), like: Any = 0.0) -> Any:
    """A dense matrix from entries.

    numpy: shape ``batch + shape``, values broadcast against ``batch`` (``like`` decides the
    dtype: pass a complex value for a complex matrix). CasADi (any value symbolic, or ``like``
    a CasADi value): an ``SX``/``MX`` matrix, or a :class:`Complex` pair of them when a value is
    complex.
    """
    entries = list(entries)
    values = [v for _, _, v in entries]
    if is_casadi(like) or any(is_casadi(v) for v in values):
        kind = _casadi_kind([like, *values])
        if any(isinstance(v, (Complex, complex)) for v in [like, *values]):
            re, im = kind.zeros(*shape), kind.zeros(*shape)
            for i, j, v in entries:
                c = as_complex(v)
                re[i, j] += c.re
                im[i, j] += c.im
            return Complex(re, im)
        out = kind.zeros(*shape)
        for i, j, v in entries:
            out[i, j] += v
        return out
    dtype = np.result_type(like, *[np.asarray(v).dtype for v in values]) if values else np.asarray(like).dtype
    full = tuple(np.broadcast_shapes(tuple(batch), *(np.shape(v) for v in values)))
    out = np.zeros(full + tuple(shape), dtype=dtype)
    for i, j, v in entries:
        out[..., i, j] += v
    return out


def _casadi_kind(values: Sequence[Any]) -> Any:
    ca = _ca()
    for v in values:
        parts = (v.re, v.im) if isinstance(v, Complex) else (v,)
        if any(isinstance(p, ca.MX) for p in parts):
            return ca.MX
    return ca.SX


def matmul(a: Any, b: Any) -> Any:
    """Matrix product (numpy: over the last two axes, broadcasting; complex pairs for CasADi)."""
    if isinstance(a, Complex) or isinstance(b, Complex):
        ca = _ca()
        if not isinstance(a, Complex):
            return Complex(ca.mtimes(a, b.re), ca.mtimes(a, b.im))
        if not isinstance(b, Complex):
            return Complex(ca.mtimes(a.re, b), ca.mtimes(a.im, b))
        return Complex(ca.mtimes(a.re, b.re) - ca.mtimes(a.im, b.im), ca.mtimes(a.re, b.im) + ca.mtimes(a.im, b.re))
    if is_casadi(a) or is_casadi(b):
        return _ca().mtimes(a, b)
    return np.matmul(a, b)


def transpose(a: Any) -> Any:
    """Swap the last two axes (a CasADi matrix's transpose)."""
    if isinstance(a, Complex):
        return Complex(a.re.T, a.im.T)
    if is_casadi(a):
        return a.T
    return np.swapaxes(a, -1, -2)


def solve(a: Any, b: Any) -> Any:
    """``a^-1 b`` (numpy: batched; CasADi: a complex system in its real block form)."""
    if isinstance(a, Complex) or isinstance(b, Complex):
        ca = _ca()
        x, y = as_complex(a), as_complex(b)
        n = x.re.shape[0]
        block = ca.vertcat(ca.horzcat(x.re, -x.im), ca.horzcat(x.im, x.re))
        rhs_im = y.im if np.shape(y.im) == np.shape(y.re) else 0.0 * y.re
        sol = _casadi_solve(block, ca.vertcat(y.re, rhs_im))
        return Complex(sol[:n, :], sol[n:, :])
    if is_casadi(a) or is_casadi(b):
        return _casadi_solve(a, b)
    return np.linalg.solve(a, b)


def _casadi_solve(a: Any, b: Any) -> Any:
    """``SX``: a symbolic solve (expanded); ``MX``: LU with partial pivoting at run time, as
    numpy solves, on the matrix with its rows and then its columns scaled by powers of two to
    sums of magnitudes near 1. A network's matrix mixes compliances near 1e-13 with
    resistances near 1e9: unpivoted QR loses digits on it (0.2 % on a pipe network's ``D(s)``),
    and so does pivoted LU on the real block form of the complex system unless the rows and
    columns are scaled (1e-8 on a twin-accumulator circuit's distributed-pipe ``D(s)`` against
    3e-16 scaled; CasADi's ``lapacklu`` option ``equilibration`` changes nothing here). The
    scales are exact and piecewise constant, so the solution and its AD derivative are those of
    the unscaled system."""
    ca = _ca()
    if not (isinstance(a, ca.MX) or isinstance(b, ca.MX)):
        return ca.solve(a, b)
    a, b = ca.MX(a), ca.MX(b)
    n, m = a.shape[0], b.shape[1]
    r = _power_of_two(ca.sum2(ca.fabs(a)))  # (n, 1) row scales
    scaled = a * ca.repmat(r, 1, n)
    c = _power_of_two(ca.sum1(ca.fabs(scaled)).T)  # (n, 1) column scales
    y = ca.solve(scaled * ca.repmat(c.T, n, 1), b * ca.repmat(r, 1, m), "lapacklu")
    return y * ca.repmat(c, 1, m)


def _power_of_two(size: Any) -> Any:
    """``2^-floor(log2 size)`` elementwise: a scale that is exact in floating point."""
    ca = _ca()
    return 2.0 ** (-ca.floor(ca.log(size) / np.log(2.0)))


def real_part(x: Any) -> Any:
    """Real part (of a numpy array or a :class:`Complex` pair)."""
    if isinstance(x, Complex):
        return x.re
    return np.real(x)
