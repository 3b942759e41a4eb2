"""Invariant functions shared by the systems (batched over leading dimensions)."""

from __future__ import annotations

import numpy as np

__all__ = ["manakov_integrals", "manakov_labels", "orthogonality_defect", "skew_spectrum"]

# Beyond this dimension the Manakov family is truncated at k = 4 (cost grows like k² n³).
_MANAKOV_FULL_UP_TO = 8


def skew_spectrum(A: np.ndarray) -> np.ndarray:
    """Rotation "angles" ``θ₁ ≥ θ₂ ≥ … ≥ θ_{⌊n/2⌋}`` of skew A (eigenvalues ``±iθ_k``).

    The singular values of a skew matrix are ``θ₁, θ₁, θ₂, θ₂, …`` (and 0 for odd n);
    they are perfectly conditioned (absolute error ≤ ε‖A‖), so this is the Casimir test.
    """
    n = A.shape[-1]
    s = np.linalg.svd(A, compute_uv=False)
    return s[..., 0 : 2 * (n // 2) : 2]


def orthogonality_defect(R: np.ndarray) -> np.ndarray:
    """``‖RᵀR − I‖_F``."""
    n = R.shape[-1]
    return np.linalg.norm(np.swapaxes(R, -1, -2) @ R - np.eye(n), axis=(-2, -1))


def manakov_labels(n: int) -> list[tuple[int, int]]:
    """``(k, j)`` pairs of the nontrivial Manakov coefficients for dimension n.

    ``tr((A − λB²)^k) = Σ_j c_kj λʲ``. ``c_k0`` are Casimirs and ``c_kk`` constants; the
    coefficient vanishes when ``k − j`` is odd (a word with an odd number of skew letters
    has zero trace summed with its reversal). What remains: ``1 ≤ j ≤ k − 2``, ``k − j`` even.
    """
    kmax = n if n <= _MANAKOV_FULL_UP_TO else 4
    return [(k, j) for k in range(3, kmax + 1) for j in range(1, k - 1) if (k - j) % 2 == 0]


def manakov_integrals(A: np.ndarray, B2: np.ndarray) -> np.ndarray:
    """Manakov's integrals: coefficients ``c_kj`` of ``tr((A − λB²)^k)`` in λ.

    The Lax pair ``d/dt(A − λB²) = [A − λB², Ω + λB]`` makes every coefficient a first
    integral of the Euler top. Each polynomial of degree k is sampled at ``k + 1`` points
    ``λ = ρ e^{2πil/(k+1)}`` on a circle (ρ = ‖A‖/‖B²‖ balances the terms) and the
    coefficients are read off by a discrete Fourier transform -- exact up to round-off and
    well conditioned. Returns shape ``(..., len(manakov_labels(n)))``; for n = 2 an empty axis.
    """
    n = A.shape[-1]
    labels = manakov_labels(n)
    batch = A.shape[:-2]
    if not labels:
        return np.zeros(batch + (0,))
    rho = np.linalg.norm(A, axis=(-2, -1)) / np.linalg.norm(B2)
    rho = np.where(rho > 0, rho, 1.0)
    out = np.empty(batch + (len(labels),))
    for k in sorted({k for k, _ in labels}):
        nodes = np.exp(2j * np.pi * np.arange(k + 1) / (k + 1))
        lam = rho[..., None] * nodes  # (..., k+1)
        M = A[..., None, :, :] - lam[..., None, None] * B2  # (..., k+1, n, n)
        P = np.linalg.matrix_power(M, k)
        values = np.trace(P, axis1=-2, axis2=-1)  # (..., k+1)
        coeff = np.fft.fft(values, axis=-1) / (k + 1)  # c_j ρ^j ω^0 …: DFT with e^{-2πi jl/(k+1)}
        for idx, (kk, j) in enumerate(labels):
            if kk == k:
                out[..., idx] = np.real(coeff[..., j]) / rho**j
    return out
