"""The exact attitude of the free 3D top (after Celledoni, Fassò, Säfström & Zanna 2008).

In the principal frame the body momentum is ``Π = I w`` with ``w(t)`` from
:mod:`lieint.systems.euler_top_exact`, relabelled there by a permutation so that
``I₁ < I₂ < I₃`` (or ``I₁ = I₂``) and the motion circles axis 3: ``w = (a₁ cn u, a₂ sn u, a₃ dn u)``,
``u = u₀ + λt``. The space momentum ``m = RΠ`` is constant, ``|m| = G``. Write

    R(t) = S · exp(ψ(t) ê₃) · U(t),

with ``U(t)`` the rotation whose rows are ``u₁ = (e₁ − n₁ n)/ρ``, ``u₂ = n × u₁``, ``u₃ = n``
(``n = Π/G``, ``ρ = (n₂² + n₃²)^{1/2}``), so that ``U n = e₃``, and S constant. ``Ṙ = R ŵ``
gives ``ψ̇ = G (2E − Π₁²/I₁)/(G² − Π₁²)``. The singular direction of U is ``±e₁``, which the
motion never approaches: ``G² − Π₁² ≥ I₃(G² − 2EI₁)/(I₃ − I₁) > 0`` on both sides of and on
the separatrix. With ``Π₁² = I₁² a₁² (1 − sn²u)``::

    ψ(t) = (G/I₁) t − G (I₃ − I₁)/(I₁ I₃ λ) · [Π(ν; am u | m) − Π(ν; am u₀ | m)],
    ν = −I₁ (2E I₃ − G²) / (I₃ (G² − 2E I₁)) ≤ 0,  (ν ≤ 0 in either ordering of the axes)

the incomplete elliptic integral of the third kind ``Π(ν; φ | m) = ∫₀^φ dθ /((1 − ν sin²θ)
(1 − m sin²θ)^{1/2})``. It is evaluated with Carlson's symmetric integrals (``scipy.special.elliprf``,
``elliprj``): ``u = 2jK + r``, ``|r| ≤ K``, ``Π(ν; am u) = 2j Π(ν|m) + s R_F(c², d², 1)
+ (ν/3) s³ R_J(c², d², 1, 1 − ν s²)`` with ``(s, c, d) = (sn r, cn r, dn r)`` from the Landen
evaluation of :func:`~lieint.systems.euler_top_exact.jacobi_elliptic`, so that ``d² = 1 − m s²``
and the complementary parameter ``p = 1 − m`` are never formed by cancellation near the
separatrix. The large parts, ``(G/I₁)t`` and the ``2jΠ(ν|m)`` of the whole half periods, are
added and reduced modulo 2π from constants carried to ~32 digits
(:mod:`lieint.systems._phase`): in doubles ψ, of size 10³ over t = 1000, would carry an error
``|ψ|·ε ≈ 2e-13``. This module is a reference for tests and a building block of the ``exact_flow``
method.
"""

from __future__ import annotations

import numpy as np

from .euler_top_exact import _setup, elliptic_functions_of_phase, energy_momentum_gaps, jacobi_elliptic

__all__ = ["euler_top_rotation"]


def _third_kind(nu: float, u: np.ndarray, p: float) -> np.ndarray:
    """``Π(ν; am u | 1 − p)`` for real u (any size), ν ≤ 0."""
    from scipy.special import ellipkm1

    u = np.asarray(u, dtype=float)
    if p == 0.0:  # on the separatrix am is bounded (K = ∞): no reduction
        return _incomplete_third_kind(nu, u, p)
    K = float(ellipkm1(p))
    j = np.round(u / (2.0 * K))
    return 2.0 * j * _complete_third_kind(nu, p) + _incomplete_third_kind(nu, u - 2.0 * K * j, p)


def _complete_third_kind(nu: float, p: float) -> float:
    """``Π(ν | 1 − p) = R_F(0, p, 1) + (ν/3) R_J(0, p, 1, 1 − ν)``."""
    from scipy.special import elliprf, elliprj

    return float(elliprf(0.0, p, 1.0) + (nu / 3.0 * elliprj(0.0, p, 1.0, 1.0 - nu) if nu != 0.0 else 0.0))


def _incomplete_third_kind(nu: float, r: np.ndarray, p: float) -> np.ndarray:
    """``Π(ν; am r | 1 − p)`` for ``|r| ≤ K``: ``s R_F(c², d², 1) + (ν/3) s³ R_J(c², d², 1, 1 − ν s²)``."""
    from scipy.special import elliprf, elliprj

    s, c, d = jacobi_elliptic(r, p)
    c2, d2 = c * c, d * d
    incomplete = s * elliprf(c2, d2, 1.0)
    if nu != 0.0:
        incomplete = incomplete + nu / 3.0 * s**3 * elliprj(c2, d2, 1.0, 1.0 - nu * s * s)
    return incomplete


def _frame(Pi: np.ndarray) -> np.ndarray:
    """``U`` with rows ``u₁ = (e₁ − n₁n)/ρ``, ``u₂ = n × u₁``, ``u₃ = n`` for ``n = Π/|Π|`` (batched)."""
    n = Pi / np.linalg.norm(Pi, axis=-1, keepdims=True)
    rho = np.hypot(n[..., 1], n[..., 2])
    # e₁ − n₁ n = (1 − n₁², −n₁n₂, −n₁n₃) = (ρ², −n₁n₂, −n₁n₃)
    u1 = np.stack([rho * rho, -n[..., 0] * n[..., 1], -n[..., 0] * n[..., 2]], axis=-1) / rho[..., None]
    u2 = np.cross(n, u1)
    return np.stack([u1, u2, n], axis=-2)


def euler_top_rotation(moments, w0, t) -> np.ndarray:
    """The body increments ``Q(t) = R(0)ᵀ R(t)`` of the free 3D top in its principal frame.

    Parameters
    ----------
    moments : array_like, shape (3,)
        Principal moments of inertia ``I_i``: any order, any positive values (the triangle
        inequality of a mass distribution is not needed).
    w0 : array_like, shape (3,)
        Initial body angular velocity in the same frame.
    t : array_like, shape (m,)
        Times since the initial instant (any sign).

    Returns
    -------
    ndarray, shape (m, 3, 3)
        ``Q(t) ∈ SO(3)`` solving ``Q̇ = Q ŵ(t)``, ``Q(0) = I``; the attitude is ``R(t) = R(0) Q(t)``.
    """
    from ..groups.bivectors import hat
    from ..groups.so import so3_exp

    t = np.atleast_1d(np.asarray(t, dtype=float))
    I = np.asarray(moments, dtype=float)
    w0 = np.asarray(w0, dtype=float)
    e = _setup(I, w0)
    if e is None:  # a steady rotation
        return so3_exp(hat(t[:, None] * w0))
    D = np.eye(3)[:, e.perm]
    I1, I2, I3 = I[e.perm]
    a1, a2, a3 = e.a
    wp0 = e.sgn * w0[e.perm]
    Pi0 = np.array([I1, I2, I3]) * wp0
    G = float(np.linalg.norm(Pi0))
    d1, _, d3 = energy_momentum_gaps((I1, I2, I3), wp0)  # G² − 2E I₁, 2E I₃ − G², exactly rounded
    # u = u₀ + λt = 2jK + r and ψ mod 2π from constants carried to ~32 digits: in doubles the
    # long phases λt, (G/I₁)t and j·2K·(…) would each carry an error ~ ε·|λt| (docs/theory.md §11)
    phase, j, r, sn, cn, dn = elliptic_functions_of_phase(e, moments, w0, t, attitude=d3 != 0.0)
    Pi = np.stack([I1 * a1 * cn, I2 * a2 * sn, I3 * a3 * dn], axis=-1)
    rest = np.zeros_like(t)
    if d3 != 0.0:  # (both d3 and d1 are negative when the axes are relabelled in descending order)
        nu = -I1 * d3 / (I3 * d1)
        c = G * (I3 - I1) / (I1 * I3 * e.lam)
        # Π(ν; am u) = 2jΠ(ν|m) + Π(ν; am r): the 2jΠ(ν|m) part is κj, reduced in reduce_psi
        in_period = _incomplete_third_kind(nu, r, e.p)
        rest = -c * (in_period - _third_kind(nu, np.array([e.u0]), e.p)[0])
    psi = phase.reduce_psi(t, j, rest)
    c, s = np.cos(psi), np.sin(psi)
    Rz = np.zeros((t.size, 3, 3))
    Rz[:, 0, 0] = Rz[:, 1, 1] = c
    Rz[:, 0, 1], Rz[:, 1, 0] = -s, s
    Rz[:, 2, 2] = 1.0
    U0 = _frame(Pi0)
    return D @ U0.T @ Rz @ _frame(Pi) @ D.T
