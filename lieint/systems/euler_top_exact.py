"""Exact body angular velocity of the 3D Euler top in Jacobi elliptic functions (docs/theory.md §2).

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

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["euler_top_angular_velocity", "euler_top_flip_times", "jacobi_elliptic"]


def jacobi_elliptic(u, p):
    """``sn, cn, dn`` of ``(u | m)`` with the parameter given by its complement ``p = 1 − m``.

    ``scipy.special.ellipj`` takes m, whose rounding alone destroys ``1 − m`` near 1, and it
    switches to a hyperbolic approximation there that is wrong beyond the quarter period
    (measured against mpmath at ``p = 1e-16``: error 0.24 at ``u = 2K − 1`` and 9e8 at
    ``u = 3K``). Here the descending Landen transformation (A&S 16.12) is applied while
    ``p < 1/2``, each step computed from ``√p`` alone::

        √μ = (1 − √p)/(1 + √p),  p_μ = 4√p/(1 + √p)²,  v = u/(1 + √μ),
        sn u = (1 + √μ) sn v / (1 + √μ sn²v),  cn u = cn v dn v / (1 + √μ sn²v),
        dn u = (cn²v + sn²v · 2√p/(1 + √p)) / (1 + √μ sn²v)   [= (1 − √μ sn²v)/(…), no cancellation]

    until the parameter is small enough for ``ellipj``. Agrees with mpmath to 3e-15 for
    ``p = 1e-16`` up to ``u = 3K``.
    """
    from scipy.special import ellipj  # lazy: keeps `import lieint` fast

    u = np.asarray(u, dtype=float)
    if p == 0.0:  # m = 1: the separatrix itself
        return np.tanh(u), 1.0 / np.cosh(u), 1.0 / np.cosh(u)
    if p >= 0.5:
        return tuple(ellipj(u, 1.0 - p)[:3])
    kp = np.sqrt(p)
    s = (1.0 - kp) / (1.0 + kp)
    sn1, cn1, dn1 = jacobi_elliptic(u / (1.0 + s), 4.0 * kp / (1.0 + kp) ** 2)
    den = 1.0 + s * sn1 * sn1
    return (1.0 + s) * sn1 / den, cn1 * dn1 / den, (cn1 * cn1 + sn1 * sn1 * 2.0 * kp / (1.0 + kp)) / den


def _initial_argument(w, a1, a2, a3, m, p) -> float:
    """u₀ with ``(cn, sn, dn)(u₀) = (w₁/a₁, w₂/a₂, w₃/a₃)``.

    ``|u₀| = F(φ|m)`` for ``cn u₀ ≥ 0`` and ``2K − F(φ|m)`` for ``cn u₀ < 0``, with
    ``φ = atan2(|sn|, |cn|) ∈ [0, π/2]`` and the sign of sn. F is Carlson's
    ``F(φ|m) = sin φ · R_F(cos²φ, cos²φ + p sin²φ, 1)`` and ``K = R_F(0, p, 1)``: the argument
    ``1 − m sin²φ`` is formed from the complementary parameter p, never from the rounded m.
    Near the separatrix (p → 0, φ → π/2) ``F(·|m)`` of scipy, which takes m, is off by
    ``~ε/p`` (measured: 4e-12 in u₀ at p = 4e-6, 4e-9 at p = 1e-10, through an earlier
    arcsin-based formula); this form is accurate to a few ulps of u₀ for every p.
    """
    from scipy.special import elliprf

    sn0 = w[1] / a2 if a2 > 0 else 0.0
    cn0 = w[0] / a1
    rho = np.hypot(sn0, cn0)
    s, c = abs(sn0) / rho, abs(cn0) / rho
    F = s * float(elliprf(c * c, c * c + p * s * s, 1.0))
    if cn0 < 0.0:
        F = 2.0 * float(elliprf(0.0, p, 1.0)) - F
    return float(np.copysign(F, sn0))


def energy_momentum_gaps(moments, w) -> tuple[float, float, float]:
    """``G² − 2E I₁``, ``G² − 2E I₂``, ``2E I₃ − G²`` correctly rounded from the doubles given.

    Each is formed from the components (``G² − 2E I_k = Σ_i I_i (I_i − I_k) w_i²``, the k-th
    term cancelling exactly) in exact rational arithmetic: near the separatrix ``G² − 2E I₂``
    is a small difference of O(1) terms, and floating-point evaluation would leave it — and
    the complementary parameter ``p = 1 − m`` and the period with it — only ``ε/p`` accurate
    (measured: 1e-10 phase errors over t = 1000 at ``p ≈ 1e-6``).
    """
    from fractions import Fraction

    I = [Fraction(float(x)) for x in moments]
    w2 = [Fraction(float(x)) ** 2 for x in w]

    def gap(k):
        return float(sum(I[i] * (I[i] - I[k]) * w2[i] for i in range(3)))

    return gap(0), gap(1), -gap(2)


def _parity(perm) -> float:
    return float(np.linalg.det(np.eye(3)[:, perm]))


@dataclass(frozen=True)
class _Elliptic:
    """``w_perm = sgn · (a₁ cn u, a₂ sn u, a₃ dn u)``, ``u = u₀ + λt``, parameter ``1 − p``."""

    perm: np.ndarray
    sgn: float
    a: tuple[float, float, float]
    u0: float
    lam: float
    p: float


def _setup(moments, w0) -> _Elliptic | None:
    I = np.asarray(moments, dtype=float)
    w0 = np.asarray(w0, dtype=float)
    # Fixed points: (I w) × w = 0 (w on a principal axis, or in an eigenspace of I).
    if np.linalg.norm(np.cross(I * w0, w0)) <= 1e-15 * np.max(I) * max(np.dot(w0, w0), 1e-300):
        return None
    asc = np.argsort(I, kind="stable")
    # G² − 2E I₂ = Σ I_i (I_i − I₂) w_i² decides which end axis the motion circles.
    perm = asc if np.sum(I * (I - I[asc[1]]) * w0**2) > 0 else asc[::-1]
    sgn = _parity(perm)
    I1, I2, I3 = I[perm]
    w = sgn * w0[perm]
    d1, d2, d3 = energy_momentum_gaps((I1, I2, I3), w)
    a1 = np.sqrt(d3 / (I1 * (I3 - I1)))
    a2 = np.sqrt(d3 / (I2 * (I3 - I2))) if I3 != I2 else 0.0
    a3 = np.copysign(np.sqrt(d1 / (I3 * (I3 - I1))), w[2])
    # complementary parameter p = 1 − m = (I₃ − I₁)(G² − 2E I₂)/((I₃ − I₂)(G² − 2E I₁)), kept
    # accurate (near the separatrix p ~ distance², far below the round-off of m itself)
    p = 1.0 if I2 == I1 else float(np.clip((I3 - I1) * d2 / ((I3 - I2) * d1), 0.0, 1.0))
    if p == 0.0:  # exactly on the separatrix: cn = dn = sech > 0, w₁ keeps its sign
        a1 = np.copysign(a1, w[0])
    u0 = _initial_argument(w, a1, a2, a3, 1.0 - p, p)
    lam = (I3 - I2) * a2 * a3 / (I1 * a1)
    return _Elliptic(perm, sgn, (float(a1), float(a2), float(a3)), u0, float(lam), p)


def elliptic_functions_of_phase(e: _Elliptic, moments, w0, t: np.ndarray, attitude: bool = False):
    """``(phase, j, r, sn, cn, dn)`` of ``u = u₀ + λt = 2jK + r`` from the reduced phase r.

    ``r`` (``|r| ≤ K``) is formed from λ and 2K known to ~32 digits with error-free products
    and sums (:mod:`lieint.systems._phase`): in double precision ``u`` itself would carry
    ``|λt|·ε`` (≈ 1e-13 over t = 1000), an error growing with t. Then
    ``sn u = (−1)^j sn r``, ``cn u = (−1)^j cn r``, ``dn u = dn r`` (the half period 2K
    flips sn and cn). ``phase`` is the :class:`~lieint.systems._phase.LongPhase` (with κ
    when ``attitude``), for the precession angle.
    """
    from ._phase import long_phase

    I = np.asarray(moments, dtype=float)[e.perm]
    w = e.sgn * np.asarray(w0, dtype=float)[e.perm]
    phase = long_phase(I, w, e.lam, attitude)
    j, r = phase.reduce_u(e.u0, t)
    sn, cn, dn = jacobi_elliptic(r, e.p)
    sign = 1.0 - 2.0 * np.mod(j, 2.0)
    return phase, j, r, sign * sn, sign * cn, dn


def euler_top_angular_velocity(moments, w0, t) -> np.ndarray:
    """Body angular velocity ``w(t)`` of the free 3D top in its principal frame.

    Parameters
    ----------
    moments : array_like, shape (3,)
        Principal moments of inertia ``I_i``: any order, any positive values (the triangle
        inequality ``I_i ≤ I_j + I_k`` of a mass distribution is not needed).
    w0 : array_like, shape (3,)
        Initial body angular velocity in the same principal frame.
    t : array_like, shape (m,)
        Times since the initial instant.

    Returns
    -------
    ndarray, shape (m, 3)
        ``w(t)`` solving ``I ẇ = (I w) × w``.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    e = _setup(moments, w0)
    if e is None:
        return np.broadcast_to(np.asarray(w0, dtype=float), (t.size, 3)).copy()
    sn, cn, dn = elliptic_functions_of_phase(e, moments, w0, t)[3:]
    a1, a2, a3 = e.a
    wp = np.stack([a1 * cn, a2 * sn, a3 * dn], axis=-1)
    out = np.empty_like(wp)
    out[:, e.perm] = e.sgn * wp
    return out


def euler_top_flip_times(moments: ArrayLike, w0: ArrayLike, t_end: float) -> np.ndarray:
    """Times in ``(0, t_end]`` where the middle-axis component of w changes sign (the flips).

    ``w₂ = a₂ sn(u₀ + λt)`` vanishes at ``u = 2jK``: ``t_j = (2jK − u₀)/λ`` with
    ``K = ellipkm1(p)``, exact even 1e-8 from the separatrix where p ~ 1e-16. A reference for
    event times (the Dzhanibekov flip), computed without any integrator.

    Parameters
    ----------
    moments : array_like, shape (3,)
        Principal moments of inertia ``I_i``: any order, any positive values.
    w0 : array_like, shape (3,)
        Initial body angular velocity in the principal frame.
    t_end : float
        End of the time window.

    Returns
    -------
    ndarray, shape (k,)
        The flip times, increasing; empty when the motion has none (a steady rotation, or a
        motion about an end axis with the middle component never zero).

    Examples
    --------
    >>> import lieint
    >>> lieint.euler_top_flip_times([1.0, 2.0, 3.0], [0.01, 1.0, 0.01], 60.0).round(6).tolist()
    [10.916913, 30.469781, 50.022648]
    """
    from scipy.special import ellipkm1

    e = _setup(moments, w0)
    if e is None or e.p >= 1.0:
        return np.zeros(0)
    K = float(ellipkm1(e.p))
    u_end = e.u0 + e.lam * t_end
    lo, hi = sorted((e.u0, u_end))
    j = np.arange(np.ceil(lo / (2 * K)), np.floor(hi / (2 * K)) + 1)
    t = (2 * K * j - e.u0) / e.lam
    return np.sort(t[(t > 0) & (t <= t_end)])
