"""Exact body angular velocity of the 3D Euler top in Jacobi elliptic functions (MATH.md §2).

With principal moments ordered ``I₁ < I₂ < I₃``, ``2E = Σ I_i w_i²``, ``G² = Σ (I_i w_i)²`` and
``G² > 2E I₂``::

    w = (a₁ cn u, a₂ sn u, a₃ dn u),  u = u₀ + λ t,
    a₁² = (2E I₃ − G²)/(I₁(I₃ − I₁)),  a₂² = (2E I₃ − G²)/(I₂(I₃ − I₂)),
    a₃² = (G² − 2E I₁)/(I₃(I₃ − I₁)),  m = k² = (I₂ − I₁)(2E I₃ − G²)/((I₃ − I₂)(G² − 2E I₁)),

and ``λ = (I₃ − I₂) a₂ a₃ / (I₁ a₁)`` from ``I₁ẇ₁ = (I₂ − I₃) w₂ w₃`` (which fixes its sign).
The case ``G² < 2E I₂`` is the same formula with the axes in descending order. A relabelling
by a permutation matrix P moves the *bivector* ``Ω ↦ PᵀΩP``, whose vector is
``det(P) Pᵀw``: odd permutations flip the sign of w, which keeps Euler's equations intact.
This module is a reference for tests and comparisons; it does not use the integrators.
"""

from __future__ import annotations

import numpy as np

__all__ = ["euler_top_angular_velocity"]


def _parity(perm) -> float:
    return float(np.linalg.det(np.eye(3)[:, perm]))


def euler_top_angular_velocity(moments, w0, t) -> np.ndarray:
    """Body angular velocity ``w(t)`` of the free 3D top in its principal frame.

    Parameters
    ----------
    moments : array_like, shape (3,)
        Principal moments of inertia ``I_i`` (any order; ``I_i ≤ I_j + I_k``).
    w0 : array_like, shape (3,)
        Initial body angular velocity in the same principal frame.
    t : array_like, shape (m,)
        Times since the initial instant.

    Returns
    -------
    ndarray, shape (m, 3)
        ``w(t)`` solving ``I ẇ = (I w) × w``.
    """
    from scipy.special import ellipj, ellipkinc  # lazy: keeps `import lieint` fast

    I = np.asarray(moments, dtype=float)
    w0 = np.asarray(w0, dtype=float)
    t = np.atleast_1d(np.asarray(t, dtype=float))
    # Fixed points: (I w) × w = 0 (w on a principal axis, or in an eigenspace of I).
    if np.linalg.norm(np.cross(I * w0, w0)) <= 1e-15 * np.max(I) * max(np.dot(w0, w0), 1e-300):
        return np.broadcast_to(w0, (t.size, 3)).copy()
    asc = np.argsort(I, kind="stable")
    # G² − 2E I₂ = Σ I_i (I_i − I₂) w_i² decides which end axis the motion circles.
    perm = asc if np.sum(I * (I - I[asc[1]]) * w0**2) > 0 else asc[::-1]
    sgn = _parity(perm)
    I1, I2, I3 = I[perm]
    w = sgn * w0[perm]
    # The differences 2E I₃ − G², G² − 2E I₁ and G² − 2E I₂ are formed from the components
    # (the w₃ resp. w₁, w₂ terms cancel exactly), which keeps 1 − m accurate near the separatrix.
    d3 = I1 * (I3 - I1) * w[0] ** 2 + I2 * (I3 - I2) * w[1] ** 2  # 2E I₃ − G²
    d1 = I2 * (I2 - I1) * w[1] ** 2 + I3 * (I3 - I1) * w[2] ** 2  # G² − 2E I₁
    d2 = I1 * (I1 - I2) * w[0] ** 2 + I3 * (I3 - I2) * w[2] ** 2  # G² − 2E I₂
    a1 = np.sqrt(d3 / (I1 * (I3 - I1)))
    a2 = np.sqrt(d3 / (I2 * (I3 - I2))) if I3 != I2 else 0.0
    a3 = np.sqrt(d1 / (I3 * (I3 - I1)))
    if I2 == I1:
        m = 0.0
    else:
        m = float(np.clip(1.0 - (I3 - I1) * d2 / ((I3 - I2) * d1), 0.0, 1.0))
    a3 = np.copysign(a3, w[2])
    if m == 1.0:  # on the separatrix cn = dn = sech > 0: w₁ keeps its sign
        a1 = np.copysign(a1, w[0])
    phi0 = np.arctan2(w[1] / a2 if a2 > 0 else 0.0, w[0] / a1)
    u0 = ellipkinc(phi0, m)
    lam = (I3 - I2) * a2 * a3 / (I1 * a1)
    sn, cn, dn, _ = ellipj(u0 + lam * t, m)
    wp = np.stack([a1 * cn, a2 * sn, a3 * dn], axis=-1)
    out = np.empty_like(wp)
    out[:, perm] = sgn * wp
    return out
