"""The special Euclidean group SE(n) in homogeneous coordinates (docs/theory.md §3–§5).

A group element is ``[[Q, v], [0, 1]]`` (shape ``(..., n+1, n+1)``), an algebra element
``[[Ω, V], [0, 0]]`` with Ω skew. The bracket is the matrix commutator,
``[(Ω₁, V₁), (Ω₂, V₂)] = ([Ω₁, Ω₂], Ω₁V₂ − Ω₂V₁)``.
"""

from __future__ import annotations

import numpy as np

from .base import MatrixLieGroup
from .bivectors import _floats, bivector_dimension
from .so import SO, onto_rotations, project_to_so, so3_angle_squared, so3_exp, so3_log, so_ad_spectral_radius

__all__ = ["SE", "se_join", "se_split"]


def se_join(rotation: np.ndarray, translation: np.ndarray, *, algebra: bool = False) -> np.ndarray:
    """Homogeneous matrix from a rotation (or bivector) block and a translation vector.

    ``algebra=True`` builds ``[[Ω, V], [0, 0]]``; otherwise ``[[Q, v], [0, 1]]``.
    """
    rotation, translation = _floats(rotation), _floats(translation)
    n = rotation.shape[-1]
    batch = np.broadcast_shapes(rotation.shape[:-2], translation.shape[:-1])
    out = np.zeros(batch + (n + 1, n + 1), dtype=np.result_type(rotation, translation))
    out[..., :n, :n] = rotation
    out[..., :n, n] = translation
    if not algebra:
        out[..., n, n] = 1.0
    return out


def se_split(g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(rotation block, translation vector)`` of homogeneous matrices."""
    n = g.shape[-1] - 1
    return g[..., :n, :n], g[..., :n, n]


def _se3_left_jacobian(X: np.ndarray) -> np.ndarray:
    """``V = Σ_k Ωᵏ/(k+1)! = I + ((1 − cos θ)/θ²) Ω + ((θ − sin θ)/θ³) Ω²`` on so(3)."""
    # θ = √(θ²), not a norm: analytic in X, so complex-step derivatives pass through it
    theta = np.sqrt(so3_angle_squared(X))[..., None, None]
    small = theta < 1e-3
    t2 = theta * theta
    safe = np.where(small, 1.0, theta)
    a = np.where(small, 0.5 - t2 / 24.0 + t2 * t2 / 720.0, (1.0 - np.cos(safe)) / (safe * safe))
    b = np.where(small, 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0, (safe - np.sin(safe)) / safe**3)
    return np.eye(3) + a * X + b * (X @ X)


class SE(MatrixLieGroup):
    """The special Euclidean group SE(n) = SO(n) ⋉ Rⁿ, n ≥ 2, as homogeneous matrices.

    Parameters
    ----------
    n : int
        Dimension of the Euclidean space moved (the matrices are ``(n+1) × (n+1)``).
    """

    def __init__(self, n: int):
        self.rotations = SO(n)
        self.n = self.rotations.n
        self.matrix_size = self.n + 1
        self.dim = bivector_dimension(self.n) + self.n
        self.name = f"se({self.n})"

    def exp(self, X: np.ndarray) -> np.ndarray:
        if self.n == 3:
            Om, V = se_split(X)
            return se_join(so3_exp(Om), (_se3_left_jacobian(Om) @ V[..., None])[..., 0])
        from scipy.linalg import expm

        return expm(X)

    def cay(self, X: np.ndarray) -> np.ndarray:
        if self.n == 3:
            # Closed form, as on SO(3): cay([[ŵ, x], [0, 0]]) = [[cay ŵ, M⁻¹x], [0, 1]] with
            # M = I − ŵ/2, M⁻¹x = (x + ŵx/2 + w⟨w, x⟩/4)/s, s = 1 + θ²/4 — orthogonal to round-off
            # at any step, where the solve on the homogeneous matrix loses the rotation's
            # orthogonality with the skewness of a huge ŵ (the compiled kernel's map, to the bit
            # of the formula)
            Om, V = se_split(X)
            w = np.stack([Om[..., 2, 1], Om[..., 0, 2], Om[..., 1, 0]], axis=-1)
            s = 1.0 + 0.25 * so3_angle_squared(Om)
            t = V + 0.5 * (Om @ V[..., None])[..., 0] + (0.25 * np.sum(w * V, axis=-1))[..., None] * w
            return se_join(self.rotations.cay(Om), t / s[..., None])
        g = super().cay(X)
        # the rotation block onto SO(n) where a huge step's solve left it off (so.onto_rotations)
        R = g[..., : self.n, : self.n]
        fixed = onto_rotations(R, X[..., : self.n, : self.n])
        if fixed is not R:
            g = g.copy()
            g[..., : self.n, : self.n] = fixed
        return g

    def log(self, g: np.ndarray) -> np.ndarray:
        if self.n == 3:
            Q, v = se_split(g)
            Om = so3_log(Q)
            V = np.linalg.solve(_se3_left_jacobian(Om), v[..., None])[..., 0]
            return se_join(Om, V, algebra=True)
        from scipy.linalg import logm

        X = np.real(logm(g))
        Om, V = se_split(X)
        return se_join(0.5 * (Om - np.swapaxes(Om, -1, -2)), V, algebra=True)

    def inverse(self, g: np.ndarray) -> np.ndarray:
        Q, v = se_split(g)
        Qt = np.swapaxes(Q, -1, -2)
        return se_join(Qt, -(Qt @ v[..., None])[..., 0])

    def project(self, g: np.ndarray) -> np.ndarray:
        Q, v = se_split(g)
        return se_join(project_to_so(Q), v)

    def ad_spectral_radius(self, X: np.ndarray) -> np.ndarray:
        # Rotation part as on so(n); the translation part adds the eigenvalues ±iθ_k of Ω
        # itself, which only matters for n = 2 where so(2) is abelian.
        Om = X[..., : self.n, : self.n]
        if self.n == 2:
            return np.abs(Om[..., 1, 0])
        return so_ad_spectral_radius(Om)

    def ad_radius_upper_bound(self, X: np.ndarray) -> np.ndarray:
        return (
            self.rotations.ad_radius_upper_bound(X[..., : self.n, : self.n])
            if self.n > 2
            else (self.ad_spectral_radius(X))
        )
