"""The tangent maps of the 3D top's RKMK methods, exact-rotation splittings and Moser–Veselov maps,
as forms of the one compiled loop (forward mode, numba, cached on disk).

A body's row is its state in the principal frame, ``(Π, R̃)`` (12 numbers, :mod:`lieint.fast.top3`),
followed by k tangent vectors ``(δΠ, δR̃)`` of the same layout: ``d = 12 (1 + k)``. A step moves
the state exactly as the plain step does (:mod:`lieint.fast.top3_split`,
:mod:`lieint.fast.top3_mv`: the same operations in the same order, so the same bits) and each
tangent vector by the derivative of that step, ``δy ↦ DΦ_h(y) δy``, differentiated by hand:

* a splitting's rotation of the plane (i, j) by ``θ = −w τ a/I_k`` (``a = ±Π_k``, w its fraction
  of τ) moves ``δθ = −w τ δa/I_k``, ``δ(cos θ) = −sin θ δθ``, ``δ(sin θ) = cos θ δθ``, and the two
  components of Π and two columns of R̃ it turns by the product rule;
* an RKMK step (exponential coordinates, dexp⁻¹ truncated) moves its stages' ``u`` by
  ``δu = h Σ a_ij δK_j``, ``exp(u)`` by ``Qᵀ δQ = (J_r(u) δu)^`` (the right Jacobian of so(3)), and
  the truncated series' terms ``t_d = (−u) × t_{d−1}`` by ``δt_d = (−δu) × t_{d−1} + (−u) × δt_{d−1}``;
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

from .se3_tangent import rotate_back, tangent_attitude_turned
from .tangent_sums import MEGNO_SLOTS, lyapunov_update, megno_update
from .top3 import (
    _RADIUS2,
    _cross,
    _exponent,
    _rodrigues,
    form_embedded,
    form_error_sum,
    form_prepare,
    form_radius2,
    form_user_field,
)
from .top3 import form_project as form_top3_project
from .top3 import form_scratch as form_top3_scratch
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


@njit(cache=True, inline="always")
def _right_jacobian(u0, u1, u2, v0, v1, v2):
    """``J_r(u) v`` with ``exp(u + δu) = exp(u) exp((J_r(u) δu)^) + O(δu²)``:
    ``J_r(u) = I − β û + γ û²``, ``β = (1 − cos θ)/θ²``, ``γ = (θ − sin θ)/θ³`` (their even series
    below θ = 0.1, exact to round-off there)."""
    t2 = u0 * u0 + u1 * u1 + u2 * u2
    if t2 < 1e-2:
        beta = 0.5 + t2 * (-1.0 / 24 + t2 * (1.0 / 720 + t2 * (-1.0 / 40320 + t2 * (1.0 / 3628800))))
        gamma = 1.0 / 6 + t2 * (-1.0 / 120 + t2 * (1.0 / 5040 + t2 * (-1.0 / 362880 + t2 * (1.0 / 39916800))))
    else:
        th = np.sqrt(t2)
        beta = (1.0 - np.cos(th)) / t2
        gamma = (th - np.sin(th)) / (t2 * th)
    c0, c1, c2 = _cross(u0, u1, u2, v0, v1, v2)
    e0, e1, e2 = _cross(u0, u1, u2, c0, c1, c2)
    return v0 - beta * c0 + gamma * e0, v1 - beta * c1 + gamma * e1, v2 - beta * c2 + gamma * e2


@njit(cache=True)
def form_rkmk_tangent_scratch(fx, meth, par, d):
    """The 3D top's scratch (:func:`lieint.fast.top3.form_scratch`), then the tangent vectors'
    stage slopes ``δK`` (k, s, 3) and the stage's ``(Π_i, δΠ_i)`` temporaries."""
    s = meth.b.shape[0]
    k = d // 12 - 1
    base = form_top3_scratch(fx, meth, par, d)
    return (*base, np.zeros((max(k, 1), s, 3)), np.zeros((max(k, 1), 3)))


@njit(cache=True)
def form_rkmk_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One RKMK step (exponential coordinates, dexp⁻¹ truncated at ``meth.coeffs``) of a body's
    state — :func:`lieint.fast.top3._lie_step`'s operations — and of its tangent vectors, in
    forward mode: a stage's ``δu = h Σ_j a_ij δK_j``; ``exp(u)`` moves by ``Qᵀ δQ = ŵ``,
    ``w = J_r(u) δu`` (:func:`_right_jacobian`), so ``δΠ_i = Qᵀ δΠ − w × Π_i``; ``δξ = I⁻¹ δΠ_i``; the
    series' terms ``t_d = (−u) × t_{d−1}`` move by ``δt_d = (−δu) × t_{d−1} + (−u) × δt_{d−1}``;
    the step's end ``Π₁ = QᵀΠ``, ``R₁ = RQ`` by ``δΠ₁ = QᵀδΠ − w × Π₁``, ``δR₁ = δR Q + R₁ ŵ``.
    Returns −1 when a stage reaches the dexp⁻¹ radius (as the plain step)."""
    K, u, Q, tpi, tR = scr[0], scr[1], scr[2], scr[3], scr[4]
    dK, du = scr[9], scr[10]
    d = y.shape[0]
    k = d // 12 - 1
    for i in range(d):
        y1[i] = y[i]
    Iinv = par[0:3]
    A, b, coeffs = meth.A, meth.b, meth.coeffs
    s = b.shape[0]
    degree = coeffs.shape[0] - 1
    pi = y1[0:3]
    for i in range(s):
        u[0] = 0.0
        u[1] = 0.0
        u[2] = 0.0
        for m in range(k):
            du[m, 0] = 0.0
            du[m, 1] = 0.0
            du[m, 2] = 0.0
        for j in range(i):
            if A[i, j] != 0.0:
                w = h * A[i, j]
                u[0] += w * K[j, 0]
                u[1] += w * K[j, 1]
                u[2] += w * K[j, 2]
                for m in range(k):
                    du[m, 0] += w * dK[m, j, 0]
                    du[m, 1] += w * dK[m, j, 1]
                    du[m, 2] += w * dK[m, j, 2]
        if i == 0 or (u[0] == 0.0 and u[1] == 0.0 and u[2] == 0.0):
            # the plain step's ξ = I⁻¹Π (u = 0: Q = I, and δu is 0 with it unless the weights are,
            # which they are not here: a zero u from nonzero weights is a zero combination)
            K[i, 0], K[i, 1], K[i, 2] = Iinv[0] * pi[0], Iinv[1] * pi[1], Iinv[2] * pi[2]
            for m in range(k):
                o = 12 * (m + 1)
                if i == 0:
                    dK[m, i, 0], dK[m, i, 1], dK[m, i, 2] = Iinv[0] * y1[o], Iinv[1] * y1[o + 1], Iinv[2] * y1[o + 2]
                else:  # u = 0 from nonzero weights: Q = I to first order, δΠ_i = δΠ − δu × Π
                    e0, e1, e2 = _cross(du[m, 0], du[m, 1], du[m, 2], pi[0], pi[1], pi[2])
                    q0, q1, q2 = y1[o] - e0, y1[o + 1] - e1, y1[o + 2] - e2
                    x0, x1, x2 = Iinv[0] * q0, Iinv[1] * q1, Iinv[2] * q2
                    # the series at u = 0 is ξ; to first order its term c₁ (−δu) × ξ moves it
                    c0, c1, c2 = _cross(du[m, 0], du[m, 1], du[m, 2], K[i, 0], K[i, 1], K[i, 2])
                    c = coeffs[1]
                    dK[m, i, 0], dK[m, i, 1], dK[m, i, 2] = x0 - c * c0, x1 - c * c1, x2 - c * c2
            continue
        if u[0] * u[0] + u[1] * u[1] + u[2] * u[2] >= _RADIUS2:
            return -1
        _rodrigues(u, Q)
        p0 = Q[0, 0] * pi[0] + Q[1, 0] * pi[1] + Q[2, 0] * pi[2]
        p1 = Q[0, 1] * pi[0] + Q[1, 1] * pi[1] + Q[2, 1] * pi[2]
        p2 = Q[0, 2] * pi[0] + Q[1, 2] * pi[1] + Q[2, 2] * pi[2]
        x0, x1, x2 = Iinv[0] * p0, Iinv[1] * p1, Iinv[2] * p2
        for m in range(k):
            o = 12 * (m + 1)
            w0, w1, w2 = _right_jacobian(u[0], u[1], u[2], du[m, 0], du[m, 1], du[m, 2])
            e0, e1, e2 = _cross(w0, w1, w2, p0, p1, p2)
            dp0 = Q[0, 0] * y1[o] + Q[1, 0] * y1[o + 1] + Q[2, 0] * y1[o + 2] - e0
            dp1 = Q[0, 1] * y1[o] + Q[1, 1] * y1[o + 1] + Q[2, 1] * y1[o + 2] - e1
            dp2 = Q[0, 2] * y1[o] + Q[1, 2] * y1[o + 1] + Q[2, 2] * y1[o + 2] - e2
            dx0, dx1, dx2 = Iinv[0] * dp0, Iinv[1] * dp1, Iinv[2] * dp2
            t0, t1, t2 = x0, x1, x2
            dt0, dt1, dt2 = dx0, dx1, dx2
            dk0, dk1, dk2 = dx0, dx1, dx2
            for dd in range(1, degree + 1):
                a0, a1, a2 = _cross(-du[m, 0], -du[m, 1], -du[m, 2], t0, t1, t2)
                b0, b1, b2 = _cross(-u[0], -u[1], -u[2], dt0, dt1, dt2)
                dt0, dt1, dt2 = a0 + b0, a1 + b1, a2 + b2
                t0, t1, t2 = _cross(-u[0], -u[1], -u[2], t0, t1, t2)
                c = coeffs[dd]
                if c != 0.0:
                    dk0 += c * dt0
                    dk1 += c * dt1
                    dk2 += c * dt2
            dK[m, i, 0], dK[m, i, 1], dK[m, i, 2] = dk0, dk1, dk2
        # the plain step's series (lieint.fast.top3._lie_step, reduce=False)
        k0, k1, k2 = x0, x1, x2
        t0, t1, t2 = x0, x1, x2
        for dd in range(1, degree + 1):
            t0, t1, t2 = _cross(-u[0], -u[1], -u[2], t0, t1, t2)
            c = coeffs[dd]
            if c != 0.0:
                k0 += c * t0
                k1 += c * t1
                k2 += c * t2
        K[i, 0] = k0
        K[i, 1] = k1
        K[i, 2] = k2
    u[0] = 0.0
    u[1] = 0.0
    u[2] = 0.0
    for m in range(k):
        du[m, 0] = 0.0
        du[m, 1] = 0.0
        du[m, 2] = 0.0
    for j in range(s):
        w = h * b[j]
        u[0] += w * K[j, 0]
        u[1] += w * K[j, 1]
        u[2] += w * K[j, 2]
        for m in range(k):
            du[m, 0] += w * dK[m, j, 0]
            du[m, 1] += w * dK[m, j, 1]
            du[m, 2] += w * dK[m, j, 2]
    _rodrigues(u, Q)
    for r in range(3):
        tpi[r] = Q[0, r] * pi[0] + Q[1, r] * pi[1] + Q[2, r] * pi[2]
    for r in range(3):
        for c2 in range(3):
            tR[r, c2] = y1[3 + 3 * r] * Q[0, c2] + y1[4 + 3 * r] * Q[1, c2] + y1[5 + 3 * r] * Q[2, c2]
    for m in range(k):
        o = 12 * (m + 1)
        w0, w1, w2 = _right_jacobian(u[0], u[1], u[2], du[m, 0], du[m, 1], du[m, 2])
        e0, e1, e2 = _cross(w0, w1, w2, tpi[0], tpi[1], tpi[2])
        q0 = Q[0, 0] * y1[o] + Q[1, 0] * y1[o + 1] + Q[2, 0] * y1[o + 2] - e0
        q1 = Q[0, 1] * y1[o] + Q[1, 1] * y1[o + 1] + Q[2, 1] * y1[o + 2] - e1
        q2 = Q[0, 2] * y1[o] + Q[1, 2] * y1[o + 1] + Q[2, 2] * y1[o + 2] - e2
        y1[o], y1[o + 1], y1[o + 2] = q0, q1, q2
        tangent_attitude_turned(y1, o + 3, Q, tR, w0, w1, w2)  # δR₁ = δR Q + R₁ ŵ
    for r in range(3):
        pi[r] = tpi[r]
        for c2 in range(3):
            y1[3 + 3 * r + c2] = tR[r, c2]
    inc[0], inc[1], inc[2] = u[0], u[1], u[2]
    aux[0] = K[0, 0] * K[0, 0] + K[0, 1] * K[0, 1] + K[0, 2] * K[0, 2]
    return s


#: where the MEGNO sums start in a row of the state and one tangent vector (two blocks of 12)
MEGNO_ROW = 24


@njit(cache=True, inline="always")
def _megno_update(y1, par, h):
    """MEGNO's sums after a step (:func:`lieint.fast.tangent_sums.megno_update`) on the 3D top's
    blocks of 12: Π, then R̃ when the top carries it (``par[12]``)."""
    megno_update(y1, h, 12, 3, par[12] != 0.0)


@njit(cache=True, inline="always")
def _lyapunov_update(y1, par, k):
    """Benettin's re-orthonormalisation when it is due (:func:`lieint.fast.tangent_sums.lyapunov_update`)
    on the 3D top's blocks of 12, every ``par[14]`` of ``par[15]`` steps."""
    lyapunov_update(y1, k, 12, 3, par[12] != 0.0, par[14], par[15])


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


@njit(cache=True)
def form_rkmk_megno_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_rkmk_tangent_step` of the state and one tangent vector, then MEGNO's sums
    (:func:`_megno_update`); −1 when a stage reached the dexp⁻¹ radius."""
    spent = form_rkmk_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    if spent >= 0:
        _megno_update(y1, par, h)
    return spent


@njit(cache=True)
def form_rkmk_lyapunov_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_rkmk_tangent_step`, then the re-orthonormalisation of :func:`_lyapunov_update`
    when it is due; −1 when a stage reached the dexp⁻¹ radius."""
    spent = form_rkmk_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    if spent >= 0:
        _lyapunov_update(y1, par, y.shape[0] // 12 - 1)
    return spent


@njit(cache=True)
def form_products_tangent_scratch(fx, meth, par, d):
    """A product of exponentials' scratch (:func:`lieint.fast.top3.form_products_scratch`), then the
    tangent vectors' stage slopes ``δK`` (k, s, 3), their exponents' ``δu`` (k, 3) and stage
    momenta ``δΠ_i`` (k, 3)."""
    s = meth.c.shape[0]
    k = max(d // 12 - 1, 1)
    return (np.zeros((s, 3)), np.zeros(3), np.zeros((3, 3)), np.zeros(3), np.zeros((3, 3)), np.zeros((k, s, 3)),
            np.zeros((k, 3)), np.zeros((k, 3)))  # fmt: skip


@njit(cache=True, inline="always")
def _exponent_tangent(du, dK, weights, row, upto, h, k):
    """``δu_m = Σ_{j < upto} (h w_j) δK_m[j]`` for every tangent vector m, over the nonzero weights
    of ``weights[row]`` in the order of j (:func:`lieint.fast.top3._exponent`'s combination)."""
    for m in range(k):
        du[m, 0] = 0.0
        du[m, 1] = 0.0
        du[m, 2] = 0.0
    for j in range(upto):
        if weights[row, j] != 0.0:
            w = h * weights[row, j]
            for m in range(k):
                du[m, 0] += w * dK[m, j, 0]
                du[m, 1] += w * dK[m, j, 1]
                du[m, 2] += w * dK[m, j, 2]


@njit(cache=True)
def form_products_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One step of a product of exponentials (the commutator-free and Crouch–Grossman methods) of a
    body's state — :func:`lieint.fast.top3._products_step`'s operations in its order, so its bits —
    and of its tangent vectors in forward mode: each exponential ``Q = exp(u)``, ``u = h Σ_j W_j K_j``,
    moves by ``Qᵀ δQ = ŵ``, ``w = J_r(u) δu``, ``δu = h Σ_j W_j δK_j``, so ``Π ← QᵀΠ`` moves by
    ``δΠ ← QᵀδΠ − w × QᵀΠ`` and ``R̃ ← R̃Q`` by ``δR̃ ← δR̃ Q + R̃Q ŵ``; ``δK_i = I⁻¹ δΠ_i``. Never
    out of range (no dexp⁻¹); ``aux[0] = |w|²`` of the first stage."""
    K, u, Q, tR, dK, du, dp = scr[0], scr[1], scr[2], scr[4], scr[5], scr[6], scr[7]
    d = y.shape[0]
    k = d // 12 - 1
    for i in range(d):
        y1[i] = y[i]
    Iinv = par[0:3]
    weights, bounds = meth.weights, meth.bounds
    s = bounds.shape[0] - 2
    pi = y1[0:3]
    for i in range(s):
        p0, p1, p2 = pi[0], pi[1], pi[2]
        for m in range(k):
            o = 12 * (m + 1)
            dp[m, 0], dp[m, 1], dp[m, 2] = y1[o], y1[o + 1], y1[o + 2]
        for e in range(bounds[i], bounds[i + 1]):
            if not _exponent(u, K, weights, e, i, h):
                continue
            _exponent_tangent(du, dK, weights, e, i, h, k)
            _rodrigues(u, Q)
            q0 = Q[0, 0] * p0 + Q[1, 0] * p1 + Q[2, 0] * p2
            q1 = Q[0, 1] * p0 + Q[1, 1] * p1 + Q[2, 1] * p2
            q2 = Q[0, 2] * p0 + Q[1, 2] * p1 + Q[2, 2] * p2
            p0, p1, p2 = q0, q1, q2
            for m in range(k):
                w0, w1, w2 = _right_jacobian(u[0], u[1], u[2], du[m, 0], du[m, 1], du[m, 2])
                e0, e1, e2 = _cross(w0, w1, w2, p0, p1, p2)
                a0, a1, a2 = rotate_back(Q, dp[m, 0], dp[m, 1], dp[m, 2])
                dp[m, 0], dp[m, 1], dp[m, 2] = a0 - e0, a1 - e1, a2 - e2
        K[i, 0], K[i, 1], K[i, 2] = Iinv[0] * p0, Iinv[1] * p1, Iinv[2] * p2
        for m in range(k):
            dK[m, i, 0], dK[m, i, 1], dK[m, i, 2] = Iinv[0] * dp[m, 0], Iinv[1] * dp[m, 1], Iinv[2] * dp[m, 2]
    first = bounds[s]
    for e in range(first, bounds[s + 1]):
        o3 = 3 * (e - first)
        if not _exponent(u, K, weights, e, s, h):
            inc[o3], inc[o3 + 1], inc[o3 + 2] = 0.0, 0.0, 0.0
            continue
        _exponent_tangent(du, dK, weights, e, s, h, k)
        inc[o3], inc[o3 + 1], inc[o3 + 2] = u[0], u[1], u[2]
        _rodrigues(u, Q)
        p0, p1, p2 = pi[0], pi[1], pi[2]
        for r in range(3):
            pi[r] = Q[0, r] * p0 + Q[1, r] * p1 + Q[2, r] * p2
        for r in range(3):
            for c2 in range(3):
                tR[r, c2] = y1[3 + 3 * r] * Q[0, c2] + y1[4 + 3 * r] * Q[1, c2] + y1[5 + 3 * r] * Q[2, c2]
        for m in range(k):
            o = 12 * (m + 1)
            w0, w1, w2 = _right_jacobian(u[0], u[1], u[2], du[m, 0], du[m, 1], du[m, 2])
            e0, e1, e2 = _cross(w0, w1, w2, pi[0], pi[1], pi[2])
            a0, a1, a2 = rotate_back(Q, y1[o], y1[o + 1], y1[o + 2])
            y1[o], y1[o + 1], y1[o + 2] = a0 - e0, a1 - e1, a2 - e2
            tangent_attitude_turned(y1, o + 3, Q, tR, w0, w1, w2)  # δR₁ = δR Q + R₁ ŵ
        for r in range(3):
            for c2 in range(3):
                y1[3 + 3 * r + c2] = tR[r, c2]
    aux[0] = K[0, 0] * K[0, 0] + K[0, 1] * K[0, 1] + K[0, 2] * K[0, 2]
    return meth.c.shape[0]


@njit(cache=True)
def form_products_megno_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_products_tangent_step` of the state and one tangent vector, then MEGNO's sums."""
    spent = form_products_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    _megno_update(y1, par, h)
    return spent


@njit(cache=True)
def form_products_lyapunov_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_products_tangent_step`, then the re-orthonormalisation when it is due."""
    spent = form_products_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
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

#: the RKMK steps' scratch is the 3D top's (and its projection reads it so)
_RKMK = {**_COMMON, "scratch": form_rkmk_tangent_scratch, "project": form_top3_project}

#: the products of exponentials' steps: their own scratch (the plain step's projection reads its Q)
_PRODUCTS = {**_COMMON, "scratch": form_products_tangent_scratch, "project": form_top3_project}

#: the names of :mod:`lieint.fast.loop` this form binds (fixed steps only, no projection: the
#: projection's derivative is not carried)
NAMESPACES = {
    "splitting": {**_COMMON, "step": form_split_tangent_step},
    "moser_veselov": {**_COMMON, "step": form_mv_tangent_step},
    "splitting_megno": {**_COMMON, "step": form_split_megno_step},
    "moser_veselov_megno": {**_COMMON, "step": form_mv_megno_step},
    "splitting_lyapunov": {**_COMMON, "step": form_split_lyapunov_step},
    "moser_veselov_lyapunov": {**_COMMON, "step": form_mv_lyapunov_step},
    "rkmk": {**_RKMK, "step": form_rkmk_tangent_step},
    "rkmk_megno": {**_RKMK, "step": form_rkmk_megno_step},
    "rkmk_lyapunov": {**_RKMK, "step": form_rkmk_lyapunov_step},
    "cf": {**_PRODUCTS, "step": form_products_tangent_step},
    "cf_megno": {**_PRODUCTS, "step": form_products_megno_step},
    "cf_lyapunov": {**_PRODUCTS, "step": form_products_lyapunov_step},
}
