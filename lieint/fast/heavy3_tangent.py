"""The tangent maps of the 3D heavy top's RKMK methods as forms of the one compiled loop (forward
mode, numba, cached on disk).

A body's row is its state in the principal frame of its top, ``(Π, Γ̃, R̃)`` (15 numbers: ``A = −Π̂``
in that frame, ``Γ̃ = PᵀΓ``, ``R̃ = R P``), followed by k tangent vectors ``(δΠ, δΓ̃, δR̃)`` of the
same layout: ``d = 15 (1 + k)``. The step is RKMK on ``SE(3)`` in exponential coordinates with
dexp⁻¹ truncated at the method's degree (the heavy top's equations, docs/theory.md §4): the
generator is ``ξ = (w, v) = (I⁻¹Π, M X̃_G)`` (its translation part constant), the right action
of ``(exp û, t)``, ``t = φ₁(û) u_v = u_v + β u × u_v + γ u × (u × u_v)`` (``β = (1 − cos θ)/θ²``,
``γ = (θ − sin θ)/θ³``, θ = |u|), is::

    Π ← Qᵀ(Π + t × Γ̃),   Γ̃ ← QᵀΓ̃,   R̃ ← R̃ Q,   Q = exp û,

and the bracket of se(3) is ``ad_{−u}(x, y) = (x × u_w, y × u_w + x × u_v)``. Each tangent vector
moves by the derivative of that step, differentiated by hand:

* a stage's ``δu = h Σ a_ij δK_j``; ``exp(u_w)`` moves by ``Qᵀ δQ = (J_r(u_w) δu_w)^`` (the right
  Jacobian of so(3), as in :mod:`lieint.fast.top3_tangent`), so ``δ(Qᵀx) = Qᵀδx − w × Qᵀx``;
* ``δt = φ₁(u_w) δu_v + δβ u_w × u_v + β δu_w × u_v + δγ u_w × (u_w × u_v)
  + γ (δu_w × (u_w × u_v) + u_w × (δu_w × u_v))`` with ``δβ = 2β′ ⟨u_w, δu_w⟩`` and the same for γ
  (β′, γ′ the derivatives in θ²: ``(sin θ/(2θ) − β)/θ²`` and ``(β − 3γ)/(2θ²)``, their series below
  θ = 0.1);
* the truncated series' terms ``T_d = ad_{−u} T_{d−1}`` by
  ``δT_d = ad_{−δu} T_{d−1} + ad_{−u} δT_{d−1}``, ``δξ = (I⁻¹ δΠ_i, 0)``;
* the step's end by the product rule, ``δR̃₁ = δR̃ Q + R̃₁ ŵ``.

This is the derivative of the map the method computes: the tangent map the complex step of
:mod:`lieint.tangent.flow` computes on the generic path, to round-off (the state itself is stepped
in vector form here, the generic path's compiled pieces in matrices: the two agree to round-off,
not to the bit). A top without attitude carries R̃ = I and δR̃ = 0, untouched.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .tangent_sums import MEGNO_SLOTS, lyapunov_update, megno_update
from .top3 import _cross, _rodrigues

__all__ = ["BLOCK", "FLAT", "MEGNO_SLOTS", "NAMESPACES"]

#: numbers of one block of a row: Π (3), Γ̃ (3), R̃ (9)
BLOCK = 15
#: the block's numbers perturbed additively (Π and Γ̃); R̃ follows them
FLAT = 6
# (2π)²: the dexp⁻¹ series of se(3) converges for |u_w| < 2π (the translations add no larger
# eigenvalue of ad)
_RADIUS2 = (2.0 * np.pi) ** 2


@njit(cache=True, inline="always")
def _coefficients(t2):
    """``β = (1 − cos θ)/θ²``, ``γ = (θ − sin θ)/θ³`` and their derivatives in ``t2 = θ²``; below
    θ = 0.1 their even series (the first omitted terms below 1e-20 relative)."""
    if t2 < 1e-2:
        beta = 0.5 + t2 * (-1.0 / 24 + t2 * (1.0 / 720 + t2 * (-1.0 / 40320 + t2 * (1.0 / 3628800))))
        gamma = 1.0 / 6 + t2 * (-1.0 / 120 + t2 * (1.0 / 5040 + t2 * (-1.0 / 362880 + t2 * (1.0 / 39916800))))
        dbeta = -1.0 / 24 + t2 * (2.0 / 720 + t2 * (-3.0 / 40320 + t2 * (4.0 / 3628800 + t2 * (-5.0 / 479001600))))
        dgamma = -1.0 / 120 + t2 * (2.0 / 5040 + t2 * (-3.0 / 362880 + t2 * (4.0 / 39916800 - t2 * 5.0 / 6227020800)))
        return beta, gamma, dbeta, dgamma
    th = np.sqrt(t2)
    s = np.sin(th)
    beta = (1.0 - np.cos(th)) / t2
    gamma = (th - s) / (t2 * th)
    return beta, gamma, (0.5 * s / th - beta) / t2, (beta - 3.0 * gamma) / (2.0 * t2)


@njit(cache=True, inline="always")
def _phi1(a0, a1, a2, b0, b1, b2, beta, gamma):
    """``φ₁(â) b = b + β a × b + γ a × (a × b)``."""
    c0, c1, c2 = _cross(a0, a1, a2, b0, b1, b2)
    e0, e1, e2 = _cross(a0, a1, a2, c0, c1, c2)
    return b0 + beta * c0 + gamma * e0, b1 + beta * c1 + gamma * e1, b2 + beta * c2 + gamma * e2


@njit(cache=True, inline="always")
def _rotate_back(Q, x0, x1, x2):
    """``Qᵀx``."""
    return (
        Q[0, 0] * x0 + Q[1, 0] * x1 + Q[2, 0] * x2,
        Q[0, 1] * x0 + Q[1, 1] * x1 + Q[2, 1] * x2,
        Q[0, 2] * x0 + Q[1, 2] * x1 + Q[2, 2] * x2,
    )


@njit(cache=True, inline="always")
def _moved(u, du, beta, gamma, dbeta, dgamma, p, g, dp, dg):
    """What a point ``(Π, Γ̃)`` and a tangent vector ``(δΠ, δΓ̃)`` at it become under ``exp(u)``
    moved by ``δu`` (module docstring): ``w = J_r(u_w) δu_w``, ``x = Π + t × Γ̃`` and
    ``δx = δΠ + δt × Γ̃ + t × δΓ̃`` (``Qᵀx`` and ``Qᵀδx − w × Qᵀx`` are the caller's)."""
    a0, a1, a2 = u[0], u[1], u[2]
    d0, d1, d2 = du[0], du[1], du[2]
    # w = J_r(a) δa = δa − β a × δa + γ a × (a × δa)
    c0, c1, c2 = _cross(a0, a1, a2, d0, d1, d2)
    e0, e1, e2 = _cross(a0, a1, a2, c0, c1, c2)
    w0, w1, w2 = d0 - beta * c0 + gamma * e0, d1 - beta * c1 + gamma * e1, d2 - beta * c2 + gamma * e2
    # t = φ₁(a) b and δt
    b0, b1, b2 = u[3], u[4], u[5]
    t0, t1, t2 = _phi1(a0, a1, a2, b0, b1, b2, beta, gamma)
    f0, f1, f2 = _phi1(a0, a1, a2, du[3], du[4], du[5], beta, gamma)  # φ₁(a) δb
    ab0, ab1, ab2 = _cross(a0, a1, a2, b0, b1, b2)  # a × b
    aab0, aab1, aab2 = _cross(a0, a1, a2, ab0, ab1, ab2)  # a × (a × b)
    db0, db1, db2 = _cross(d0, d1, d2, b0, b1, b2)  # δa × b
    q0, q1, q2 = _cross(d0, d1, d2, ab0, ab1, ab2)  # δa × (a × b)
    r0, r1, r2 = _cross(a0, a1, a2, db0, db1, db2)  # a × (δa × b)
    two_dot = 2.0 * (a0 * d0 + a1 * d1 + a2 * d2)
    dbe, dga = dbeta * two_dot, dgamma * two_dot
    dt0 = f0 + dbe * ab0 + beta * db0 + dga * aab0 + gamma * (q0 + r0)
    dt1 = f1 + dbe * ab1 + beta * db1 + dga * aab1 + gamma * (q1 + r1)
    dt2 = f2 + dbe * ab2 + beta * db2 + dga * aab2 + gamma * (q2 + r2)
    x0, x1, x2 = _cross(t0, t1, t2, g[0], g[1], g[2])
    x0, x1, x2 = p[0] + x0, p[1] + x1, p[2] + x2
    y0, y1, y2 = _cross(dt0, dt1, dt2, g[0], g[1], g[2])
    z0, z1, z2 = _cross(t0, t1, t2, dg[0], dg[1], dg[2])
    dx0, dx1, dx2 = dp[0] + y0 + z0, dp[1] + y1 + z1, dp[2] + y2 + z2
    return w0, w1, w2, x0, x1, x2, dx0, dx1, dx2


@njit(cache=True, inline="always")
def _ad_minus(u, x0, x1, x2, y0, y1, y2):
    """``ad_{−u}(x, y) = (x × u_w, y × u_w + x × u_v)`` on se(3)."""
    a0, a1, a2 = _cross(x0, x1, x2, u[0], u[1], u[2])
    b0, b1, b2 = _cross(y0, y1, y2, u[0], u[1], u[2])
    c0, c1, c2 = _cross(x0, x1, x2, u[3], u[4], u[5])
    return a0, a1, a2, b0 + c0, b1 + c1, b2 + c2


@njit(cache=True)
def form_prepare(ctx):
    """Nothing to prepare: the stage code is in this module."""
    return ctx


@njit(cache=True)
def form_scratch(fx, meth, par, d):
    """The stage slopes ``K`` (s, 6) and the tangent vectors' ``δK`` (k, s, 6), the stage's ``u``
    (6) and ``δu`` (k, 6), Q and the state's new R̃ (3, 3)."""
    s = meth.b.shape[0]
    k = max(d // BLOCK - 1, 1)
    return np.zeros((s, 6)), np.zeros((k, s, 6)), np.zeros(6), np.zeros((k, 6)), np.zeros((3, 3)), np.zeros((3, 3))


@njit(cache=True)
def form_radius2(fx, y, par, scr):
    """``|w|²``, ``w = I⁻¹Π``: the squared ad spectral radius of ξ on se(3) (the translations add
    no larger eigenvalue)."""
    w0, w1, w2 = par[0] * y[0], par[1] * y[1], par[2] * y[2]
    return w0 * w0 + w1 * w1 + w2 * w2


@njit(cache=True)
def form_project(fx, y, par, out, scr):
    """The row as it is: a run of tangent vectors does not project (the projection's derivative
    is not carried, :class:`lieint.tangent.compiled.CompiledTangent` runs with ``project=False``)."""
    for i in range(y.shape[0]):
        out[i] = y[i]


@njit(cache=True)
def form_rkmk_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One RKMK step (exponential coordinates, dexp⁻¹ truncated at ``meth.coeffs``) of a body's
    state and of its tangent vectors in forward mode (module docstring); ``inc`` = the step's
    increment ``(u_w, u_v)``, ``aux[0]`` = ``|ξ_w(y)|²``. Returns the stages, or −1 when a stage
    reaches the dexp⁻¹ radius (as the plain step)."""
    K, dK, u, du, Q, newR = scr[0], scr[1], scr[2], scr[3], scr[4], scr[5]
    d = y.shape[0]
    k = d // BLOCK - 1
    for i in range(d):
        y1[i] = y[i]
    Iinv, v = par[0:3], par[3:6]
    orient = par[6] != 0.0
    A, b, coeffs = meth.A, meth.b, meth.coeffs
    s = b.shape[0]
    degree = coeffs.shape[0] - 1
    p, g = y1[0:3], y1[3:6]
    for i in range(s + 1):  # the stages, then (i = s) the step's end
        for c in range(6):
            u[c] = 0.0
        for m in range(k):
            for c in range(6):
                du[m, c] = 0.0
        for j in range(i if i < s else s):
            weight = A[i, j] if i < s else b[j]
            if weight != 0.0:
                hw = h * weight
                for c in range(6):
                    u[c] += hw * K[j, c]
                for m in range(k):
                    for c in range(6):
                        du[m, c] += hw * dK[m, j, c]
        if i == 0:  # u = 0 and δu = 0: K₀ = ξ(y), δK₀ = (I⁻¹δΠ, 0)
            for c in range(3):
                K[0, c] = Iinv[c] * p[c]
                K[0, 3 + c] = v[c]
            for m in range(k):
                o = BLOCK * (m + 1)
                for c in range(3):
                    dK[m, 0, c] = Iinv[c] * y1[o + c]
                    dK[m, 0, 3 + c] = 0.0
            continue
        t2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2]
        if i < s and t2 >= _RADIUS2:
            return -1
        _rodrigues(u, Q)
        beta, gamma, dbeta, dgamma = _coefficients(t2)
        b0, b1, b2 = u[3], u[4], u[5]
        t0, t1, t2_ = _phi1(u[0], u[1], u[2], b0, b1, b2, beta, gamma)
        x0, x1, x2 = _cross(t0, t1, t2_, g[0], g[1], g[2])
        pi0, pi1, pi2 = _rotate_back(Q, p[0] + x0, p[1] + x1, p[2] + x2)
        if i == s:  # the step's end: the tangent vectors first, they read the state before it moves
            g0, g1, g2 = _rotate_back(Q, g[0], g[1], g[2])
            for r in range(3):
                for c in range(3):
                    newR[r, c] = y1[6 + 3 * r] * Q[0, c] + y1[7 + 3 * r] * Q[1, c] + y1[8 + 3 * r] * Q[2, c]
            for m in range(k):
                o = BLOCK * (m + 1)
                w0, w1, w2, _, _, _, dx0, dx1, dx2 = _moved(
                    u, du[m], beta, gamma, dbeta, dgamma, p, g, y1[o : o + 3], y1[o + 3 : o + 6]
                )
                q0, q1, q2 = _rotate_back(Q, dx0, dx1, dx2)
                e0, e1, e2 = _cross(w0, w1, w2, pi0, pi1, pi2)
                r0, r1, r2 = _rotate_back(Q, y1[o + 3], y1[o + 4], y1[o + 5])
                f0, f1, f2 = _cross(w0, w1, w2, g0, g1, g2)
                y1[o], y1[o + 1], y1[o + 2] = q0 - e0, q1 - e1, q2 - e2
                y1[o + 3], y1[o + 4], y1[o + 5] = r0 - f0, r1 - f1, r2 - f2
                if orient:  # δR̃₁ = δR̃ Q + R̃₁ ŵ, ŵ = [[0, −w2, w1], [w2, 0, −w0], [−w1, w0, 0]]
                    for r in range(3):
                        e = o + 6 + 3 * r
                        s0, s1, s2 = y1[e], y1[e + 1], y1[e + 2]
                        n0, n1, n2 = newR[r, 0], newR[r, 1], newR[r, 2]
                        y1[e] = (s0 * Q[0, 0] + s1 * Q[1, 0] + s2 * Q[2, 0]) + (n1 * w2 - n2 * w1)
                        y1[e + 1] = (s0 * Q[0, 1] + s1 * Q[1, 1] + s2 * Q[2, 1]) + (n2 * w0 - n0 * w2)
                        y1[e + 2] = (s0 * Q[0, 2] + s1 * Q[1, 2] + s2 * Q[2, 2]) + (n0 * w1 - n1 * w0)
            y1[0], y1[1], y1[2] = pi0, pi1, pi2
            y1[3], y1[4], y1[5] = g0, g1, g2
            if orient:
                for r in range(3):
                    for c in range(3):
                        y1[6 + 3 * r + c] = newR[r, c]
            for c in range(6):
                if c < inc.shape[0]:
                    inc[c] = u[c]
            aux[0] = K[0, 0] * K[0, 0] + K[0, 1] * K[0, 1] + K[0, 2] * K[0, 2]
            return s
        # a stage: ξ at the moved state and its truncated dexp⁻¹ series, K_i = Σ c_d T_d
        xw0, xw1, xw2 = Iinv[0] * pi0, Iinv[1] * pi1, Iinv[2] * pi2
        for m in range(k):
            o = BLOCK * (m + 1)
            w0, w1, w2, _, _, _, dx0, dx1, dx2 = _moved(
                u, du[m], beta, gamma, dbeta, dgamma, p, g, y1[o : o + 3], y1[o + 3 : o + 6]
            )
            q0, q1, q2 = _rotate_back(Q, dx0, dx1, dx2)
            e0, e1, e2 = _cross(w0, w1, w2, pi0, pi1, pi2)
            # T₀ = ξ_i, δT₀ = (I⁻¹δΠ_i, 0)
            T0, T1, T2, T3, T4, T5 = xw0, xw1, xw2, v[0], v[1], v[2]
            D0, D1, D2 = Iinv[0] * (q0 - e0), Iinv[1] * (q1 - e1), Iinv[2] * (q2 - e2)
            D3, D4, D5 = 0.0, 0.0, 0.0
            k0, k1, k2, k3, k4, k5 = D0, D1, D2, D3, D4, D5
            for dd in range(1, degree + 1):
                a0, a1, a2, a3, a4, a5 = _ad_minus(du[m], T0, T1, T2, T3, T4, T5)
                c0, c1, c2, c3, c4, c5 = _ad_minus(u, D0, D1, D2, D3, D4, D5)
                D0, D1, D2, D3, D4, D5 = a0 + c0, a1 + c1, a2 + c2, a3 + c3, a4 + c4, a5 + c5
                T0, T1, T2, T3, T4, T5 = _ad_minus(u, T0, T1, T2, T3, T4, T5)
                cd = coeffs[dd]
                if cd != 0.0:
                    k0 += cd * D0
                    k1 += cd * D1
                    k2 += cd * D2
                    k3 += cd * D3
                    k4 += cd * D4
                    k5 += cd * D5
            dK[m, i, 0], dK[m, i, 1], dK[m, i, 2] = k0, k1, k2
            dK[m, i, 3], dK[m, i, 4], dK[m, i, 5] = k3, k4, k5
        T0, T1, T2, T3, T4, T5 = xw0, xw1, xw2, v[0], v[1], v[2]
        k0, k1, k2, k3, k4, k5 = T0, T1, T2, T3, T4, T5
        for dd in range(1, degree + 1):
            T0, T1, T2, T3, T4, T5 = _ad_minus(u, T0, T1, T2, T3, T4, T5)
            cd = coeffs[dd]
            if cd != 0.0:
                k0 += cd * T0
                k1 += cd * T1
                k2 += cd * T2
                k3 += cd * T3
                k4 += cd * T4
                k5 += cd * T5
        K[i, 0], K[i, 1], K[i, 2], K[i, 3], K[i, 4], K[i, 5] = k0, k1, k2, k3, k4, k5
    return s  # not reached: the loop returns at i = s


@njit(cache=True)
def form_rkmk_megno_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_rkmk_tangent_step` of the state and one tangent vector, then MEGNO's sums
    (:func:`lieint.fast.tangent_sums.megno_update`); −1 when a stage reached the dexp⁻¹ radius."""
    spent = form_rkmk_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    if spent >= 0:
        megno_update(y1, h, BLOCK, FLAT, par[6] != 0.0)
    return spent


@njit(cache=True)
def form_rkmk_lyapunov_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_rkmk_tangent_step`, then the re-orthonormalisation of
    :func:`lieint.fast.tangent_sums.lyapunov_update` when it is due (every ``par[7]`` of ``par[8]``
    steps); −1 when a stage reached the dexp⁻¹ radius."""
    spent = form_rkmk_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    if spent >= 0:
        lyapunov_update(y1, y.shape[0] // BLOCK - 1, BLOCK, FLAT, par[6] != 0.0, par[7], par[8])
    return spent


_COMMON = {"prepare": form_prepare, "scratch": form_scratch, "project": form_project, "radius2": form_radius2}

#: the names of :mod:`lieint.fast.loop` this form binds (fixed steps only, no projection: the
#: projection's derivative is not carried; the adaptive loop's names are left unbound)
NAMESPACES = {
    "rkmk": {**_COMMON, "step": form_rkmk_tangent_step},
    "rkmk_megno": {**_COMMON, "step": form_rkmk_megno_step},
    "rkmk_lyapunov": {**_COMMON, "step": form_rkmk_lyapunov_step},
}
