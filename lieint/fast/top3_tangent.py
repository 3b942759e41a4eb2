"""The tangent maps of the 3D top's exact-rotation splittings and Moser–Veselov maps, as forms of
the one compiled loop (forward mode, numba, cached on disk).

A body's row is its state in the principal frame, ``(Π, R̃)`` (12 numbers, :mod:`lieint.fast.top3`),
followed by k tangent vectors ``(δΠ, δR̃)`` of the same layout: ``d = 12 (1 + k)``. A step moves
the state exactly as the plain step does (:mod:`lieint.fast.top3_split`,
:mod:`lieint.fast.top3_mv`: the same operations in the same order, so the same bits) and each
tangent vector by the derivative of that step, ``δy ↦ DΦ_h(y) δy``, differentiated by hand:

* a splitting's rotation of the plane (i, j) by ``θ = −w τ a/I_k`` (``a = ±Π_k``, w its fraction
  of τ) moves ``δθ = −w τ δa/I_k``, ``δ(cos θ) = −sin θ δθ``, ``δ(sin θ) = cos θ δθ``, and the two
  components of Π and two columns of R̃ it turns by the product rule;
* a Moser–Veselov substep solves ``F(c; a) = c − (1 + |c|²) a − f ⊙ (c₂c₃, c₃c₁, c₁c₂) = 0`` with
  ``a = (h_s/2) Π/I``: by the implicit function theorem ``δc = (1 + |c|²) J⁻¹ δa``, J = ∂F/∂c at
  the converged c (its adjugate, as Newton solves with it), then ``K = g (ĉ + ccᵀ − |c|² I)``,
  ``g = 2/(1 + |c|²)``, ``Π₁ = Π + KᵀΠ``, ``R̃₁ = R̃ + R̃K`` by the product rule.

This is the derivative of the map the method computes (Newton converged to round-off), the
tangent map the complex step of :mod:`lieint.tangent.flow` computes on the generic path, at a
cost of about one more step per tangent vector. The modified-moment forms (``degree > 0``,
moments that depend on Π) are not here: their tangent map is refused on both paths.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .top3 import form_embedded, form_error_sum, form_prepare, form_radius2, form_user_field
from .top3_mv import _solve, form_project, form_scratch
from .top3_mv import numbers as _mv_numbers
from .top3_split import numbers as _split_numbers

__all__ = ["MEGNO_ROW", "MEGNO_SLOTS", "NAMESPACES", "numbers"]


def numbers(form, layout):
    """The map's numbers (:func:`lieint.fast.top3_split.numbers`, :func:`lieint.fast.top3_mv.numbers`)."""
    if form.family == "splitting":
        return _split_numbers(form, layout)
    if form.degree:
        raise ValueError(f"no compiled tangent map of the modified Moser–Veselov map of degree {form.degree}")
    return _mv_numbers(form, layout)


@njit(cache=True)
def form_split_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One splitting step of a body's state and of its tangent vectors (module docstring);
    ``inc`` and ``aux`` as :func:`lieint.fast.top3_split.form_split_step` writes them."""
    Iinv = par[0:3]
    d = y.shape[0]
    k = d // 12 - 1
    for i in range(d):
        y1[i] = y[i]
    w0, w1, w2 = Iinv[0] * y1[0], Iinv[1] * y1[1], Iinv[2] * y1[2]
    aux[0] = w0 * w0 + w1 * w1 + w2 * w2
    q0, q1, q2, q3 = 1.0, 0.0, 0.0, 0.0
    planes, halves = meth.planes, meth.halves
    for sub in range(meth.substeps.shape[0]):
        tau = h * meth.substeps[sub]
        for row in range(planes.shape[0]):
            i, j, kk = planes[row, 0], planes[row, 1], planes[row, 2]
            flipped = i == 0 and j == 2
            a = -y1[kk] if flipped else y1[kk]
            theta = -halves[row] * tau * a * Iinv[kk]  # the plain step's expression, bit for bit
            c, s = np.cos(theta), np.sin(theta)
            pi, pj = y1[i], y1[j]
            for m in range(1, k + 1):  # the tangent vectors first: they read the state before the turn
                o = 12 * m
                da = -y1[o + kk] if flipped else y1[o + kk]
                dth = -halves[row] * tau * da * Iinv[kk]
                dc, ds = -s * dth, c * dth
                dpi, dpj = y1[o + i], y1[o + j]
                y1[o + i] = (dc * pi - ds * pj) + (c * dpi - s * dpj)
                y1[o + j] = (ds * pi + dc * pj) + (s * dpi + c * dpj)
                for r in range(3):
                    ri, rj = y1[3 + 3 * r + i], y1[3 + 3 * r + j]
                    dri, drj = y1[o + 3 + 3 * r + i], y1[o + 3 + 3 * r + j]
                    y1[o + 3 + 3 * r + i] = (dc * ri - ds * rj) + (c * dri - s * drj)
                    y1[o + 3 + 3 * r + j] = (ds * ri + dc * rj) + (s * dri + c * drj)
            y1[i] = c * pi - s * pj  # QᵀΠ
            y1[j] = s * pi + c * pj
            for r in range(3):  # RQ: columns i and j
                ri, rj = y1[3 + 3 * r + i], y1[3 + 3 * r + j]
                y1[3 + 3 * r + i] = c * ri - s * rj
                y1[3 + 3 * r + j] = s * ri + c * rj
            t = np.tan(0.5 * theta) * (1.0 if flipped else -1.0)
            e0 = t if kk == 0 else 0.0
            e1 = t if kk == 1 else 0.0
            e2 = t if kk == 2 else 0.0
            q0, q1, q2, q3 = (
                q0 - (q1 * e0 + q2 * e1 + q3 * e2),
                q1 + q0 * e0 + (q2 * e2 - q3 * e1),
                q2 + q0 * e1 + (q3 * e0 - q1 * e2),
                q3 + q0 * e2 + (q1 * e1 - q2 * e0),
            )
    inc[0], inc[1], inc[2] = 2.0 * q1 / q0, 2.0 * q2 / q0, 2.0 * q3 / q0
    return meth.substeps.shape[0]


@njit(cache=True)
def form_mv_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One Moser–Veselov step (every substep a solve and its action) of a body's state and of its
    tangent vectors (module docstring; the body's moments, ``degree = 0``); ``inc``, ``aux`` and
    the return value as :func:`lieint.fast.top3_mv.form_mv_step` writes them."""
    Iinv = par[0:3]
    d = y.shape[0]
    k = d // 12 - 1
    for i in range(d):
        y1[i] = y[i]
    p0, p1, p2 = y1[0], y1[1], y1[2]
    w0, w1, w2 = Iinv[0] * p0, Iinv[1] * p1, Iinv[2] * p2
    aux[0] = w0 * w0 + w1 * w1 + w2 * w2
    Jinv0, Jinv1, Jinv2 = Iinv[0], Iinv[1], Iinv[2]
    J0, J1, J2 = 1.0 / Jinv0, 1.0 / Jinv1, 1.0 / Jinv2
    f0, f1, f2 = (J1 - J2) * Jinv0, (J2 - J0) * Jinv1, (J0 - J1) * Jinv2
    spent = 0
    q0, q1, q2, q3 = 1.0, 0.0, 0.0, 0.0
    for sub in range(meth.substeps.shape[0]):
        hh = 0.5 * h * meth.substeps[sub]
        p0, p1, p2 = y1[0], y1[1], y1[2]
        a0, a1, a2 = hh * p0 * Jinv0, hh * p1 * Jinv1, hh * p2 * Jinv2
        c0, c1, c2, it = _solve(a0, a1, a2, f0, f1, f2)
        if it < 0:
            return -1
        spent += it
        n2 = c0 * c0 + c1 * c1 + c2 * c2
        g = 2.0 / (1.0 + n2)
        k00 = g * (c0 * c0 - n2)
        k11 = g * (c1 * c1 - n2)
        k22 = g * (c2 * c2 - n2)
        k01 = g * (c0 * c1 - c2)
        k10 = g * (c1 * c0 + c2)
        k02 = g * (c0 * c2 + c1)
        k20 = g * (c2 * c0 - c1)
        k12 = g * (c1 * c2 - c0)
        k21 = g * (c2 * c1 + c0)
        # J = ∂F/∂c at the solution and its adjugate M (J⁻¹ = M / det J)
        j00 = 1.0 - 2.0 * a0 * c0
        j01 = -2.0 * a0 * c1 - f0 * c2
        j02 = -2.0 * a0 * c2 - f0 * c1
        j10 = -2.0 * a1 * c0 - f1 * c2
        j11 = 1.0 - 2.0 * a1 * c1
        j12 = -2.0 * a1 * c2 - f1 * c0
        j20 = -2.0 * a2 * c0 - f2 * c1
        j21 = -2.0 * a2 * c1 - f2 * c0
        j22 = 1.0 - 2.0 * a2 * c2
        m00 = j11 * j22 - j12 * j21
        m01 = j02 * j21 - j01 * j22
        m02 = j01 * j12 - j02 * j11
        m10 = j12 * j20 - j10 * j22
        m11 = j00 * j22 - j02 * j20
        m12 = j02 * j10 - j00 * j12
        m20 = j10 * j21 - j11 * j20
        m21 = j01 * j20 - j00 * j21
        m22 = j00 * j11 - j01 * j10
        scale = (1.0 + n2) / (j00 * m00 + j01 * m10 + j02 * m20)
        half_g2 = 0.5 * g * g
        for m in range(1, k + 1):  # the tangent vectors first: they read the state before the substep
            o = 12 * m
            dp0, dp1, dp2 = y1[o], y1[o + 1], y1[o + 2]
            da0, da1, da2 = hh * dp0 * Jinv0, hh * dp1 * Jinv1, hh * dp2 * Jinv2
            dc0 = scale * (m00 * da0 + m01 * da1 + m02 * da2)
            dc1 = scale * (m10 * da0 + m11 * da1 + m12 * da2)
            dc2 = scale * (m20 * da0 + m21 * da1 + m22 * da2)
            dn2 = 2.0 * (c0 * dc0 + c1 * dc1 + c2 * dc2)
            dg = -half_g2 * dn2
            dk00 = dg * (c0 * c0 - n2) + g * (2.0 * c0 * dc0 - dn2)
            dk11 = dg * (c1 * c1 - n2) + g * (2.0 * c1 * dc1 - dn2)
            dk22 = dg * (c2 * c2 - n2) + g * (2.0 * c2 * dc2 - dn2)
            dk01 = dg * (c0 * c1 - c2) + g * (dc0 * c1 + c0 * dc1 - dc2)
            dk10 = dg * (c1 * c0 + c2) + g * (dc1 * c0 + c1 * dc0 + dc2)
            dk02 = dg * (c0 * c2 + c1) + g * (dc0 * c2 + c0 * dc2 + dc1)
            dk20 = dg * (c2 * c0 - c1) + g * (dc2 * c0 + c2 * dc0 - dc1)
            dk12 = dg * (c1 * c2 - c0) + g * (dc1 * c2 + c1 * dc2 - dc0)
            dk21 = dg * (c2 * c1 + c0) + g * (dc2 * c1 + c2 * dc1 + dc0)
            # δΠ₁ = δΠ + δKᵀΠ + KᵀδΠ
            y1[o] = dp0 + (dk00 * p0 + dk10 * p1 + dk20 * p2) + (k00 * dp0 + k10 * dp1 + k20 * dp2)
            y1[o + 1] = dp1 + (dk01 * p0 + dk11 * p1 + dk21 * p2) + (k01 * dp0 + k11 * dp1 + k21 * dp2)
            y1[o + 2] = dp2 + (dk02 * p0 + dk12 * p1 + dk22 * p2) + (k02 * dp0 + k12 * dp1 + k22 * dp2)
            # δR₁ = δR + δR K + R δK (row by row)
            for r in range(3):
                r0, r1, r2 = y1[3 + 3 * r], y1[4 + 3 * r], y1[5 + 3 * r]
                e = o + 3 + 3 * r
                s0, s1, s2 = y1[e], y1[e + 1], y1[e + 2]
                y1[e] = s0 + (s0 * k00 + s1 * k10 + s2 * k20) + (r0 * dk00 + r1 * dk10 + r2 * dk20)
                y1[e + 1] = s1 + (s0 * k01 + s1 * k11 + s2 * k21) + (r0 * dk01 + r1 * dk11 + r2 * dk21)
                y1[e + 2] = s2 + (s0 * k02 + s1 * k12 + s2 * k22) + (r0 * dk02 + r1 * dk12 + r2 * dk22)
        # the state: the plain step's operations (lieint.fast.top3_mv.form_mv_step)
        y1[0] = p0 + (k00 * p0 + k10 * p1 + k20 * p2)
        y1[1] = p1 + (k01 * p0 + k11 * p1 + k21 * p2)
        y1[2] = p2 + (k02 * p0 + k12 * p1 + k22 * p2)
        for r in range(3):
            r0, r1, r2 = y1[3 + 3 * r], y1[4 + 3 * r], y1[5 + 3 * r]
            y1[3 + 3 * r] = r0 + (r0 * k00 + r1 * k10 + r2 * k20)
            y1[4 + 3 * r] = r1 + (r0 * k01 + r1 * k11 + r2 * k21)
            y1[5 + 3 * r] = r2 + (r0 * k02 + r1 * k12 + r2 * k22)
        q0, q1, q2, q3 = (
            q0 - (q1 * c0 + q2 * c1 + q3 * c2),
            q1 + q0 * c0 + (q2 * c2 - q3 * c1),
            q2 + q0 * c1 + (q3 * c0 - q1 * c2),
            q3 + q0 * c2 + (q1 * c1 - q2 * c0),
        )
    inc[0], inc[1], inc[2] = 2.0 * q1 / q0, 2.0 * q2 / q0, 2.0 * q3 / q0
    return spent


#: the MEGNO sums after a body's state and its tangent vector (:data:`MEGNO_ROW`): the time
#: since the start, ``log|δ|`` (renormalisations added back), ``∫ s d log|δ|``, ``∫ Y dt``, ``Y``
MEGNO_SLOTS = 5
#: where the MEGNO sums start in a row of the state and one tangent vector
MEGNO_ROW = 24


@njit(cache=True, inline="always")
def _megno_update(y1, par, h):
    """After a step of size h: ``|δ|`` in the tangent coordinates (``δΠ`` and, for a top with
    attitude, ``vee`` of the skew part of ``R̃ᵀδR̃``: the chart's norm, the frame being a rotation),
    MEGNO's sums (:func:`lieint.megno`: ``Y(t) = (2/t) ∫ s d log|δ|``, ⟨Y⟩ by the trapezoidal
    rule), and δ renormalised to 1. Where |δ| is not finite and positive the sums become NaN (and
    stay so: the caller refuses the run, naming it)."""
    n2 = y1[12] * y1[12] + y1[13] * y1[13] + y1[14] * y1[14]
    if par[12] != 0.0:  # the attitude's part: M = R̃ᵀ δR̃, δ = vee((M − Mᵀ)/2)
        m01, m10, m02, m20, m12, m21 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        for r in range(3):
            a0, a1, a2 = y1[3 + 3 * r], y1[4 + 3 * r], y1[5 + 3 * r]
            b0, b1, b2 = y1[15 + 3 * r], y1[16 + 3 * r], y1[17 + 3 * r]
            m01 += a0 * b1
            m10 += a1 * b0
            m02 += a0 * b2
            m20 += a2 * b0
            m12 += a1 * b2
            m21 += a2 * b1
        d0, d1, d2 = 0.5 * (m21 - m12), 0.5 * (m02 - m20), 0.5 * (m10 - m01)
        n2 += d0 * d0 + d1 * d1 + d2 * d2
    norm = np.sqrt(n2)
    s = MEGNO_ROW
    if not (norm > 0.0 and np.isfinite(norm)):
        for i in range(s + 1, s + 5):
            y1[i] = np.nan
        y1[s] += h
        return
    tk = y1[s]
    t = tk + h
    dlog = np.log(norm)
    y1[s] = t
    y1[s + 1] += dlog
    y1[s + 2] += (tk + 0.5 * h) * dlog
    Y = 2.0 * y1[s + 2] / t
    y1[s + 3] += 0.5 * (y1[s + 4] + Y) * h
    y1[s + 4] = Y
    for i in range(12, 24):
        y1[i] /= norm


@njit(cache=True)
def form_split_megno_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_split_tangent_step` of the state and one tangent vector, then MEGNO's sums
    (:func:`_megno_update`)."""
    spent = form_split_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    _megno_update(y1, par, h)
    return spent


@njit(cache=True)
def form_mv_megno_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_mv_tangent_step` of the state and one tangent vector, then MEGNO's sums
    (:func:`_megno_update`); −1 when Newton failed."""
    spent = form_mv_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    if spent >= 0:
        _megno_update(y1, par, h)
    return spent


@njit(cache=True, inline="always")
def _chart_coordinates(y1, o, orient, u):
    """``u`` = the tangent vector at ``y1[o : o + 12]`` in coordinates of the chart's norm: δΠ, then
    (for a top with attitude) ``vee`` of the skew part of ``R̃ᵀδR̃`` (:func:`_megno_update`)."""
    u[0], u[1], u[2] = y1[o], y1[o + 1], y1[o + 2]
    u[3], u[4], u[5] = 0.0, 0.0, 0.0
    if orient:
        m01, m10, m02, m20, m12, m21 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        for r in range(3):
            a0, a1, a2 = y1[3 + 3 * r], y1[4 + 3 * r], y1[5 + 3 * r]
            b0, b1, b2 = y1[o + 3 + 3 * r], y1[o + 4 + 3 * r], y1[o + 5 + 3 * r]
            m01 += a0 * b1
            m10 += a1 * b0
            m02 += a0 * b2
            m20 += a2 * b0
            m12 += a1 * b2
            m21 += a2 * b1
        u[3], u[4], u[5] = 0.5 * (m21 - m12), 0.5 * (m02 - m20), 0.5 * (m10 - m01)


@njit(cache=True, inline="always")
def _lyapunov_update(y1, par, k):
    """Every ``every`` steps (``par[14]``) and after the last (``par[15]``): the k tangent vectors
    orthonormalised by modified Gram–Schmidt in the chart's norm (:func:`_chart_coordinates`; the
    combinations applied to the vectors themselves, the coordinates being linear in them), and
    ``log`` of each vector's norm before its normalisation (the diagonal of QR's R) added to its
    sum. The row's step counter is at ``12 (1 + k)``, the k sums after it."""
    c = 12 * (1 + k)
    y1[c] += 1.0
    done, every, total = y1[c], par[14], par[15]
    if done % every != 0.0 and done != total:
        return
    orient = par[12] != 0.0
    u = np.empty(6)
    w = np.empty(6)
    for j in range(1, k + 1):
        oj = 12 * j
        for i in range(1, j):  # v_j ← v_j − ⟨q_i, v_j⟩ q_i, q_i already normalised
            oi = 12 * i
            _chart_coordinates(y1, oi, orient, u)
            _chart_coordinates(y1, oj, orient, w)
            dot = 0.0
            for a in range(6):
                dot += u[a] * w[a]
            for a in range(12):
                y1[oj + a] -= dot * y1[oi + a]
        _chart_coordinates(y1, oj, orient, w)
        n2 = 0.0
        for a in range(6):
            n2 += w[a] * w[a]
        norm = np.sqrt(n2)
        y1[c + j] += np.log(norm)  # −inf or NaN when the vectors degenerate: the caller refuses
        for a in range(12):
            y1[oj + a] /= norm


@njit(cache=True)
def form_split_lyapunov_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_split_tangent_step`, then the re-orthonormalisation of :func:`_lyapunov_update`
    when it is due."""
    spent = form_split_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    _lyapunov_update(y1, par, y.shape[0] // 12 - 1)
    return spent


@njit(cache=True)
def form_mv_lyapunov_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_mv_tangent_step`, then the re-orthonormalisation of :func:`_lyapunov_update`
    when it is due; −1 when Newton failed."""
    spent = form_mv_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    if spent >= 0:
        _lyapunov_update(y1, par, y.shape[0] // 12 - 1)
    return spent


_COMMON = {
    "prepare": form_prepare,
    "scratch": form_scratch,
    "embedded": form_embedded,
    "error_sum": form_error_sum,
    "project": form_project,
    "radius2": form_radius2,
    "user_field": form_user_field,
}

#: the names of :mod:`lieint.fast.loop` this form binds (fixed steps only, no projection: the
#: projection's derivative is not carried)
NAMESPACES = {
    "splitting": {**_COMMON, "step": form_split_tangent_step},
    "moser_veselov": {**_COMMON, "step": form_mv_tangent_step},
    "splitting_megno": {**_COMMON, "step": form_split_megno_step},
    "moser_veselov_megno": {**_COMMON, "step": form_mv_megno_step},
    "splitting_lyapunov": {**_COMMON, "step": form_split_lyapunov_step},
    "moser_veselov_lyapunov": {**_COMMON, "step": form_mv_lyapunov_step},
}
