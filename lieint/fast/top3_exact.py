"""The stepped exact flow of the free 3D top as a form of the one compiled loop (``exact_flow``).

A step is the numpy path's short step (:mod:`lieint.systems.euler_top_step`), operation for
operation in the same order but for ψ (below), with double-double arithmetic
(:mod:`lieint.fast.double_double`) where that one takes numpy's long double and exact fractions:

* the relabelling, amplitudes' signs, ``λ`` and the parameter ``p`` of
  :func:`lieint.systems.euler_top_exact._setup` (its gaps correctly rounded: here from a
  double-double sum of error-free products);
* the gaps ``G² − 2EI₁, G² − 2EI₂, 2EI₃ − G²`` of the state's momentum (rational in the
  doubles), the amplitudes ``I_k a_k``, ``m`` and ``(cn u₀, sn u₀, dn u₀)`` in double-double;
* ``ΔΠ`` by the addition theorems in double-double, the elliptic functions in double
  (:mod:`lieint.fast.elliptic`, the numpy path's algorithm);
* the precession angle ψ in closed form (:func:`_precession_closed`: the addition theorem of the
  third-kind integral with Carlson's ``R_J`` and ``R_C``, :mod:`lieint.fast.carlson`), where the
  numpy path integrates ψ̇ by Gauss–Legendre rules (16, 32, 64 nodes, refined until two agree).
  The closed form is ``hG/I₃`` plus a rest evaluated in doubles; when the rest is larger than ψ
  itself (``I₃`` the smallest moment and ``Π₃`` small all the step, ψ near ``hG/I₂``) the two
  cancel and ψ is integrated as on the numpy path instead. Against 40-digit quadrature the
  closed form is within ``(1 + 1.7|rest/ψ|)ε|ψ|`` (measured: ≤ 2.7ε|ψ| where it is taken, the
  rules ≤ 2.4ε|ψ|), and the step costs about one FRB_STEP instead of ten;
* the direction change ``n₁ − n₀`` and the angle differences from double-double arguments, the
  three small rotations as quaternions and ``K = Q − I`` from their product
  (:func:`rotation_minus_identity`, orthogonal to ``ε‖K‖``), applied as ``Π₁ = Π + KᵀΠ``,
  ``R₁ = R + RK`` (:meth:`lieint.EulerTop.act_near_identity` on the numpy path).

Two cases differ from the numpy path, by round-off only. A steady rotation (the state on a
principal axis) turns about ``w`` as there. A *long* step, ``|λh| >`` :data:`SHORT_PHASE`, where
the numpy path evaluates the closed form of
:func:`lieint.systems.euler_top_attitude.euler_top_rotation_minus_identity` (its long phases
in 50-digit decimals, not compiled), is taken here as ``n = ⌊|λh|/SHORT_PHASE⌋ + 1`` equal short
steps; a step whose quadrature of ψ (where it is taken) does not settle (the momentum near
the frame's singular direction) is retried with twice as many substeps. The substeps' rotations are composed into
the step's increment.

A step's increment (what dense output interpolates) is the Cayley coordinates ``2q/q₀`` of the
step's rotation; the error norm, projection, ``radius2`` and vector field are the 3D top's
(:mod:`lieint.fast.top3`).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from .carlson import carlson_rc1, carlson_rj
from .double_double import dd_add, dd_div, dd_mul, dd_sqrt, two_prod, two_sum
from .elliptic import TABLE_SIZE, elliptic_table, sn_cn_dn
from .top3 import _newton_schulz, form_embedded, form_error_sum, form_prepare, form_radius2, form_user_field

__all__ = ["NAMESPACES", "SHORT_PHASE", "ExactNumbers", "exact_increments", "numbers", "rotation_minus_identity"]

#: steps with ``|λh|`` up to this are one short step (the numpy path's
#: :data:`lieint.systems.euler_top_step.SHORT_PHASE`); longer ones are cut into equal ones
SHORT_PHASE = 1.0
#: the node counts of the quadrature rules of ψ (where its closed form would cancel), tried in
#: turn until two agree to round-off
RULES = (16, 32, 64)
#: substeps a step may be cut into before it is declared unsolvable
MAX_PIECES = 1 << 12

#: the step's numbers: the body's principal moments (the doubles given: the gaps are rational in
#: them), the Gauss–Legendre nodes and weights on [0, 1] of the rules one after
#: another (``sizes`` their lengths), SHORT_PHASE, MAX_PIECES, and ``cayley`` (the increments
#: are Cayley coordinates: dense output converts them)
ExactNumbers = namedtuple("ExactNumbers", "moments nodes weights sizes short_phase max_pieces cayley")

_EPS = np.finfo(float).eps
# what a short step reports
_DONE, _LONG, _UNSETTLED = 0, 1, 2


def _rules():
    """The rules' nodes ``(1 + x)/2`` and weights ``w/2`` (numpy's Gauss–Legendre), as the
    numpy path takes them (its long-double nodes rounded to doubles, its weights exact)."""
    nodes, weights = [], []
    for n in RULES:
        x, w = np.polynomial.legendre.leggauss(n)
        nodes.append(0.5 * (1.0 + x))
        weights.append(0.5 * w)
    return np.concatenate(nodes), np.concatenate(weights), np.array(RULES, dtype=np.int64)


def numbers(form, layout) -> ExactNumbers:
    """The numbers of the exact flow's :class:`~lieint.fast.forms.MapForm` for the 3D top of ``layout``."""
    return _numbers(layout.moments)


def _numbers(moments) -> ExactNumbers:
    nodes, weights, sizes = _rules()
    return ExactNumbers(np.array(moments, dtype=float), nodes, weights, sizes, SHORT_PHASE, MAX_PIECES, True)


# -- double-double helpers on triples -------------------------------------------------------------


@njit(cache=True)
def _neg(x):
    return -x[0], -x[1]


@njit(cache=True)
def _sub(a, b):
    return dd_add(a[0], a[1], -b[0], -b[1])


@njit(cache=True)
def _add(a, b):
    return dd_add(a[0], a[1], b[0], b[1])


@njit(cache=True)
def _mul(a, b):
    return dd_mul(a[0], a[1], b[0], b[1])


@njit(cache=True)
def _div(a, b):
    return dd_div(a[0], a[1], b[0], b[1])


@njit(cache=True)
def _sqrt(a):
    return dd_sqrt(a[0], a[1])


@njit(cache=True)
def _copysign(a, sign):
    return (-a[0], -a[1]) if (a[0] < 0.0) != (sign < 0.0) else a


@njit(cache=True)
def _dot3(a0, a1, a2, b0, b1, b2):
    return _add(_add(_mul(a0, b0), _mul(a1, b1)), _mul(a2, b2))


# -- the short step ------------------------------------------------------------------------------


@njit(cache=True)
def _relabelling(I, w):
    """``(perm, sgn)`` of :func:`lieint.systems.euler_top_exact._setup`: the axes ascending
    (stable) when ``G² − 2EI₂ > 0``, else descending, and the permutation's parity."""
    i0, i1, i2 = 0, 1, 2  # a stable sort of three
    if I[i1] < I[i0]:
        i0, i1 = i1, i0
    if I[i2] < I[i1]:
        i1, i2 = i2, i1
        if I[i1] < I[i0]:
            i0, i1 = i1, i0
    mid = I[i1]
    side = I[0] * (I[0] - mid) * w[0] ** 2 + I[1] * (I[1] - mid) * w[1] ** 2 + I[2] * (I[2] - mid) * w[2] ** 2
    if not side > 0.0:
        i0, i2 = i2, i0
    # the parity: +1 for the cyclic orders of (0, 1, 2)
    sgn = 1.0 if (i1 - i0) % 3 == 1 else -1.0
    return i0, i1, i2, sgn


@njit(cache=True)
def _rounded_gap(I, w, k):
    """``Σ_i I_i (I_i − I_k) w_i²`` from error-free products and differences, rounded once."""
    sh, sl = 0.0, 0.0
    for i in range(3):
        term = _mul(two_sum(I[i], -I[k]), (I[i], 0.0))
        term = _mul(term, two_prod(w[i], w[i]))
        sh, sl = dd_add(sh, sl, term[0], term[1])
    return sh + sl


@njit(cache=True)
def _exact_gap(I, P, k):
    """``Σ_i P_i² (I_i − I_k)/I_i`` (= ``G² − 2EI_k``) in double-double."""
    sh, sl = 0.0, 0.0
    for i in range(3):
        if i == k:
            continue
        term = _div(_mul(two_prod(P[i], P[i]), two_sum(I[i], -I[k])), (I[i], 0.0))
        sh, sl = dd_add(sh, sl, term[0], term[1])
    return sh, sl


@njit(cache=True)
def _increment(v, table, m, amp, c0, s0, d0):
    """``ΔΠ`` over the phase v by the addition theorems (relabelled frame; double-double)."""
    sv, cv, dv = sn_cn_dn(v, table)
    return _increment_from(sv, cv, dv, m, amp, c0, s0, d0)


@njit(cache=True)
def _increment_from(sv, cv, dv, m, amp, c0, s0, d0):
    """``ΔΠ`` from ``(sn v, cn v, dn v)`` (:func:`_increment`)."""
    sv2 = two_prod(sv, sv)
    cv1 = _neg(_div(sv2, two_sum(1.0, cv)))  # cn v − 1
    dv1 = _neg(_div(_mul(m, sv2), two_sum(1.0, dv)))  # dn v − 1
    ms = _mul(_mul(_mul(m, s0), s0), sv2)
    inv = _div((1.0, 0.0), _sub((1.0, 0.0), ms))
    svd, cvd, dvd = (sv, 0.0), (cv, 0.0), (dv, 0.0)
    ds = _add(_mul(s0, _add(_add(_mul(cv1, dvd), dv1), ms)), _mul(_mul(svd, c0), d0))
    dc = _sub(_mul(c0, _add(cv1, ms)), _mul(_mul(_mul(s0, d0), svd), dvd))
    dd = _sub(_mul(d0, _add(dv1, ms)), _mul(_mul(_mul(_mul(m, s0), c0), svd), cvd))
    return _mul(amp[0], _mul(dc, inv)), _mul(amp[1], _mul(ds, inv)), _mul(amp[2], _mul(dd, inv))


@njit(cache=True)
def _precession(meth, start, size, lam_h, h, G0, table, m, amp, c0, s0, d0, P0, i1, i2):
    """ψ by the rule at ``start`` (``size`` nodes) of the Gauss–Legendre rules (double-double)."""
    th, tl = 0.0, 0.0
    for k in range(start, start + size):
        d = _increment(lam_h * meth.nodes[k], table, m, amp, c0, s0, d0)
        q2 = _add(d[1], (P0[1], 0.0))
        q3 = _add(d[2], (P0[2], 0.0))
        q2 = _mul(q2, q2)
        q3 = _mul(q3, q3)
        f = _div(_add(_mul(q2, i1), _mul(q3, i2)), _add(q2, q3))
        th, tl = _add((th, tl), _mul((meth.weights[k], 0.0), f))
    return _mul(_mul((h, 0.0), G0), (th, tl))


@njit(cache=True)
def _precession_closed(h, G0, m, amp, s0, s1, sv, cv, dv, inv3):
    """ψ in closed form, as ``(hG/I₃, the rest)`` in double-double (the sum is ψ).

    With ``Π = (A₁ cn, A₂ sn, A₃ dn)(u₀ + λt)``, ``Π₂² + Π₃² = A₃²(1 + n sn²)``, ``n = A₁²/A₃²``, so
    ``ψ = hG/I₃ + (G A₁A₂/A₃³) [Z(u₀ + v) − Z(u₀)]``, ``Z(u) = ∫₀ᵘ sn²/(1 + n sn²)``, ``v = λh``
    (the factor is ``G (1/I₂ − 1/I₃) A₂²/(λA₃²)`` with λ's definition put in: no ``I₃ − I₂``
    left to cancel). The addition theorem of the third-kind integral gives
    ``Z(u₀ + v) − Z(u₀) = (s_v³/3) R_J(c_v², d_v², 1, 1 + n s_v²) + atan(√δ X)/√δ``,
    ``X = s₀s₁s_v/Q``, ``Q = 1 + n(s₀² + s₁² + s_v² − m s₀²s₁²s_v²)/2``, ``δ = n(1 + n)(m + n)``
    (s₀, s₁, s_v the sn at u₀, u₀ + v and v; ``|v| ≤ 1 < K`` so ``am v`` is the principal
    angle; ``Q ≥ 1``), and ``atan(√δ X)/√δ = X R_C(1, 1 + δX²)``, well-behaved as δ → 0.
    """
    s0d, s1d = s0[0] + s0[1], s1[0] + s1[1]
    r = (amp[0][0] + amp[0][1]) / (amp[2][0] + amp[2][1])
    n = r * r
    mm = m[0] + m[1]
    a, b, c = s0d * s0d, s1d * s1d, sv * sv
    X = s0d * s1d * sv / (1.0 + 0.5 * n * (a + b + c - mm * a * b * c))
    delta = n * (1.0 + n) * (mm + n)
    Z = sv * c / 3.0 * carlson_rj(cv * cv, dv * dv, 1.0, 1.0 + n * c) + X * carlson_rc1(delta * X * X)
    factor = _mul(_mul(G0, amp[0]), _div(amp[1], _mul(_mul(amp[2], amp[2]), amp[2])))
    return _mul(_mul((h, 0.0), G0), inv3), _mul(factor, (Z, 0.0))


@njit(cache=True)
def _quaternion_product(p0, p1, p2, p3, q0, q1, q2, q3):
    """``p ⊗ q`` (scalar first): the rotation of ``R(p) R(q)``."""
    return (
        p0 * q0 - (p1 * q1 + p2 * q2 + p3 * q3),
        p0 * q1 + q0 * p1 + (p2 * q3 - p3 * q2),
        p0 * q2 + q0 * p2 + (p3 * q1 - p1 * q3),
        p0 * q3 + q0 * p3 + (p1 * q2 - p2 * q1),
    )


@njit(cache=True)
def _setup(I, Pi):
    """:func:`lieint.systems.euler_top_exact._setup` in doubles from the momentum ``Pi``:
    ``(steady, i₀, i₁, i₂, sgn, a₁, a₂, a₃, p, λ)`` — ``steady`` for a fixed point (``(I w) × w = 0``:
    the rest is then unset), the relabelling, the amplitudes (their signs are what the step
    takes), the complementary parameter and λ."""
    w0, w1, w2 = Pi[0] / I[0], Pi[1] / I[1], Pi[2] / I[2]
    c0, c1, c2 = (
        I[1] * w1 * w2 - I[2] * w2 * w1,
        I[2] * w2 * w0 - I[0] * w0 * w2,
        I[0] * w0 * w1 - I[1] * w1 * w0,
    )
    w2n = w0 * w0 + w1 * w1 + w2 * w2
    if math.sqrt(c0 * c0 + c1 * c1 + c2 * c2) <= 1e-15 * max(I[0], I[1], I[2]) * max(w2n, 1e-300):
        return True, 0, 1, 2, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0
    w = np.array([w0, w1, w2])
    i0, i1, i2, sgn = _relabelling(I, w)
    Ir = np.array([I[i0], I[i1], I[i2]])
    wr = np.array([sgn * w[i0], sgn * w[i1], sgn * w[i2]])
    I1, I2, I3 = Ir[0], Ir[1], Ir[2]
    d1, d2, d3 = _rounded_gap(Ir, wr, 0), _rounded_gap(Ir, wr, 1), -_rounded_gap(Ir, wr, 2)
    a1 = math.sqrt(d3 / (I1 * (I3 - I1)))
    a2 = math.sqrt(d3 / (I2 * (I3 - I2))) if I3 != I2 else 0.0
    a3 = math.copysign(math.sqrt(d1 / (I3 * (I3 - I1))), wr[2])
    p = 1.0 if I2 == I1 else min(max((I3 - I1) * d2 / ((I3 - I2) * d1), 0.0), 1.0)
    if p == 0.0:
        a1 = math.copysign(a1, wr[0])
    lam = (I3 - I2) * a2 * a3 / (I1 * a1)
    return False, i0, i1, i2, sgn, a1, a2, a3, p, lam


@njit(cache=True)
def _short_step(I, Pi, h, meth, table):
    """The body increment over one short step from the momentum ``Pi`` (principal frame) as a
    quaternion: ``(status, λ, q₀, q₁, q₂, q₃)``, status :data:`_LONG` when ``|λh|`` exceeds the
    short phase (or the relabelled body is degenerate) and :data:`_UNSETTLED` when the rules
    of ψ did not agree (the quaternion is then meaningless)."""
    steady, i0, i1, i2, sgn, a1, a2, a3, p, lam = _setup(I, Pi)
    if steady:  # a steady rotation about w
        w0, w1, w2 = Pi[0] / I[0], Pi[1] / I[1], Pi[2] / I[2]
        speed = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        half = 0.5 * speed * h
        s = math.sin(half) / speed if speed > 0.0 else 0.0
        return _DONE, 0.0, math.cos(half), s * w0, s * w1, s * w2
    if a2 == 0.0 or not abs(lam * h) <= meth.short_phase:
        return _LONG, lam, 1.0, 0.0, 0.0, 0.0
    Ir = np.array([I[i0], I[i1], I[i2]])
    P0 = np.array([sgn * Pi[i0], sgn * Pi[i1], sgn * Pi[i2]])  # the signs flip exactly
    I1, I2, I3 = Ir[0], Ir[1], Ir[2]
    # the gaps of the state's momentum, the amplitudes I_k a_k, m and (cn, sn, dn)(u₀)
    g1, g2 = _exact_gap(Ir, P0, 0), _exact_gap(Ir, P0, 1)
    g3 = _neg(_exact_gap(Ir, P0, 2))
    I31, I32 = two_sum(I3, -I1), two_sum(I3, -I2)
    amp = (
        _copysign(_sqrt(_div(_mul(g3, (I1, 0.0)), I31)), a1),
        _sqrt(_div(_mul(g3, (I2, 0.0)), I32)),
        _copysign(_sqrt(_div(_mul(g1, (I3, 0.0)), I31)), a3),
    )
    pdd = _div(_mul(I31, g2), _mul(I32, g1)) if I2 != I1 else (1.0, 0.0)
    m = _sub((1.0, 0.0), pdd)
    c0 = _div((P0[0], 0.0), amp[0])
    s0 = _div((P0[1], 0.0), amp[1])
    d0 = _div((P0[2], 0.0), amp[2])
    elliptic_table(p, table)
    lam_h = lam * h
    G0 = _sqrt(_dot3((P0[0], 0.0), (P0[1], 0.0), (P0[2], 0.0), (P0[0], 0.0), (P0[1], 0.0), (P0[2], 0.0)))
    inv2, inv3 = _div((1.0, 0.0), (I2, 0.0)), _div((1.0, 0.0), (I3, 0.0))
    sv, cv, dv = sn_cn_dn(lam_h, table)
    dP = _increment_from(sv, cv, dv, m, amp, c0, s0, d0)
    s1 = _div(_add((P0[1], 0.0), dP[1]), amp[1])
    base, rest = _precession_closed(h, G0, m, amp, s0, s1, sv, cv, dv, inv3)
    psi = _add(base, rest)
    if abs(rest[0]) > abs(psi[0]):
        # ψ much smaller than hG/I₃ (I₃ the smallest moment, Π₃ small all the step): the closed
        # form loses about 1.7ε per unit of |rest/ψ| (measured), so ψ is integrated instead, by
        # the rules refined until two agree (ψ̇ has poles near the real axis when the momentum
        # comes close to the frame's singular direction ±e₁)
        start = 0
        psi = _precession(meth, start, meth.sizes[0], lam_h, h, G0, table, m, amp, c0, s0, d0, P0, inv2, inv3)
        settled = False
        for r in range(1, meth.sizes.shape[0]):
            start += meth.sizes[r - 1]
            finer = _precession(meth, start, meth.sizes[r], lam_h, h, G0, table, m, amp, c0, s0, d0, P0, inv2, inv3)
            gap = _sub(finer, psi)
            psi = finer
            if abs(gap[0] + gap[1]) <= 4.0 * _EPS * abs(finer[0]):
                settled = True
                break
        if not settled:
            return _UNSETTLED, lam, 1.0, 0.0, 0.0, 0.0
    P1 = (_add((P0[0], 0.0), dP[0]), _add((P0[1], 0.0), dP[1]), _add((P0[2], 0.0), dP[2]))
    G1 = _sqrt(_dot3(P1[0], P1[1], P1[2], P1[0], P1[1], P1[2]))
    P0d = ((P0[0], 0.0), (P0[1], 0.0), (P0[2], 0.0))
    n0 = (_div(P0d[0], G0), _div(P0d[1], G0), _div(P0d[2], G0))
    # n₁ − n₀ = ΔP/G₁ − P₀ (2 P₀·ΔP + ΔP·ΔP)/((G₀ + G₁) G₀ G₁)
    t = _mul((2.0, 0.0), _dot3(P0d[0], P0d[1], P0d[2], dP[0], dP[1], dP[2]))
    t = _add(t, _dot3(dP[0], dP[1], dP[2], dP[0], dP[1], dP[2]))
    t = _div(t, _add(G0, G1))
    t = _div(t, _mul(G0, G1))
    dn = (_sub(_div(dP[0], G1), _mul(P0d[0], t)), _sub(_div(dP[1], G1), _mul(P0d[1], t)))
    dn = (dn[0], dn[1], _sub(_div(dP[2], G1), _mul(P0d[2], t)))
    n1 = (_add(n0[0], dn[0]), _add(n0[1], dn[1]), _add(n0[2], dn[2]))
    rho0 = _sqrt(_add(_mul(n0[1], n0[1]), _mul(n0[2], n0[2])))
    rho1 = _sqrt(_add(_mul(n1[1], n1[1]), _mul(n1[2], n1[2])))
    two = (2.0, 0.0)
    drho = _add(_mul(dn[1], _add(_mul(two, n0[1]), dn[1])), _mul(dn[2], _add(_mul(two, n0[2]), dn[2])))
    drho = _div(drho, _add(rho0, rho1))
    y = _sub(_mul(n0[0], drho), _mul(rho0, dn[0]))
    x = _add(_mul(n0[0], n1[0]), _mul(rho0, rho1))
    da = math.atan2(y[0] + y[1], x[0] + x[1])  # a₁ − a₀
    y = _sub(_mul(n0[1], dn[2]), _mul(n0[2], dn[1]))
    x = _add(_mul(n0[1], n1[1]), _mul(n0[2], n1[2]))
    db = math.atan2(y[0] + y[1], x[0] + x[1])  # b₁ − b₀
    r0 = _sqrt(_add(_mul(n0[0], n0[0]), _mul(rho0, rho0)))
    e0, e1 = _div(n0[0], r0), _div(rho0, r0)
    cb, sb = _div(n0[1], rho0), _div(n0[2], rho0)
    # Rot((cos a₀, sin a₀, 0), ψ) Rz(a₀ − a₁), turned by Rx(b₀), then Rx(b₀ − b₁)
    half = 0.5 * (psi[0] + psi[1])
    sp = math.sin(half)
    ca, sa = math.cos(-0.5 * da), math.sin(-0.5 * da)
    q = _quaternion_product(math.cos(half), sp * (e0[0] + e0[1]), sp * (e1[0] + e1[1]), 0.0, ca, 0.0, 0.0, sa)
    cbd, sbd = cb[0] + cb[1], sb[0] + sb[1]
    q = _quaternion_product(
        q[0], q[1], cbd * q[2] - sbd * q[3], sbd * q[2] + cbd * q[3], math.cos(-0.5 * db), math.sin(-0.5 * db), 0.0, 0.0
    )
    # back to the principal frame: the vector part moves by det(D)·D
    v = np.empty(3)
    v[i0], v[i1], v[i2] = sgn * q[1], sgn * q[2], sgn * q[3]
    return _DONE, lam, q[0], v[0], v[1], v[2]


@njit(cache=True)
def rotation_minus_identity(q0, q1, q2, q3, K):
    """``K = R(q) − I`` for a quaternion of any norm (the numpy path's construction: the Cayley
    map of the quarter angle's Gibbs vector, squared), written into the 3 × 3 array K."""
    if q0 < 0.0:
        q0, q1, q2, q3 = -q0, -q1, -q2, -q3
    scale = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3) + q0
    g0, g1, g2 = q1 / scale, q2 / scale, q3 / scale
    f = 2.0 / (1.0 + (g0 * g0 + g1 * g1 + g2 * g2))
    # H − I = f (ĝ + ĝ²), ĝ² = g gᵀ − |g|² I with its diagonal −(g_j² + g_k²) formed without
    # cancellation (as ĝ @ ĝ on the numpy path); K = 2(H − I) + (H − I)²
    h00, h11, h22 = -f * (g1 * g1 + g2 * g2), -f * (g0 * g0 + g2 * g2), -f * (g0 * g0 + g1 * g1)
    h01, h10 = f * (g0 * g1 - g2), f * (g1 * g0 + g2)
    h02, h20 = f * (g0 * g2 + g1), f * (g2 * g0 - g1)
    h12, h21 = f * (g1 * g2 - g0), f * (g2 * g1 + g0)
    H = ((h00, h01, h02), (h10, h11, h12), (h20, h21, h22))
    for i in range(3):
        for j in range(3):
            K[i, j] = 2.0 * H[i][j] + (H[i][0] * H[0][j] + H[i][1] * H[1][j] + H[i][2] * H[2][j])


@njit(cache=True)
def _apply(y1, K):
    """``Π ↦ Π + KᵀΠ``, ``R ↦ R + RK`` in place (the flat state ``(Π, R)``)."""
    p0, p1, p2 = y1[0], y1[1], y1[2]
    y1[0] = p0 + (K[0, 0] * p0 + K[1, 0] * p1 + K[2, 0] * p2)
    y1[1] = p1 + (K[0, 1] * p0 + K[1, 1] * p1 + K[2, 1] * p2)
    y1[2] = p2 + (K[0, 2] * p0 + K[1, 2] * p1 + K[2, 2] * p2)
    for r in range(3):
        r0, r1, r2 = y1[3 + 3 * r], y1[4 + 3 * r], y1[5 + 3 * r]
        y1[3 + 3 * r] = r0 + (r0 * K[0, 0] + r1 * K[1, 0] + r2 * K[2, 0])
        y1[4 + 3 * r] = r1 + (r0 * K[0, 1] + r1 * K[1, 1] + r2 * K[2, 1])
        y1[5 + 3 * r] = r2 + (r0 * K[0, 2] + r1 * K[1, 2] + r2 * K[2, 2])


@njit(cache=True)
def _exact_step(I, y, h, meth, y1, K, table):
    """One step from the flat state y into y1 (K the last substep's ``Q − I``): the step's
    quaternion ``(q₀, q₁, q₂, q₃)`` and the substeps it took (0: none settled)."""
    pieces = 1
    while pieces <= meth.max_pieces:
        for i in range(12):
            y1[i] = y[i]
        Q = (1.0, 0.0, 0.0, 0.0)
        cut = 0
        tau = h / pieces
        for _ in range(pieces):
            status, lam, q0, q1, q2, q3 = _short_step(I, y1[0:3], tau, meth, table)
            if status == _LONG and pieces == 1 and lam == lam:  # a long step: equal short ones
                cut = max(2, math.floor(abs(lam * h) / meth.short_phase) + 1)
                break
            if status != _DONE:
                cut = 2 * pieces
                break
            rotation_minus_identity(q0, q1, q2, q3, K)
            _apply(y1, K)
            Q = _quaternion_product(Q[0], Q[1], Q[2], Q[3], q0, q1, q2, q3)
        if cut == 0:
            return Q[0], Q[1], Q[2], Q[3], pieces
        pieces = cut
    return 1.0, 0.0, 0.0, 0.0, 0


@njit(cache=True)
def _phases(moments, Pi, h, out):
    for b in range(Pi.shape[0]):
        setup = _setup(moments, Pi[b])
        steady, a2, lam = setup[0], setup[6], setup[9]
        out[b] = 0.0 if steady else (abs(lam * h) if a2 != 0.0 else math.inf)


def step_phases(moments, Pi, h: float) -> np.ndarray:
    """``|λh|`` of each momentum's motion (0 for a steady rotation; ∞ for a degenerate one)."""
    Pi = np.ascontiguousarray(np.atleast_2d(Pi), dtype=float)
    out = np.empty(Pi.shape[0])
    _phases(np.ascontiguousarray(moments, dtype=float), Pi, float(h), out)
    return out


def decline(layout, Y: np.ndarray, h: float | None) -> str:
    """Why a run from the flat states Y with steps up to ``|h|`` is not for this form ("" when it
    is): a step longer than the short phase takes the numpy path's closed form (one rounding
    for the whole step, its long phases in 50 digits), not a chain of short steps."""
    if h is None:
        return ""
    longest = float(np.max(step_phases(layout.moments, Y[:, :3], float(h)), initial=0.0))
    if longest > SHORT_PHASE:
        return (
            f"'exact_flow' steps with |λh| > {SHORT_PHASE:g} (here up to {longest:.3g}) take the closed form "
            "(numpy path)"
        )
    return ""


# -- the form -------------------------------------------------------------------------------------


@njit(cache=True)
def form_scratch(fx, meth, par, d):
    """The projection's 3 × 3 work matrix, ``K`` and the elliptic table."""
    return np.zeros((3, 3)), np.zeros((3, 3)), np.zeros(TABLE_SIZE)


@njit(cache=True)
def form_exact_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One step of one body in the principal frame; ``inc`` = the Cayley coordinates of the
    step's rotation, ``aux[0] = |I⁻¹Π|²``. Returns the substeps taken, or −1 when a step could
    not be cut into settled substeps."""
    Iinv = par[0:3]
    w0, w1, w2 = Iinv[0] * y[0], Iinv[1] * y[1], Iinv[2] * y[2]
    aux[0] = w0 * w0 + w1 * w1 + w2 * w2
    q0, q1, q2, q3, pieces = _exact_step(meth.moments, y, h, meth, y1, scr[1], scr[2])
    if pieces == 0:
        return -1
    if q0 < 0.0:
        q0, q1, q2, q3 = -q0, -q1, -q2, -q3
    inc[0], inc[1], inc[2] = 2.0 * q1 / q0, 2.0 * q2 / q0, 2.0 * q3 / q0
    return pieces


@njit(cache=True)
def form_project(fx, y, par, out, scr):
    """R onto SO(3) (the 3D top's Newton–Schulz); Π as it is."""
    for i in range(12):
        out[i] = y[i]
    _newton_schulz(out[3:12].reshape((3, 3)), scr[0])


@njit(cache=True)
def _increments(moments, Pi, h, meth, K):
    table = np.zeros(TABLE_SIZE)
    y, y1 = np.zeros(12), np.zeros(12)
    Kstep = np.zeros((3, 3))
    pieces = np.zeros(Pi.shape[0], dtype=np.int64)
    for b in range(Pi.shape[0]):
        y[0], y[1], y[2] = Pi[b, 0], Pi[b, 1], Pi[b, 2]
        q0, q1, q2, q3, pieces[b] = _exact_step(moments, y, h, meth, y1, Kstep, table)
        rotation_minus_identity(q0, q1, q2, q3, K[b])
    return pieces


def exact_increments(moments, Pi, h: float) -> tuple[np.ndarray, np.ndarray]:
    """The compiled step's ``K = Q(h) − I`` for each momentum (a reference for tests).

    Parameters
    ----------
    moments : array_like, shape (3,)
        Principal moments of inertia.
    Pi : array_like, shape (N, 3)
        Body momenta in the principal frame.
    h : float
        The step.

    Returns
    -------
    K : ndarray, shape (N, 3, 3)
        The increments (of the composed substeps' rotation when a step was cut).
    pieces : ndarray, shape (N,)
        The substeps each step took (0: it could not be cut into settled ones).
    """
    Pi = np.ascontiguousarray(np.atleast_2d(Pi), dtype=float)
    K = np.empty((Pi.shape[0], 3, 3))
    pieces = _increments(np.ascontiguousarray(moments, dtype=float), Pi, float(h), _numbers(moments), K)
    return K, pieces


#: the names of :mod:`lieint.fast.loop` this form binds (fixed steps only)
NAMESPACES = {
    "exact_flow": {
        "prepare": form_prepare,
        "scratch": form_scratch,
        "step": form_exact_step,
        "embedded": form_embedded,
        "error_sum": form_error_sum,
        "project": form_project,
        "radius2": form_radius2,
        "user_field": form_user_field,
    }
}
