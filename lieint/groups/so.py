"""The rotation group SO(n) and its algebra so(n) of bivectors (docs/theory.md §1, §6).

Closed forms where they exist -- n = 2 (rotation by an angle), n = 3 (Rodrigues, and the
so(3) closed form of dexp⁻¹) -- and general n through ``scipy.linalg.expm``/``logm`` and
the spectral form of dexp⁻¹. All functions accept leading batch dimensions.
"""

from __future__ import annotations

import numpy as np

from .base import MatrixLieGroup
from .bivectors import bivector_dimension, commutator, hat, skew_part, vee

__all__ = [
    "SO",
    "dexpinv_so3",
    "dexpinv_spectral",
    "project_to_so",
    "so3_angle_squared",
    "so3_exp",
    "so3_log",
    "so_ad_spectral_radius",
    "so_exp",
    "so_log",
    "so_norm",
]

# Below this angle the closed forms switch to their Taylor series (no 0/0).
_SMALL_ANGLE = 1e-3
_EYE3 = np.eye(3)
_EYE3.flags.writeable = False


def so3_angle_squared(X: np.ndarray) -> np.ndarray:
    """``θ² = |vee X|²`` of skew 3×3 matrices, read off the lower triangle (cheap, no copy)."""
    a, b, c = X[..., 2, 1], X[..., 0, 2], X[..., 1, 0]
    return a * a + b * b + c * c  # x * x is x ** 2 to the bit, without the power's scalar dispatch


def so_norm(X: np.ndarray) -> np.ndarray:
    """Spectral norm ``‖X‖₂`` of skew matrices = the largest rotation angle ``θ_max``."""
    n = X.shape[-1]
    if n == 2:
        return np.abs(X[..., 1, 0])
    if n == 3:
        return np.sqrt(so3_angle_squared(X))
    return np.linalg.svd(X, compute_uv=False)[..., 0]


def so_ad_spectral_radius(X: np.ndarray) -> np.ndarray:
    """Spectral radius of ``ad_X`` on so(n): ``θ₁ + θ₂``, the two largest rotation angles.

    ``X = W diag(λ) Wᴴ`` with ``λ = ±iθ_k`` (and 0 for odd n); ``ad_X`` has eigenvalues
    ``λ_i − λ_j`` on ``w_i w_jᴴ``, but ``w wᵀ`` for the pair ``±iθ_k`` of one plane is
    symmetric, so ``2θ_k`` is *not* an eigenvalue on skew matrices. Hence the radius is
    ``θ₁ + θ₂`` (``θ₂ = 0`` for n = 3), and 0 on the abelian so(2). For so(3) the dexp⁻¹
    series thus converges up to ``θ < 2π``, as the poles of the closed form confirm.
    """
    n = X.shape[-1]
    if n == 2:
        return np.zeros(X.shape[:-2])
    if n == 3:
        return np.sqrt(so3_angle_squared(X))
    s = np.linalg.svd(X, compute_uv=False)  # θ₁, θ₁, θ₂, θ₂, …
    return s[..., 0] + s[..., 2]


def so3_exp(X: np.ndarray) -> np.ndarray:
    """Rodrigues' formula ``exp X = I + (sin θ/θ) X + ((1 − cos θ)/θ²) X²``, θ = |vee X|."""
    if X.ndim == 2:  # one matrix: the same arithmetic on scalars (4× faster than on 1 × 1 arrays)
        t2 = np.float64(so3_angle_squared(X))
        theta = np.sqrt(t2)
        if theta < _SMALL_ANGLE:
            a, b = 1.0 - t2 / 6.0 + t2 * t2 / 120.0, 0.5 - t2 / 24.0 + t2 * t2 / 720.0
        else:
            a, b = np.sin(theta) / theta, (1.0 - np.cos(theta)) / (theta * theta)
        return _EYE3 + a * X + b * (X @ X)
    t2 = so3_angle_squared(X)[..., None, None]
    theta = np.sqrt(t2)
    small = theta < _SMALL_ANGLE
    safe = np.where(small, 1.0, theta)
    a = np.where(small, 1.0 - t2 / 6.0 + t2 * t2 / 120.0, np.sin(safe) / safe)
    b = np.where(small, 0.5 - t2 / 24.0 + t2 * t2 / 720.0, (1.0 - np.cos(safe)) / (safe * safe))
    return np.eye(3) + a * X + b * (X @ X)


def so3_log(R: np.ndarray) -> np.ndarray:
    """Principal logarithm on SO(3), robust near θ = 0 and θ = π."""
    s = 0.5 * vee(R - np.swapaxes(R, -1, -2))  # sin θ · axis
    c = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)  # cos θ
    sin_t = np.linalg.norm(s, axis=-1)
    theta = np.arctan2(sin_t, c)
    small = sin_t < _SMALL_ANGLE
    # Regular case: X = θ / sin θ · skew(R); θ/sin θ stays bounded unless θ ≈ π.
    ratio = np.where(
        small & (c > 0), 1.0 + theta**2 / 6.0 + 7.0 * theta**4 / 360.0, theta / np.where(small, 1.0, sin_t)
    )
    w = ratio[..., None] * s
    near_pi = small & (c <= 0)
    if np.any(near_pi):
        # (R + Rᵀ)/2 − c I = (1 − c) a aᵀ: read the axis off its largest column.
        sym = 0.5 * (R + np.swapaxes(R, -1, -2)) - c[..., None, None] * np.eye(3)
        aat = sym / (1.0 - c)[..., None, None]
        col = np.argmax(np.diagonal(aat, axis1=-2, axis2=-1), axis=-1)
        axis = np.take_along_axis(aat, col[..., None, None], axis=-1)[..., 0]
        axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
        sign = np.where(np.einsum("...i,...i->...", axis, s) < 0, -1.0, 1.0)
        w_pi = (sign * theta)[..., None] * axis
        w = np.where(near_pi[..., None], w_pi, w)
    return hat(w)


def so_exp(X: np.ndarray) -> np.ndarray:
    """Exponential ``so(n) → SO(n)``: closed form for n = 2, 3, ``scipy.linalg.expm`` else."""
    n = X.shape[-1]
    if n == 2:
        theta = X[..., 1, 0]
        c, s = np.cos(theta), np.sin(theta)
        return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    if n == 3:
        return so3_exp(X)
    from scipy.linalg import expm

    return expm(X)


def so_log(R: np.ndarray) -> np.ndarray:
    """Principal logarithm ``SO(n) → so(n)`` (rotation angles in ``[0, π]``)."""
    n = R.shape[-1]
    if n == 2:
        theta = np.arctan2(R[..., 1, 0], R[..., 0, 0])
        z = np.zeros_like(theta)
        return np.stack([np.stack([z, -theta], -1), np.stack([theta, z], -1)], -2)
    if n == 3:
        return so3_log(R)
    from scipy.linalg import logm

    return skew_part(np.real(logm(R)))


def onto_rotations(Q: np.ndarray, W: np.ndarray) -> np.ndarray:
    """``Q = cay(W)`` (computed by a solve) with each matrix whose ``I − W/2`` is not column
    diagonally dominant (``Σ_r |W_rc| ≥ 2`` for some c; below, θ₁ < 2 and the solve is
    orthogonal to a few ε: nothing to look at) and is off the orthogonal ones by
    ``δ = max |QᵀQ − I| > 8nε`` replaced by
    its nearest rotation (:func:`project_to_so`), or by NaN when δ exceeds
    :data:`lieint.fast.skew.OFF_GROUP` (1e-6): a Cayley map computed by a solve is accurate to
    ``ε·cond(I − X/2) = ε(1 + θ₁²/4)^{1/2}``, and an RKMK stage far beyond the step's range
    (θ ~ 1e17) leaves it off SO(n) by O(1) — the attitude ``R ← RQ`` with it; such a map is not
    the map any more, and NaN has the step reported or, a trial step, rejected. The compiled
    kernels do the same (:func:`lieint.fast.skew.orthogonal_polish`). Non-finite matrices are
    left as they are."""
    n = Q.shape[-1]
    if np.all(np.abs(W).sum(axis=-2) < 2.0):  # every matrix dominant (NaN fails: looked at)
        return Q
    defect = np.abs(np.swapaxes(Q, -1, -2) @ Q - np.eye(n)).max(axis=(-2, -1))
    off = defect > 8 * n * np.finfo(float).eps  # NaN is not off: left to the caller
    if not np.any(off):
        return Q
    Q = Q.copy()
    Q[off] = project_to_so(Q[off])
    Q[defect > _OFF_GROUP] = np.nan
    return Q


#: :data:`lieint.fast.skew.OFF_GROUP` (not imported: numba stays unloaded on the generic path)
_OFF_GROUP = 1e-6


def project_to_so(R: np.ndarray) -> np.ndarray:
    """Nearest rotation in the Frobenius norm: the orthogonal polar factor with det = +1.

    From the SVD ``R = U Σ Vᵀ``: ``R ← U diag(1, …, 1, det(U Vᵀ)) Vᵀ``. numpy's batched SVD is
    used rather than ``scipy.linalg.polar`` because the polar factor alone may be a
    reflection (det −1), which is not the nearest *rotation*, and because it batches.
    """
    U, _, Vt = np.linalg.svd(R)
    d = np.sign(np.linalg.det(U @ Vt))
    U = U.copy()
    U[..., :, -1] *= d[..., None]
    return U @ Vt


def dexpinv_so3(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Closed form on so(3): ``dexp⁻¹_u(v) = v − ½[u, v] + α [u, [u, v]]`` with
    ``α = (1 − (θ/2) cot(θ/2)) / θ²``, ``θ = |vee u|`` (exact; singular at θ = 2π)."""
    t2 = so3_angle_squared(u)[..., None, None]
    theta = np.sqrt(t2)
    small = theta < 1e-2
    safe = np.where(small, 1.0, theta)
    alpha = np.where(
        small,
        1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0 + t2**3 / 1209600.0,
        (1.0 - 0.5 * safe / np.tan(0.5 * safe)) / (safe * safe),
    )
    uv = commutator(u, v)
    return v - 0.5 * uv + alpha * commutator(u, uv)


def _bernoulli_generating(z: np.ndarray) -> np.ndarray:
    """``z / (eᶻ − 1)`` (= 1 at z = 0), for complex z."""
    small = np.abs(z) < 1e-4
    zs = np.where(small, 1.0, z)
    return np.where(small, 1.0 - z / 2.0 + z * z / 12.0, zs / np.expm1(zs))


def dexpinv_spectral(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Exact ``dexp⁻¹_u(v)`` on so(n) for any n from the spectral decomposition of u.

    ``iu`` is Hermitian: ``u = W diag(λ) Wᴴ`` with imaginary λ, and ``ad_u`` acts on the
    entry ``(i, j)`` of ``Wᴴ v W`` by ``λ_i − λ_j``; apply ``z / (eᶻ − 1)`` there.
    """
    mu, W = np.linalg.eigh(1j * u)
    lam = -1j * mu
    factor = _bernoulli_generating(lam[..., :, None] - lam[..., None, :])
    WH = np.conj(np.swapaxes(W, -1, -2))
    return np.real(W @ (factor * (WH @ v @ W)) @ WH)


class SO(MatrixLieGroup):
    """The special orthogonal group SO(n), n ≥ 2, acting on bivectors and rotations.

    Parameters
    ----------
    n : int
        Dimension of the space rotated (n ≥ 2).

    Examples
    --------
    >>> import numpy as np
    >>> from lieint.groups import SO, hat
    >>> G = SO(3)
    >>> R = G.exp(hat(np.array([0.0, 0.0, np.pi / 2])))
    >>> np.allclose(R @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    True
    """

    def __init__(self, n: int):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
            raise ValueError(f"`n` must be an integer >= 2; got {n!r}.")
        self.n = int(n)
        self.matrix_size = self.n
        self.dim = bivector_dimension(self.n)
        self.name = f"so({self.n})"

    def exp(self, X: np.ndarray) -> np.ndarray:
        return so_exp(X)

    def log(self, g: np.ndarray) -> np.ndarray:
        return so_log(g)

    def inverse(self, g: np.ndarray) -> np.ndarray:
        return np.swapaxes(g, -1, -2)

    def cay(self, X: np.ndarray) -> np.ndarray:
        if self.n == 3:
            # Closed form cay(ŵ) = I + 4/(4 + θ²) (ŵ + ŵ²/2): orthogonal to round-off at any θ,
            # where the linear solve loses digits as cond(I − X/2) = √(1 + θ²/4) grows.
            t2 = so3_angle_squared(X)[..., None, None]
            return np.eye(3) + (4.0 / (4.0 + t2)) * (X + 0.5 * (X @ X))
        return onto_rotations(super().cay(X), X)

    def project(self, g: np.ndarray) -> np.ndarray:
        return project_to_so(g)

    def ad_spectral_radius(self, X: np.ndarray) -> np.ndarray:
        return so_ad_spectral_radius(X)

    def ad_radius_upper_bound(self, X: np.ndarray) -> np.ndarray:
        # ‖X‖_F² = 2 Σ θ_k² ≥ (θ₁ + θ₂)²: the Frobenius norm bounds the radius without an SVD
        if self.n <= 3:
            return so_ad_spectral_radius(X)
        return np.sqrt(np.sum(X * X, axis=(-2, -1)))

    def dexpinv(self, u: np.ndarray, v: np.ndarray, degree: int | None = None) -> np.ndarray:
        if self.n == 2:
            return v.copy()  # so(2) is abelian: dexp⁻¹ is the identity
        if degree is not None:
            return super().dexpinv(u, v, degree)
        self.check_dexpinv_range(u)
        if self.n == 3:
            return dexpinv_so3(u, v)
        return dexpinv_spectral(u, v)
