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

With k = 0 the step is the plain RKMK step of the state alone: one 3D heavy top's fixed-step runs
in exponential coordinates go through it (:class:`lieint.fast.tangent_layouts.HeavyTop3Layout`), about
seven times cheaper a step than the compiled pieces' 3 × 3 matrices.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .se3_tangent import (
    attitude_turned_into,
    combine_stage,
    dexpinv_series,
    dexpinv_series_tangent,
    exponential,
    phi1,
    product_exponent,
    right_jacobian,
    rotate_back,
    tangent_attitude_turned,
    translation,
)
from .tangent_sums import MEGNO_SLOTS, keep_row, lyapunov_update, megno_update, prepare_nothing
from .top3 import _cross

__all__ = ["BLOCK", "FLAT", "MEGNO_SLOTS", "NAMESPACES", "rows_to_user", "user_to_rows"]

#: numbers of one block of a row: Π (3), Γ̃ (3), R̃ (9)
BLOCK = 15
#: the block's numbers perturbed additively (Π and Γ̃); R̃ follows them
FLAT = 6
# (2π)²: the dexp⁻¹ series of se(3) converges for |u_w| < 2π (the translations add no larger
# eigenvalue of ad)
_RADIUS2 = (2.0 * np.pi) ** 2


@njit(cache=True, inline="always")
def _moved(u, du, beta, gamma, dbeta, dgamma, p, g, dp, dg):
    """What a point ``(Π, Γ̃)`` and a tangent vector ``(δΠ, δΓ̃)`` at it become under ``exp(u)``
    moved by ``δu`` (module docstring): ``w = J_r(u_w) δu_w``, ``x = Π + t × Γ̃`` and
    ``δx = δΠ + δt × Γ̃ + t × δΓ̃`` (``Qᵀx`` and ``Qᵀδx − w × Qᵀx`` are the caller's)."""
    w0, w1, w2 = right_jacobian(u, du, beta, gamma)
    t0, t1, t2, dt0, dt1, dt2 = translation(u, du, beta, gamma, dbeta, dgamma)
    x0, x1, x2 = _cross(t0, t1, t2, g[0], g[1], g[2])
    x0, x1, x2 = p[0] + x0, p[1] + x1, p[2] + x2
    y0, y1, y2 = _cross(dt0, dt1, dt2, g[0], g[1], g[2])
    z0, z1, z2 = _cross(t0, t1, t2, dg[0], dg[1], dg[2])
    dx0, dx1, dx2 = dp[0] + y0 + z0, dp[1] + y1 + z1, dp[2] + y2 + z2
    return w0, w1, w2, x0, x1, x2, dx0, dx1, dx2


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
    p, g = y1[0:3], y1[3:6]
    for i in range(s + 1):  # the stages, then (i = s) the step's end
        combine_stage(i, A, b, h, K, dK, u, du, k)
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
        beta, gamma, dbeta, dgamma = exponential(u, Q)  # one sine and cosine for Q and the coefficients
        if i == s:  # the step's end: exp(u) turns the block and its tangent vectors
            _turn(y1, BLOCK, k, u, du, Q, beta, gamma, dbeta, dgamma, orient, newR)
            for c in range(6):
                if c < inc.shape[0]:
                    inc[c] = u[c]
            aux[0] = K[0, 0] * K[0, 0] + K[0, 1] * K[0, 1] + K[0, 2] * K[0, 2]
            return s
        b0, b1, b2 = u[3], u[4], u[5]
        t0, t1, t2_ = phi1(u[0], u[1], u[2], b0, b1, b2, beta, gamma)
        x0, x1, x2 = _cross(t0, t1, t2_, g[0], g[1], g[2])
        pi0, pi1, pi2 = rotate_back(Q, p[0] + x0, p[1] + x1, p[2] + x2)
        # a stage: ξ at the moved state and its truncated dexp⁻¹ series, K_i = Σ c_d T_d
        xw0, xw1, xw2 = Iinv[0] * pi0, Iinv[1] * pi1, Iinv[2] * pi2
        for m in range(k):
            o = BLOCK * (m + 1)
            w0, w1, w2, _, _, _, dx0, dx1, dx2 = _moved(
                u, du[m], beta, gamma, dbeta, dgamma, p, g, y1[o : o + 3], y1[o + 3 : o + 6]
            )
            q0, q1, q2 = rotate_back(Q, dx0, dx1, dx2)
            e0, e1, e2 = _cross(w0, w1, w2, pi0, pi1, pi2)
            # δξ_i = (I⁻¹δΠ_i, 0)
            D0, D1, D2 = Iinv[0] * (q0 - e0), Iinv[1] * (q1 - e1), Iinv[2] * (q2 - e2)
            k0, k1, k2, k3, k4, k5 = dexpinv_series_tangent(
                u, du[m], coeffs, xw0, xw1, xw2, v[0], v[1], v[2], D0, D1, D2, 0.0, 0.0, 0.0
            )
            dK[m, i, 0], dK[m, i, 1], dK[m, i, 2] = k0, k1, k2
            dK[m, i, 3], dK[m, i, 4], dK[m, i, 5] = k3, k4, k5
        k0, k1, k2, k3, k4, k5 = dexpinv_series(u, coeffs, xw0, xw1, xw2, v[0], v[1], v[2])
        K[i, 0], K[i, 1], K[i, 2], K[i, 3], K[i, 4], K[i, 5] = k0, k1, k2, k3, k4, k5
    return s  # not reached: the loop returns at i = s


@njit(cache=True)
def form_products_scratch(fx, meth, par, d):
    """:func:`form_scratch`'s arrays for s = the method's stages, then a stage's point ``(Π, Γ̃)``
    and its k tangent vectors, six numbers each."""
    s = meth.c.shape[0]
    k = max(d // BLOCK - 1, 1)
    return (np.zeros((s, 6)), np.zeros((k, s, 6)), np.zeros(6), np.zeros((k, 6)), np.zeros((3, 3)), np.zeros((3, 3)),
            np.zeros(6 * (k + 1)))  # fmt: skip


@njit(cache=True)  # not inlined: inlined into the RKMK step it slowed the plain step by a third
def _turn(arr, stride, k, u, du, Q, beta, gamma, dbeta, dgamma, attitude, newR):
    """The point ``(Π, Γ̃) = arr[0:6]`` and its k tangent vectors (``arr[stride (m + 1):]``) under the
    right action of ``exp(u)`` moved by ``δu`` (module docstring), in place, ``Q = exp(u_w)`` and the
    coefficients of u given; with ``attitude`` the block's R̃ (at 6) and the tangent vectors' δR̃ too
    (``R̃ ← R̃Q``, ``δR̃ ← δR̃ Q + R̃₁ ŵ``)."""
    p, g = arr[0:3], arr[3:6]
    t0, t1, t2_ = phi1(u[0], u[1], u[2], u[3], u[4], u[5], beta, gamma)
    x0, x1, x2 = _cross(t0, t1, t2_, g[0], g[1], g[2])
    pi0, pi1, pi2 = rotate_back(Q, p[0] + x0, p[1] + x1, p[2] + x2)
    g0, g1, g2 = rotate_back(Q, g[0], g[1], g[2])
    if attitude:
        attitude_turned_into(arr, 6, Q, newR)
    for m in range(k):  # the tangent vectors first: they read the point before it moves
        o = stride * (m + 1)
        w0, w1, w2, _, _, _, dx0, dx1, dx2 = _moved(u, du[m], beta, gamma, dbeta, dgamma, p, g, arr[o : o + 3],
                                                    arr[o + 3 : o + 6])  # fmt: skip
        q0, q1, q2 = rotate_back(Q, dx0, dx1, dx2)
        e0, e1, e2 = _cross(w0, w1, w2, pi0, pi1, pi2)
        r0, r1, r2 = rotate_back(Q, arr[o + 3], arr[o + 4], arr[o + 5])
        f0, f1, f2 = _cross(w0, w1, w2, g0, g1, g2)
        arr[o], arr[o + 1], arr[o + 2] = q0 - e0, q1 - e1, q2 - e2
        arr[o + 3], arr[o + 4], arr[o + 5] = r0 - f0, r1 - f1, r2 - f2
        if attitude:
            tangent_attitude_turned(arr, o + 6, Q, newR, w0, w1, w2)
    arr[0], arr[1], arr[2] = pi0, pi1, pi2
    arr[3], arr[4], arr[5] = g0, g1, g2
    if attitude:
        for r in range(3):
            for c in range(3):
                arr[6 + 3 * r + c] = newR[r, c]


@njit(cache=True)
def form_products_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One step of a product of exponentials (the commutator-free and Crouch–Grossman methods) of a
    top's state and its tangent vectors in forward mode: stage i turns ``(Π, Γ̃)`` and their
    tangent vectors by its exponentials ``exp(h Σ_j W_j K_j)`` one after the other (:func:`_turn`),
    ``K_i = (I⁻¹Π_i, M X̃_G)``, ``δK_i = (I⁻¹δΠ_i, 0)``; the step turns the whole block, R̃ included, by
    its own. No dexp⁻¹, so never out of range; ``aux[0] = |ξ_w(y)|²``."""
    K, dK, u, du, Q, newR, st = scr[0], scr[1], scr[2], scr[3], scr[4], scr[5], scr[6]
    d = y.shape[0]
    k = d // BLOCK - 1
    for i in range(d):
        y1[i] = y[i]
    Iinv, v = par[0:3], par[3:6]
    orient = par[6] != 0.0
    weights, bounds = meth.weights, meth.bounds
    s = bounds.shape[0] - 2
    for i in range(s):
        for m in range(k + 1):  # the stage's point (Π, Γ̃) and its tangent vectors, from y
            for c in range(6):
                st[6 * m + c] = y1[BLOCK * m + c]
        for e in range(bounds[i], bounds[i + 1]):
            if product_exponent(u, du, K, dK, weights, e, i, h, k):
                beta, gamma, dbeta, dgamma = exponential(u, Q)
                _turn(st, 6, k, u, du, Q, beta, gamma, dbeta, dgamma, False, newR)
        for c in range(3):
            K[i, c] = Iinv[c] * st[c]
            K[i, 3 + c] = v[c]
            for m in range(k):
                dK[m, i, c] = Iinv[c] * st[6 * (m + 1) + c]
                dK[m, i, 3 + c] = 0.0
    first = bounds[s]
    for e in range(first, bounds[s + 1]):
        o = 6 * (e - first)
        if not product_exponent(u, du, K, dK, weights, e, s, h, k):
            for c in range(6):
                if o + c < inc.shape[0]:
                    inc[o + c] = 0.0
            continue
        for c in range(6):
            if o + c < inc.shape[0]:
                inc[o + c] = u[c]
        beta, gamma, dbeta, dgamma = exponential(u, Q)
        _turn(y1, BLOCK, k, u, du, Q, beta, gamma, dbeta, dgamma, orient, newR)
    aux[0] = K[0, 0] * K[0, 0] + K[0, 1] * K[0, 1] + K[0, 2] * K[0, 2]
    return meth.c.shape[0]


@njit(cache=True)
def form_products_megno_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_products_tangent_step` of the state and one tangent vector, then MEGNO's sums."""
    spent = form_products_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    megno_update(y1, h, BLOCK, FLAT, par[6] != 0.0)
    return spent


@njit(cache=True)
def form_products_lyapunov_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_products_tangent_step`, then the re-orthonormalisation when it is due."""
    spent = form_products_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    lyapunov_update(y1, y.shape[0] // BLOCK - 1, BLOCK, FLAT, par[6] != 0.0, par[7], par[8])
    return spent


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


_COMMON = {"prepare": prepare_nothing, "scratch": form_scratch, "project": keep_row, "radius2": form_radius2}

#: the names of :mod:`lieint.fast.loop` this form binds (fixed steps only, no projection: the
#: projection's derivative is not carried; the adaptive loop's names are left unbound)
NAMESPACES = {
    "rkmk": {**_COMMON, "step": form_rkmk_tangent_step},
    "rkmk_megno": {**_COMMON, "step": form_rkmk_megno_step},
    "rkmk_lyapunov": {**_COMMON, "step": form_rkmk_lyapunov_step},
    "cf": {**_COMMON, "scratch": form_products_scratch, "step": form_products_tangent_step},
    "cf_megno": {**_COMMON, "scratch": form_products_scratch, "step": form_products_megno_step},
    "cf_lyapunov": {**_COMMON, "scratch": form_products_scratch, "step": form_products_lyapunov_step},
}


@njit(cache=True)
def rows_to_user(Y, P, identity, orientation, A, G, R):
    """The user's fields of the blocks ``Y`` (M, ≥ 15: Π, Γ̃, R̃ in the principal frame, or a
    tangent vector's δΠ, δΓ̃, δR̃), into ``A`` (M, 3, 3), ``G`` (M, 3) and, with ``orientation``,
    ``R`` (M, 3, 3): ``A = −(PΠ)^``, ``Γ = PΓ̃``, ``R = R̃Pᵀ`` (conjugation by a proper P moves the
    vector of a hat matrix by P; the change of frame is linear, so tangent vectors move alike).
    ``identity``: P = I, the blocks copied (products with I would turn −0.0 into 0.0)."""
    for m in range(Y.shape[0]):
        if identity:
            p0, p1, p2 = Y[m, 0], Y[m, 1], Y[m, 2]
            G[m, 0], G[m, 1], G[m, 2] = Y[m, 3], Y[m, 4], Y[m, 5]
        else:
            p0 = P[0, 0] * Y[m, 0] + P[0, 1] * Y[m, 1] + P[0, 2] * Y[m, 2]
            p1 = P[1, 0] * Y[m, 0] + P[1, 1] * Y[m, 1] + P[1, 2] * Y[m, 2]
            p2 = P[2, 0] * Y[m, 0] + P[2, 1] * Y[m, 1] + P[2, 2] * Y[m, 2]
            for r in range(3):
                G[m, r] = P[r, 0] * Y[m, 3] + P[r, 1] * Y[m, 4] + P[r, 2] * Y[m, 5]
        A[m, 0, 0], A[m, 0, 1], A[m, 0, 2] = 0.0, p2, -p1
        A[m, 1, 0], A[m, 1, 1], A[m, 1, 2] = -p2, 0.0, p0
        A[m, 2, 0], A[m, 2, 1], A[m, 2, 2] = p1, -p0, 0.0
        if orientation:
            for r in range(3):
                for c in range(3):
                    if identity:
                        R[m, r, c] = Y[m, 6 + 3 * r + c]
                    else:
                        R[m, r, c] = Y[m, 6 + 3 * r] * P[c, 0] + Y[m, 7 + 3 * r] * P[c, 1] + Y[m, 8 + 3 * r] * P[c, 2]


@njit(cache=True)
def user_to_rows(A, G, R, P, identity, orientation, tangent, Y):
    """:func:`rows_to_user`'s inverse: the blocks ``Y`` (M, 15) of the user's ``A`` (M, 3, 3), ``G``
    (M, 3) and ``R`` (M, 3, 3; read only with ``orientation``): ``Π = Pᵀ(−vee A)``, ``Γ̃ = PᵀΓ``,
    ``R̃ = R P``. Without attitude R̃ is I for a state and 0 for a tangent vector (``tangent``)."""
    for m in range(Y.shape[0]):
        a0 = -0.5 * (A[m, 2, 1] - A[m, 1, 2])  # −vee A (its skew part's, as top3.minus_vee)
        a1 = -0.5 * (A[m, 0, 2] - A[m, 2, 0])
        a2 = -0.5 * (A[m, 1, 0] - A[m, 0, 1])
        if identity:
            Y[m, 0], Y[m, 1], Y[m, 2] = a0, a1, a2
            Y[m, 3], Y[m, 4], Y[m, 5] = G[m, 0], G[m, 1], G[m, 2]
        else:
            for c in range(3):
                Y[m, c] = P[0, c] * a0 + P[1, c] * a1 + P[2, c] * a2
                Y[m, 3 + c] = P[0, c] * G[m, 0] + P[1, c] * G[m, 1] + P[2, c] * G[m, 2]
        for r in range(3):
            for c in range(3):
                if not orientation:
                    Y[m, 6 + 3 * r + c] = 1.0 if (r == c and not tangent) else 0.0
                elif identity:
                    Y[m, 6 + 3 * r + c] = R[m, r, c]
                else:
                    Y[m, 6 + 3 * r + c] = R[m, r, 0] * P[0, c] + R[m, r, 1] * P[1, c] + R[m, r, 2] * P[2, c]
