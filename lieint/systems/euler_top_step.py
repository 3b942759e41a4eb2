"""One short step of the exact free-top flow, to the relative precision of its increment.

:func:`~lieint.systems.euler_top_attitude.euler_top_rotation_minus_identity` evaluates the
increment ``K = Q(h) − I`` from the elliptic functions at the new phase: its entries, of size
``h|w|``, carry an error of ε *absolute*, because the new momentum ``Π(h)`` is an O(1) quantity
known to ε. Stepped over 10⁴ steps that is the dominant error: a direction error ε·G of the new
momentum moves the gap ``G² − 2EI₁`` — which sets the elliptic frequency — by ε·G²/(G² − 2EI₁)
relative (measured 7.4e-16 a step, 9× the 8e-17 of rounding the new state, for Hairer–Vilmart's
body (0.6, 0.8, 1), Π = (1.8, 0.4, −0.9)); the frequency wanders and the phase error of the run
grows faster than t (fitted t^1.8 over T = 1000).

Here the increment is formed from small quantities only (principal frame relabelled as in
:mod:`lieint.systems.euler_top_exact`, ``w = (a₁ cn u, a₂ sn u, a₃ dn u)``):

* the state's own ``(cn u₀, sn u₀, dn u₀) = (w₁/a₁, w₂/a₂, w₃/a₃)`` and the addition theorems
  (DLMF 22.8.1–3) give ``Δsn, Δcn, Δdn`` over ``v = λh`` from ``sn v``, ``cn v − 1 =
  −sn²v/(1 + cn v)`` and ``dn v − 1 = −m sn²v/(1 + dn v)``: ``ΔΠ = Π(h) − Π₀`` to its own
  relative precision, with no phase to decode;
* the precession angle over the step, ``ψ = ∫₀ʰ G (Π₂²/I₂ + Π₃²/I₃)/(Π₂² + Π₃²) dt``, by
  Gauss–Legendre quadrature of its positive integrand (the closed form subtracts two incomplete
  integrals of the third kind of size O(1));
* the frame of :mod:`lieint.systems.euler_top_attitude`, ``U(n) = Rx(π/2) Rz(π/2 − a) Rx(−b)``
  with ``n = (cos a, sin a cos b, sin a sin b)``, turns ``Q = U(n₀)ᵀ Rz(ψ) U(n₁)`` into
  ``Q = Rx(b₀) [Rot((cos a₀, sin a₀, 0), ψ) Rz(a₀ − a₁)] Rx(−b₀) · Rx(b₀ − b₁)``: three small
  rotations, the angle differences formed from ``Δn`` (cross and dot products, no subtraction
  of angles).

The amplitudes ``a_k`` come from the exact gaps ``G² − 2EI_k`` (rational in the doubles) in
extended precision, and the small quantities are combined in extended precision, so their
roundings do not repeat from step to step. The result, mapped by
:func:`~lieint.systems.euler_top_attitude.rotation_minus_identity`, is K to a few ε‖K‖.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from .euler_top_attitude import euler_top_rotation_minus_identity, rotation_minus_identity
from .euler_top_exact import _setup, jacobi_elliptic

__all__ = ["SHORT_PHASE", "euler_top_step_minus_identity"]

#: steps with ``|λh|`` up to this use the addition theorems (longer steps: the closed form);
#: below K (≥ π/2) ``1 + cn v`` stays away from 0
SHORT_PHASE = 1.0

_LD = np.longdouble


def _gauss(n: int):
    """Gauss–Legendre nodes and weights on [0, 1] (long double)."""
    x, w = np.polynomial.legendre.leggauss(n)
    return (0.5 * (1.0 + x)).astype(_LD), (0.5 * w).astype(_LD)


#: the quadrature rules of ψ, tried in turn until two agree to round-off
_RULES = [_gauss(n) for n in (16, 32, 64)]


def _ld(q: Fraction):
    return _LD(q.numerator) / _LD(q.denominator)


def _axis_quaternion(axis, angle):
    """The quaternion of the rotation by ``angle`` about the unit vector ``axis`` (long double)."""
    half = _LD(0.5) * angle
    return np.concatenate([[np.cos(half)], np.sin(half) * np.asarray(axis, dtype=_LD)])


def _product(p, q):
    ps, pv, qs, qv = p[0], p[1:], q[0], q[1:]
    return np.concatenate([[ps * qs - pv @ qv], ps * qv + qs * pv + np.cross(pv, qv)])


def euler_top_step_minus_identity(moments, Pi, h: float) -> np.ndarray:
    """``Q(h) − I`` for the body increment of the free 3D top from the momentum Π (principal frame).

    Parameters
    ----------
    moments : array_like, shape (3,)
        Principal moments of inertia.
    Pi : array_like, shape (3,)
        The body angular momentum in the same frame.
    h : float
        The step (any sign).

    Returns
    -------
    ndarray, shape (3, 3)
        ``K`` with ``I + K`` orthogonal to ``ε‖K‖``; to a few ε‖K‖ of the exact increment when
        ``|λh| ≤`` :data:`SHORT_PHASE` (else, and for the degenerate bodies I₂ = I₃, the closed
        form of :func:`~lieint.systems.euler_top_attitude.euler_top_rotation_minus_identity`).
    """
    I = np.asarray(moments, dtype=float)
    Pi = np.asarray(Pi, dtype=float)
    w = Pi / I
    e = _setup(I, w)
    if e is None or e.a[1] == 0.0 or not abs(e.lam * h) <= SHORT_PHASE:
        return euler_top_rotation_minus_identity(I, w, [h])[0]
    perm = e.perm
    D = np.eye(3)[:, perm]
    Ip = I[perm]
    P0 = (e.sgn * Pi[perm]).astype(_LD)  # the state's momentum, relabelled (signs flip exactly)
    # the gaps G² − 2EI₁, G² − 2EI₂, 2EI₃ − G² exactly, from the state's momentum
    Iq = [Fraction(float(x)) for x in Ip]
    Pq = [Fraction(float(x)) for x in e.sgn * Pi[perm]]

    def gap(k):
        return sum(Pq[i] * Pq[i] * (Iq[i] - Iq[k]) / Iq[i] for i in range(3))

    d1, d2, d3 = gap(0), gap(1), -gap(2)
    a = [
        np.copysign(np.sqrt(_ld(d3 * Iq[0] / (Iq[2] - Iq[0]))), e.a[0]),  # I₁a₁ = (I₁ d₃/(I₃ − I₁))^{1/2}
        np.sqrt(_ld(d3 * Iq[1] / (Iq[2] - Iq[1]))),
        np.copysign(np.sqrt(_ld(d1 * Iq[2] / (Iq[2] - Iq[0]))), e.a[2]),
    ]  # a[k] = I_k a_k: Π = (a[0] cn, a[1] sn, a[2] dn)
    p = _ld((Iq[2] - Iq[0]) * d2 / ((Iq[2] - Iq[1]) * d1)) if Iq[1] != Iq[0] else _LD(1.0)
    m = _LD(1.0) - p
    c0, s0, d0 = P0[0] / a[0], P0[1] / a[1], P0[2] / a[2]

    def increment(v):
        """ΔΠ over the phases v (array), by the addition theorems."""
        sv, cv, dv = (np.asarray(x, dtype=_LD) for x in jacobi_elliptic(np.asarray(v, dtype=float), e.p))
        sv2 = sv * sv
        cv1, dv1 = -sv2 / (1 + cv), -m * sv2 / (1 + dv)  # cn v − 1, dn v − 1
        ms = m * s0 * s0 * sv2
        den = 1 - ms
        ds = (s0 * (cv1 * dv + dv1 + ms) + sv * c0 * d0) / den
        dc = (c0 * (cv1 + ms) - s0 * d0 * sv * dv) / den
        dd = (d0 * (dv1 + ms) - m * s0 * c0 * sv * cv) / den
        return np.stack([a[0] * dc, a[1] * ds, a[2] * dd], axis=-1)

    lam_h = e.lam * h
    G0 = np.sqrt(P0 @ P0)
    i1, i2 = _LD(1.0) / _ld(Iq[1]), _LD(1.0) / _ld(Iq[2])

    def precession(rule):
        nodes, weights = rule
        P = increment(lam_h * nodes.astype(float)) + P0  # Π at the nodes
        q2, q3 = P[:, 1] ** 2, P[:, 2] ** 2
        return _LD(h) * G0 * np.sum(weights * (q2 * i1 + q3 * i2) / (q2 + q3))

    # ψ̇ has poles where Π₂² + Π₃² = G² − Π₁² vanishes, near the real axis when the momentum comes
    # close to the frame's singular direction ±e₁: the rule is refined until two agree
    psi = precession(_RULES[0])
    for rule in _RULES[1:]:
        finer = precession(rule)
        converged = abs(finer - psi) <= 4 * np.finfo(float).eps * abs(finer)
        psi = finer
        if converged:
            break
    else:
        return euler_top_rotation_minus_identity(I, w, [h])[0]
    dP = increment(np.array([lam_h]))[0]
    P1 = P0 + dP
    G1 = np.sqrt(P1 @ P1)
    n0 = P0 / G0
    dn = dP / G1 - P0 * ((2 * (P0 @ dP) + dP @ dP) / (G0 + G1)) / (G0 * G1)  # n₁ − n₀
    n1 = n0 + dn
    rho0, rho1 = np.hypot(n0[1], n0[2]), np.hypot(n1[1], n1[2])
    drho = (dn[1] * (2 * n0[1] + dn[1]) + dn[2] * (2 * n0[2] + dn[2])) / (rho0 + rho1)
    da = np.arctan2(n0[0] * drho - rho0 * dn[0], n0[0] * n1[0] + rho0 * rho1)  # a₁ − a₀
    db = np.arctan2(n0[1] * dn[2] - n0[2] * dn[1], n0[1] * n1[1] + n0[2] * n1[2])  # b₁ − b₀
    r0 = np.hypot(n0[0], rho0)
    inner = _product(_axis_quaternion([n0[0] / r0, rho0 / r0, 0], psi), _axis_quaternion([0, 0, 1], -da))
    cb, sb = n0[1] / rho0, n0[2] / rho0  # Rx(b₀) turns the inner rotation's axis
    x, y, z = inner[1:]
    q = _product(np.array([inner[0], x, cb * y - sb * z, sb * y + cb * z]), _axis_quaternion([1, 0, 0], -db))
    # back to the principal frame: the vector part moves by det(D)·D
    v = np.linalg.det(D) * (D @ q[1:].astype(float))
    return rotation_minus_identity(np.concatenate([[float(q[0])], v])[None, :])[0]
