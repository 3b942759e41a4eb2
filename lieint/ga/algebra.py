"""Bivectors and rotors of Cl(n) through ``clifford``, batched (MATH.md §1).

Sign convention, checked once and for all in ``tests/test_ga.py``: the skew matrix of a
bivector ω acts on vectors as the commutator product ``x ↦ ω × x = ½(ωx − xω)`` (the entry
``[i, j]``, i < j, is the coefficient of the blade ``e_ij = e_i ∧ e_j``), and the rotor
``exp(tω/2)`` moves ``x ↦ R x R̃`` with ``d/dt = ω × x``. So the rotation matrix ``exp(X)``
corresponds to the rotor ``exp(X/2)`` (up to the sign of the double cover).

clifford provides the algebra (its layout and multiplication table); lieint vectorises the
products over leading batch dimensions with a gather table: for each left blade i, the right
blade j that lands on the output blade k, and the sign. A product then costs ``(2ⁿ)²``
multiply-adds per member (n = 6: 4096), which keeps Cl(n) practical up to n ≈ 8.
"""

from __future__ import annotations

from functools import cache

import clifford
import numpy as np

from ..groups.bivectors import bivector_coordinates, from_bivector_coordinates
from ..groups.so import so_log

__all__ = [
    "GA",
    "algebra",
    "bivector_to_skew",
    "matrix_to_rotor",
    "rotor_to_matrix",
    "skew_to_bivector",
    "to_values",
]

_MAX_N = 8


class GA:
    """Cl(n) (Euclidean signature) with batched products on coefficient arrays ``(..., 2ⁿ)``.

    Attributes
    ----------
    layout : clifford.Layout
        clifford's layout (blade order: shortlex, so grade-2 blades run ``e12, e13, …, e23, …``
        exactly like :func:`lieint.groups.bivector_coordinates`).
    size : int
        ``2ⁿ``.
    """

    def __init__(self, n: int):
        self.n = n
        self.layout, self.blades = clifford.Cl(n)
        self.size = self.layout.gaDims
        grades = np.array([len(t) for t in self.layout.bladeTupList])
        self.grades = grades
        self.reverse_sign = np.where((grades * (grades - 1) // 2) % 2 == 0, 1.0, -1.0)
        self.vector_index = np.flatnonzero(grades == 1)
        self.bivector_index = np.flatnonzero(grades == 2)
        # Gather table of the geometric product: (ab)_k = Σ_i a_i b_{J[i,k]} S[i,k].
        i, k, j = self.layout.gmt.coords
        J = np.zeros((self.size, self.size), dtype=np.intp)
        S = np.zeros((self.size, self.size))
        J[i, k] = j
        S[i, k] = self.layout.gmt.data
        self._J, self._S = J, S

    def product(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Geometric product of coefficient arrays (broadcast over leading dimensions)."""
        return np.einsum("...i,...ik->...k", a, b[..., self._J] * self._S)

    def reverse(self, a: np.ndarray) -> np.ndarray:
        """Reversion ``ã`` (sign ``(−1)^{g(g−1)/2}`` on grade g)."""
        return a * self.reverse_sign

    def scalar(self, value: np.ndarray) -> np.ndarray:
        """Multivector with scalar part ``value``."""
        out = np.zeros(np.shape(value) + (self.size,))
        out[..., 0] = value
        return out

    def vector(self, x: np.ndarray) -> np.ndarray:
        out = np.zeros(np.shape(x)[:-1] + (self.size,))
        out[..., self.vector_index] = x
        return out

    def bivector(self, X: np.ndarray) -> np.ndarray:
        """Coefficients of the bivector of a skew matrix X."""
        out = np.zeros(np.shape(X)[:-2] + (self.size,))
        out[..., self.bivector_index] = bivector_coordinates(X)
        return out

    def skew(self, a: np.ndarray) -> np.ndarray:
        """Skew matrix of the grade-2 part of ``a``."""
        return from_bivector_coordinates(a[..., self.bivector_index], self.n)

    def sandwich(self, R: np.ndarray, x: np.ndarray) -> np.ndarray:
        """``R x R̃``."""
        return self.product(self.product(R, x), self.reverse(R))

    def rotor_exp(self, X: np.ndarray) -> np.ndarray:
        """Rotor ``exp(ω/2)`` of the bivector of the skew matrix X (Spin(n) element).

        n ≤ 3 (every bivector simple, ``ω² = −θ²``): ``cos(θ/2) + sin(θ/2) ω/θ``. Otherwise a
        Taylor series in the algebra with scaling and squaring, then normalisation.
        """
        half = 0.5 * self.bivector(X)
        if self.n <= 3:
            theta = np.sqrt(np.sum(bivector_coordinates(X) ** 2, axis=-1))[..., None]
            small = theta < 1e-8
            safe = np.where(small, 1.0, theta)
            sinc = np.where(small, 1.0 - theta**2 / 24.0, np.sin(0.5 * safe) / (0.5 * safe))
            return self.scalar(np.cos(0.5 * theta[..., 0])) + sinc * half
        norm = np.sqrt(np.sum(half * half, axis=-1))
        squarings = int(max(0, np.ceil(np.log2(max(float(np.max(norm, initial=0.0)), 1e-300) / 0.25))))
        scaled = half / 2.0**squarings
        term = self.scalar(np.ones(half.shape[:-1]))
        out = term.copy()
        for k in range(1, 14):
            term = self.product(term, scaled) / k
            out = out + term
        for _ in range(squarings):
            out = self.product(out, out)
        return self.normalize(out)

    def normalize(self, R: np.ndarray) -> np.ndarray:
        """Nearest rotor: ``R (R̃R)^{-1/2}`` — the Clifford analogue of the polar factor.

        ``R̃R = 1 + ε`` for a rotor perturbed by round-off (ε of grades 0 and 4, …); the inverse
        square root is the series ``1 − ε/2 + 3ε²/8 − 5ε³/16``, exact to round-off for ε ~ 1e-15.
        For n ≤ 3, ``R̃R`` is a scalar and this is division by the norm.
        """
        RR = self.product(self.reverse(R), R)
        if self.n <= 3:
            return R / np.sqrt(RR[..., :1])
        eps = RR - self.scalar(np.ones(RR.shape[:-1]))
        eps2 = self.product(eps, eps)
        inv_sqrt = self.scalar(np.ones(RR.shape[:-1])) - 0.5 * eps + 0.375 * eps2 - 0.3125 * self.product(eps2, eps)
        return self.product(R, inv_sqrt)

    def rotor_matrix(self, R: np.ndarray) -> np.ndarray:
        """Rotation matrix Q of a rotor: ``Q e_i = R e_i R̃``."""
        basis = np.eye(self.n)
        cols = self.sandwich(R[..., None, :], self.vector(basis))  # (..., n basis, 2ⁿ)
        return np.swapaxes(cols[..., self.vector_index], -1, -2)


@cache
def algebra(n: int) -> GA:
    """The (cached) batched Cl(n) for ``2 ≤ n ≤ 8``."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 2 <= n <= _MAX_N:
        raise ValueError(
            f"`n` must be an integer in [2, {_MAX_N}] for geometric algebra (Cl(n) has 2^n coefficients "
            f"and a product costs 4^n per body); got {n!r}."
        )
    return GA(int(n))


def to_values(mv, n: int | None = None) -> np.ndarray:
    """Coefficient array ``(..., 2ⁿ)`` of a clifford MultiVector or MVArray (or an array)."""
    if isinstance(mv, clifford.MultiVector):
        return np.asarray(mv.value, dtype=float)
    if isinstance(mv, np.ndarray) and mv.dtype == object:
        return np.stack([to_values(m) for m in mv.ravel()]).reshape(mv.shape + (-1,))
    return np.asarray(mv, dtype=float)


def _to_mv(values: np.ndarray, ga: GA):
    if values.ndim == 1:
        return ga.layout.MultiVector(values.copy())
    flat = [ga.layout.MultiVector(v.copy()) for v in values.reshape(-1, ga.size)]
    return clifford.MVArray(flat).reshape(values.shape[:-1])


def skew_to_bivector(X):
    """clifford bivector(s) of skew matrices ``(..., n, n)``: a MultiVector, or an MVArray for batches."""
    X = np.asarray(X, dtype=float)
    ga = algebra(X.shape[-1])
    return _to_mv(ga.bivector(X), ga)


def bivector_to_skew(B, n: int | None = None) -> np.ndarray:
    """Skew matrices ``(..., n, n)`` of clifford bivector(s) (other grades must vanish)."""
    layout = _layout_of(B)
    n = layout.dims if layout is not None else n
    if n is None:
        raise ValueError("`n` is needed to read bivectors given as plain coefficient arrays.")
    ga = algebra(n)
    values = to_values(B)
    other = np.delete(values, ga.bivector_index, axis=-1)
    scale = max(float(np.max(np.abs(values), initial=0.0)), 1e-300)
    if np.max(np.abs(other), initial=0.0) > 1e-12 * scale:
        raise ValueError(
            "expected a bivector (grade 2 only); got a multivector with other grades of size "
            f"{float(np.max(np.abs(other))):.3g}."
        )
    return ga.skew(values)


def rotor_to_matrix(R) -> np.ndarray:
    """Rotation matrices ``(..., n, n)`` of clifford rotors (MultiVector/MVArray or arrays with ``n``)."""
    layout = _layout_of(R)
    ga = algebra(layout.dims)
    return ga.rotor_matrix(to_values(R))


def matrix_to_rotor(Q, reference=None, *, as_multivector: bool = True):
    """Rotor(s) of rotation matrices: ``exp(log(Q)/2)``.

    The double cover leaves a sign free; it is chosen so that the rotor has a nonnegative
    scalar part, or, given ``reference`` rotors, a nonnegative inner product with them
    (continuity along a trajectory).
    """
    Q = np.asarray(Q, dtype=float)
    ga = algebra(Q.shape[-1])
    R = ga.rotor_exp(so_log(Q))
    ref = to_values(reference) if reference is not None else ga.scalar(np.ones(R.shape[:-1]))
    sign = np.where(np.sum(R * ref, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    R = sign * R
    return _to_mv(R, ga) if as_multivector else R


def _layout_of(mv):
    if isinstance(mv, clifford.MultiVector):
        return mv.layout
    if isinstance(mv, np.ndarray) and mv.dtype == object and mv.size:
        return mv.ravel()[0].layout
    return None
