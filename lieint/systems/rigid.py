"""Parts every rigid-body system shares (docs/theory.md §1–§2).

* :class:`InertiaOperator` — the constant body mass tensor B with the maps between angular
  velocity and momentum, ``A = −(BΩ + ΩB)`` and ``Ω_ij = −Ã_ij/(b_i + b_j)`` in the eigenbasis,
  and the kinetic energy ``T = ¼ tr(ΩA)``;
* the invariants of a rotating body: the Casimirs (rotation angles of A), the space momentum
  ``a = R A Rᵀ``, the orthogonality defect ``‖RᵀR − I‖``;
* the outputs of a rotating body: its orientation and angular velocity.
"""

from __future__ import annotations

import numpy as np

from ..groups.bivectors import inner, skew_part
from .base import Invariant, Output
from .invariants import orthogonality_defect, skew_spectrum
from .mass import check_inertia_tensor, check_mass_tensor, solve_lyapunov

__all__ = [
    "ComplexStepInertia",
    "InertiaOperator",
    "casimir_invariant",
    "momentum_invariant",
    "orientation_output",
    "orthogonality_invariant",
]


class InertiaOperator:
    """The body mass tensor ``B = ∫ m X Xᵀ`` (symmetric PSD, at most one zero eigenvalue) and its
    inertia operator.

    Parameters
    ----------
    B : array_like, shape (n, n)
        The mass tensor.
    name : str
        The argument's name in error messages.
    mass_distribution : bool, default True
        Require B ⪰ 0 (:func:`~lieint.systems.mass.check_mass_tensor`). False: any symmetric B
        with ``b_i + b_j > 0`` for i ≠ j (:func:`~lieint.systems.mass.check_inertia_tensor`),
        all that the maps below need.

    Attributes
    ----------
    B, b, P : ndarray
        The tensor, its eigenvalues and a (column) eigenbasis, ``B = P diag(b) Pᵀ``.
    n : int
    """

    def __init__(self, B, name: str = "B", *, mass_distribution: bool = True):
        check = check_mass_tensor if mass_distribution else check_inertia_tensor
        self.B, self.b, self.P = check(B, name)
        self.n = self.B.shape[0]
        # A diagonal B needs no change of basis: skip two matrix products per evaluation.
        self.diagonal = bool(np.all(self.B == np.diag(np.diag(self.B))))
        if self.diagonal:
            self.b = np.diag(self.B).copy()
            self.P = np.eye(self.n)
        pair = self.b[:, None] + self.b[None, :]
        np.fill_diagonal(pair, 1.0)  # the diagonal of a bivector is zero anyway
        self.minus_inv_pair = -1.0 / pair
        self.B2 = self.B @ self.B
        # what the compiled kernels read (lieint.fast.bodies): P, then M = −1/(b_i + b_j) with a
        # zero diagonal, row by row; built once, not on every call of a system's compiled()
        off_diagonal = self.minus_inv_pair.copy()
        np.fill_diagonal(off_diagonal, 0.0)
        self.kernel_params = np.concatenate([self.P.ravel(), off_diagonal.ravel()])
        self._principal_moments = self.b.sum() - self.b

    @property
    def principal_moments(self) -> np.ndarray:
        """n = 3: ``I = tr(B) − b`` in the order of the eigenvalues ``b``."""
        return self._principal_moments.copy()

    def momentum(self, Omega: np.ndarray) -> np.ndarray:
        """Body angular momentum ``A = −(BΩ + ΩB)``."""
        return -(self.B @ Omega + Omega @ self.B)

    def angular_velocity(self, A: np.ndarray) -> np.ndarray:
        """Ω with ``A = −(BΩ + ΩB)``, via ``Ω_ij = −Ã_ij/(b_i + b_j)`` in the eigenbasis."""
        # The result is made exactly skew: for a nearly flat or rod-like body (b_i + b_j tiny)
        # the round-off asymmetry of A, divided by b_i + b_j, would otherwise make Ω visibly
        # non-skew, exp(hΩ) non-orthogonal, and the Casimirs drift.
        if self.diagonal:
            return skew_part(A * self.minus_inv_pair)
        P = self.P
        return skew_part(P @ ((P.T @ A @ P) * self.minus_inv_pair) @ P.T)

    def energy(self, A: np.ndarray) -> np.ndarray:
        """Kinetic energy ``T = ¼ tr(ΩA) = −¼ ⟨Ω, A⟩``."""
        return -0.25 * inner(self.angular_velocity(A), A)


class ComplexStepInertia:
    """The inertia operator of a complex mass tensor ``B + iε dB`` (parameter sensitivities).

    :mod:`lieint.tangent` differentiates a run with respect to B by the complex step, which
    needs every map of B to be analytic. The eigendecomposition of a complex matrix is the
    Hermitian one (not analytic), so Ω is found from ``B Ω + Ω B = −A`` by one dense solve
    (:func:`~lieint.systems.mass.solve_lyapunov`), unless B is diagonal, where
    ``Ω_ij = −A_ij/(b_i + b_j)`` is analytic as it stands. The real part ``B`` was validated by
    the system's constructor.

    Parameters
    ----------
    B : ndarray, shape (n, n)
        The complex symmetric tensor.

    Attributes
    ----------
    B, B2 : ndarray
        The tensor and its square.
    b, P : ndarray or None
        Diagonal B: its diagonal and the identity; else None (no analytic eigenbasis: the
        splittings, which rotate about the principal axes, are refused for such a B).
    diagonal : bool
    n : int
    """

    def __init__(self, B: np.ndarray):
        self.B = np.asarray(B, dtype=complex)
        self.n = self.B.shape[-1]
        self.B2 = self.B @ self.B
        self.diagonal = bool(np.all(self.B == np.diag(np.diag(self.B))))
        self.b = self.P = None
        if self.diagonal:
            self.b, self.P = np.diag(self.B).copy(), np.eye(self.n)
            pair = self.b[:, None] + self.b[None, :]
            np.fill_diagonal(pair, 1.0)
            self.minus_inv_pair = -1.0 / pair

    @property
    def principal_moments(self) -> np.ndarray:
        """n = 3, diagonal B: ``I = tr(B) − b``."""
        if self.b is None:
            raise ValueError("a non-diagonal complex mass tensor has no analytic principal moments")
        return self.b.sum() - self.b

    def momentum(self, Omega: np.ndarray) -> np.ndarray:
        """Body angular momentum ``A = −(BΩ + ΩB)``."""
        return -(self.B @ Omega + Omega @ self.B)

    def angular_velocity(self, A: np.ndarray) -> np.ndarray:
        """Ω with ``A = −(BΩ + ΩB)`` (analytic in B and A)."""
        if self.diagonal:
            return skew_part(A * self.minus_inv_pair)
        return solve_lyapunov(self.B, -np.asarray(A, dtype=complex))

    def energy(self, A: np.ndarray) -> np.ndarray:
        """Kinetic energy ``T = ¼ tr(ΩA) = −¼ ⟨Ω, A⟩``."""
        return -0.25 * inner(self.angular_velocity(A), A)


def casimir_invariant(field: str = "A") -> Invariant:
    """The rotation angles ``θ₁ ≥ θ₂ ≥ …`` of a momentum bivector (its spectrum)."""
    return Invariant(lambda t, y: skew_spectrum(y[field]), "integral", f"rotation angles of {field} (Casimirs)")


def momentum_invariant(field: str = "A") -> Invariant:
    """The space momentum ``a = R A Rᵀ``."""

    def momentum(t, y):
        R = y["R"]
        return R @ y[field] @ np.swapaxes(R, -1, -2)

    return Invariant(momentum, "integral", f"space momentum R {field} Rᵀ")


def orthogonality_invariant() -> Invariant:
    """``‖RᵀR − I‖_F``, zero for the exact flow."""
    return Invariant(lambda t, y: orthogonality_defect(y["R"]), "defect", "‖RᵀR − I‖ (R off SO(n))")


def orientation_output(n: int) -> Output:
    """The orientation R ∈ SO(n) under its physical name."""
    return Output(lambda t, y: y["R"], (n, n), "orientation R (body to space)", "rotation")


def pose_invariants(momentum_field: str | None = "A") -> dict[str, Invariant]:
    """What every body carrying R keeps: the space momentum (when conserved) and RᵀR = I."""
    out = {} if momentum_field is None else {"momentum": momentum_invariant(momentum_field)}
    out["orthogonality"] = orthogonality_invariant()
    return out


def momentum_outputs(n: int, angular_velocity, description: str = "body angular momentum A") -> dict[str, Output]:
    """``angular_momentum`` (the field A) and ``angular_velocity`` Ω = ``angular_velocity(y)``."""
    return {
        "angular_momentum": Output(lambda t, y: y["A"], (n, n), description, "bivector"),
        "angular_velocity": Output(lambda t, y: angular_velocity(y), (n, n), "body angular velocity Ω", "bivector"),
    }
