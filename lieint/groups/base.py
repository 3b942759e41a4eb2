"""The contract a matrix Lie group fulfils for the integrators (docs/theory.md §6).

Algebra elements and group elements are both stored as matrices with leading batch
dimensions: ``so(n)`` as skew ``(..., n, n)``, ``se(n)`` as homogeneous ``(..., n+1, n+1)``.
The bracket is then the matrix commutator for every group, which lets the Bernoulli series
of dexp⁻¹ and the closed form of dcay⁻¹ be written once here.

Sign conventions (left trivialisation): ``d/dt exp(u) = dexp_u(u̇) exp(u)`` with
``dexp_u = Σ_k ad_u^k / (k+1)!`` and ``dexp⁻¹_u = Σ_k B_k / k! ad_u^k``
(``B₁ = −1/2``): ``dexp⁻¹_u(v) = v − ½[u,v] + (1/12)[u,[u,v]] − (1/720)[u,[u,[u,[u,v]]]] + …``.
For ``cay(X) = (I − X/2)⁻¹(I + X/2)``: ``dcay⁻¹_X(v) = v − ½[X, v] − ¼ X v X``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from fractions import Fraction
from functools import cache

import numpy as np

from .bivectors import commutator

__all__ = ["DexpinvRangeError", "LieGroup", "MatrixLieGroup", "bernoulli_dexpinv_coefficients"]


class DexpinvRangeError(ValueError):
    """A Lie step left the region where the dexp⁻¹ series converges.

    The Bernoulli series of ``dexp⁻¹_u`` converges only while the spectral radius of
    ``ad_u`` is below ``2π`` (for so(n), n ≥ 4: ``θ₁ + θ₂ < 2π`` with θ the rotation
    angles of u; for so(3): ``θ < 2π``). Beyond it the truncated series is a polynomial that
    silently returns garbage, so lieint refuses the step.
    """


@cache
def bernoulli_dexpinv_coefficients(degree: int) -> tuple[float, ...]:
    """Coefficients ``B_k / k!`` of ``dexp⁻¹_u = Σ_k (B_k / k!) ad_u^k`` for ``k ≤ degree``.

    Computed exactly with rational arithmetic (``B₁ = −1/2`` convention), then rounded.
    """
    bern = [Fraction(1)]
    for m in range(1, degree + 1):
        # Σ_{j=0}^{m} C(m+1, j) B_j = 0
        acc = Fraction(0)
        binom = 1
        for j in range(m):
            acc += binom * bern[j]
            binom = binom * (m + 1 - j) // (j + 1)
        bern.append(-acc / (m + 1))
    coeffs = []
    fact = 1
    for k, bk in enumerate(bern):
        if k > 0:
            fact *= k
        coeffs.append(float(bk / fact))
    return tuple(coeffs)


class LieGroup(ABC):
    """The one surface every group offers: the group law (identity, multiply, inverse), the
    coordinate maps (exp, log, cay) and their inverse differentials, the projection onto the
    group, and linear combinations of algebra elements.

    Algebra and group elements are arrays with leading batch dimensions (matrices for
    :class:`MatrixLieGroup`, vectors for a vector space, tuples for a product group,
    multivectors for Spin(n)). Methods, systems and tests use only these names, so every group
    answers to the same calls.
    """

    name: str
    dim: int

    @abstractmethod
    def identity(self, batch_shape: tuple[int, ...] = ()):
        """The identity element, broadcast to ``batch_shape``."""

    @abstractmethod
    def multiply(self, g, h):
        """The group product ``g h``."""

    @abstractmethod
    def inverse(self, g):
        """The group inverse ``g⁻¹``."""

    @abstractmethod
    def log(self, g):
        """Principal logarithm: the inverse of :meth:`exp` near the identity."""

    @abstractmethod
    def project(self, g):
        """The nearest group element (removes round-off drift off the group)."""

    @abstractmethod
    def exp(self, X):
        """Exponential map of the algebra into the group."""

    @abstractmethod
    def cay(self, X):
        """Cayley map of the algebra into the group."""

    @abstractmethod
    def dexpinv(self, u, v, degree: int | None = None):
        """``dexp⁻¹_u(v)``, truncated after ``ad_u^degree`` (None: exact)."""

    @abstractmethod
    def dcayinv(self, X, v):
        """``dcay⁻¹_X(v)``."""

    @abstractmethod
    def ad_spectral_radius(self, X) -> np.ndarray:
        """Spectral radius of ``ad_X`` (shape: the batch shape of ``X``)."""

    def ad_radius_upper_bound(self, X) -> np.ndarray:
        """A cheap upper bound of :meth:`ad_spectral_radius` (default: the radius itself)."""
        return self.ad_spectral_radius(X)

    def lincomb(self, weights, elements):
        """``Σ_j w_j X_j`` of algebra elements (weights are Python floats)."""
        out = None
        for w, X in zip(weights, elements, strict=True):
            out = w * X if out is None else out + w * X
        return out

    def negate(self, X):
        """``−X``."""
        return -X


class MatrixLieGroup(LieGroup):
    """A matrix Lie group acting in the integrators.

    Subclasses declare ``n`` (the dimension of the space the group moves), ``matrix_size``
    and ``dim`` (the dimension of the algebra), and implement :meth:`exp`, :meth:`log`,
    :meth:`project` and :meth:`ad_spectral_radius`. Everything accepts leading batch
    dimensions.
    """

    n: int
    matrix_size: int
    dim: int
    name: str

    # -- group structure ---------------------------------------------------------------
    def identity(self, batch_shape: tuple[int, ...] = ()) -> np.ndarray:
        """Identity element, broadcast to ``batch_shape``."""
        eye = np.eye(self.matrix_size)
        return np.broadcast_to(eye, tuple(batch_shape) + eye.shape).copy()

    def multiply(self, g: np.ndarray, h: np.ndarray) -> np.ndarray:
        """Group product ``g h``."""
        return g @ h

    def inverse(self, g: np.ndarray) -> np.ndarray:
        """Group inverse (general matrix inverse; subclasses use the structure)."""
        return np.linalg.inv(g)

    @abstractmethod
    def exp(self, X: np.ndarray) -> np.ndarray:
        """Exponential map of the algebra into the group."""

    @abstractmethod
    def log(self, g: np.ndarray) -> np.ndarray:
        """Principal logarithm, the inverse of :meth:`exp` near the identity."""

    @abstractmethod
    def project(self, g: np.ndarray) -> np.ndarray:
        """Nearest group element (exact projection removing round-off drift)."""

    # -- algebra structure -------------------------------------------------------------
    @staticmethod
    def bracket(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
        """Lie bracket, the matrix commutator ``[X, Y] = XY − YX``."""
        return commutator(X, Y)

    def cay(self, X: np.ndarray) -> np.ndarray:
        """Cayley map ``cay(X) = (I − X/2)⁻¹ (I + X/2)`` (exactly in the group for
        quadratic groups such as SO(n), and for SE(n))."""
        eye = np.eye(self.matrix_size)
        try:
            return np.linalg.solve(eye - 0.5 * X, eye + 0.5 * X)
        except np.linalg.LinAlgError:
            # I − X/2 is invertible for every X of so(n) or se(n) (singular values ≥ 1), but in
            # floating point its unit diagonal is lost beside entries ≳ 1e16 (a loose adaptive
            # trial step can get there) and the elimination may meet an exact zero pivot. NaN
            # there, as a non-finite X gives, so that the caller rejects the step or reports the
            # state, instead of LAPACK's error.
            return _solve_or_nan(eye - 0.5 * X, eye + 0.5 * X)

    def cay_inv(self, g: np.ndarray) -> np.ndarray:
        """Inverse Cayley map ``X = 2 (g − I)(g + I)⁻¹``."""
        eye = np.eye(self.matrix_size)
        # (g - I)(g + I)^{-1} = ((g + I)^{-T} (g - I)^T)^T
        return 2.0 * np.swapaxes(np.linalg.solve(np.swapaxes(g + eye, -1, -2), np.swapaxes(g - eye, -1, -2)), -1, -2)

    def dexpinv(self, u: np.ndarray, v: np.ndarray, degree: int | None = None) -> np.ndarray:
        """``dexp⁻¹_u(v)`` by the Bernoulli series truncated after ``ad_u^degree``.

        ``degree=None`` asks for the exact value; subclasses with a closed form override
        this. The generic exact value sums the series until the terms stop contributing.
        Raises :class:`DexpinvRangeError` when the series does not converge
        (spectral radius of ``ad_u`` ≥ 2π).
        """
        self.check_dexpinv_range(u)
        if degree is None:
            return self._dexpinv_series_to_convergence(u, v)
        coeffs = bernoulli_dexpinv_coefficients(degree)
        out = v.copy()
        term = v
        for k in range(1, degree + 1):
            term = commutator(u, term)
            if coeffs[k] != 0.0:
                out = out + coeffs[k] * term
        return out

    def _dexpinv_series_to_convergence(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        coeffs = bernoulli_dexpinv_coefficients(60)
        out = v.copy()
        term = v
        scale = max(float(np.max(np.abs(v), initial=0.0)), 1e-300)
        for k in range(1, 61):
            term = commutator(u, term)
            if coeffs[k] != 0.0:
                contrib = coeffs[k] * term
                out = out + contrib
                if np.max(np.abs(contrib), initial=0.0) < 1e-17 * scale and k > 4:
                    break
        return out

    @staticmethod
    def dcayinv(X: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``dcay⁻¹_X(v) = v − ½[X, v] − ¼ X v X`` (exact, no series)."""
        return v - 0.5 * (X @ v - v @ X) - 0.25 * (X @ v @ X)

    def check_dexpinv_range(self, u: np.ndarray) -> None:
        """Raise :class:`DexpinvRangeError` if the dexp⁻¹ series diverges at ``u``."""
        with np.errstate(invalid="ignore"):
            # a cheap upper bound settles the usual case without the exact (SVD) radius
            bound = self.ad_radius_upper_bound(u)
            if np.all(bound < 2.0 * np.pi):
                return
            rho = self.ad_spectral_radius(u)
        # A non-finite stage is not a "too large step": it propagates and the driver reports it.
        worst = float(np.max(np.where(np.isfinite(rho), rho, 0.0), initial=0.0))
        if worst >= 2.0 * np.pi:
            raise DexpinvRangeError(
                f"Lie step too large for exponential coordinates on {self.name}: the spectral "
                f"radius of ad_u is {worst:.4g} >= 2*pi, where the dexp^-1 series diverges "
                "(for so(n): theta_1 + theta_2 >= 2*pi, the two largest rotation angles of the "
                "stage increment). Reduce the step `h`, or use "
                "`coordinates='cayley'`, whose dcay^-1 is exact at every step."
            )

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.n})"

    def __eq__(self, other) -> bool:
        return type(self) is type(other) and self.n == other.n

    def __hash__(self) -> int:
        return hash((type(self).__name__, self.n))


def _solve_or_nan(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``A⁻¹B`` matrix by matrix, NaN where ``A`` is singular or not finite."""
    A, B = np.broadcast_arrays(A, B)
    out = np.full(A.shape, np.nan)
    for index in np.ndindex(A.shape[:-2]):
        if np.isfinite(A[index]).all():
            try:
                out[index] = np.linalg.solve(A[index], B[index])
            except np.linalg.LinAlgError:
                pass
    return out
