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

from ..groups.bivectors import hat
from .euler_top_exact import _setup, elliptic_functions_of_phase, energy_momentum_gaps, jacobi_elliptic

__all__ = ["euler_top_rotation", "euler_top_rotation_minus_identity", "rotation_minus_identity"]


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


def _quaternion_product(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``p ⊗ q`` of quaternions ``(s, v)`` (scalar first, batched): the rotation of ``R(p) R(q)``."""
    ps, pv, qs, qv = p[..., :1], p[..., 1:], q[..., :1], q[..., 1:]
    scalar = ps * qs - np.sum(pv * qv, axis=-1, keepdims=True)
    return np.concatenate([scalar, ps * qv + qs * pv + np.cross(pv, qv)], axis=-1)


def _axis_quaternion(axis: int, angle: np.ndarray) -> np.ndarray:
    """The quaternion of the rotation by ``angle`` about ``e_axis`` (batched)."""
    angle = np.asarray(angle, dtype=float)
    q = np.zeros(angle.shape + (4,))
    q[..., 0] = np.cos(0.5 * angle)
    q[..., 1 + axis] = np.sin(0.5 * angle)
    return q


def _frame_quaternion(Pi: np.ndarray) -> np.ndarray:
    """The quaternion of ``U`` with rows ``u₁ = (e₁ − n₁n)/ρ``, ``u₂ = n × u₁``, ``u₃ = n``, ``n = Π/|Π|``.

    With ``n = (cos a, sin a cos b, sin a sin b)`` (``ρ = sin a > 0``: n stays away from ±e₁),
    ``U = Rx(π/2) Rz(π/2 − a) Rx(−b)``: ``U n = e₃`` and ``U u₁ = e₁``.
    """
    a = np.arctan2(np.hypot(Pi[..., 1], Pi[..., 2]), Pi[..., 0])
    b = np.arctan2(Pi[..., 2], Pi[..., 1])
    q = _quaternion_product(_axis_quaternion(0, np.full(a.shape, 0.5 * np.pi)), _axis_quaternion(2, 0.5 * np.pi - a))
    return _quaternion_product(q, _axis_quaternion(0, -b))


def rotation_minus_identity(q: np.ndarray) -> np.ndarray:
    """``R(q) − I`` for quaternions q (any norm, batched), orthogonal to the round-off of its own size.

    ``R(q) = H²`` with H the rotation by half the angle, ``H = cay(2ĝ)``, ``g = v/(|q| + s)``
    the Gibbs vector ``tan(θ/4) e`` of the quarter angle (q's sign chosen with ``s ≥ 0``, so
    ``|g| ≤ 1`` for every rotation). The Cayley map is rational, ``H − I = 2(ĝ + ĝ²)/(1 + |g|²)``:
    ``K = R − I = 2(H − I) + (H − I)²`` keeps ``K + Kᵀ + KᵀK`` at ``ε‖K‖`` whatever q's norm,
    where ``I + K`` formed from three separately rounded frames misses orthogonality by ε —
    an error that moves ``|Π|`` and the energy by ε every step.
    """
    q = np.where(q[..., :1] < 0.0, -q, q)
    g = q[..., 1:] / (np.linalg.norm(q, axis=-1, keepdims=True) + q[..., :1])
    G = hat(g)
    half = 2.0 * (G + G @ G) / (1.0 + np.sum(g * g, axis=-1))[..., None, None]
    return 2.0 * half + half @ half


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
    return np.eye(3) + euler_top_rotation_minus_identity(moments, w0, t)


def euler_top_rotation_minus_identity(moments, w0, t) -> np.ndarray:
    """``Q(t) − I`` for the increments of :func:`euler_top_rotation`, without forming ``Q(t)``.

    ``Q`` is assembled as the product of the quaternions of its three rotations and turned into a
    matrix by :func:`rotation_minus_identity`: ``K = Q − I`` keeps its small entries (a short
    step) to their own relative precision and ``I + K`` is orthogonal to ``ε‖K‖``. Stepping
    with it (:meth:`lieint.EulerTop.act_near_identity`) moves ``|Π|`` and the energy only by the
    rounding of the new state.

    Parameters and the shape of the result are those of :func:`euler_top_rotation`.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    I = np.asarray(moments, dtype=float)
    w0 = np.asarray(w0, dtype=float)
    e = _setup(I, w0)
    if e is None:  # a steady rotation about w0
        speed = float(np.linalg.norm(w0))
        axis = w0 / speed if speed > 0 else np.zeros(3)
        half = 0.5 * speed * t
        return rotation_minus_identity(np.concatenate([np.cos(half)[:, None], np.sin(half)[:, None] * axis], axis=-1))
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
    # Q̃ = U₀ᵀ Rz(ψ) U(t) as the product of quaternions, and Q = D Q̃ Dᵀ: the vector part moves
    # by det(D)·D (D is a signed relabelling of the axes)
    conj = np.array([1.0, -1.0, -1.0, -1.0])
    q = _quaternion_product(_frame_quaternion(Pi0) * conj, _axis_quaternion(2, psi))
    q = _quaternion_product(q, _frame_quaternion(Pi))
    q = np.concatenate([q[:, :1], np.linalg.det(D) * q[:, 1:] @ D.T], axis=-1)
    return rotation_minus_identity(q)
