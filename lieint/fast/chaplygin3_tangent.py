"""The tangent maps of the 3D Chaplygin ball's RKMK methods as forms of the one compiled loop
(forward mode, numba, cached on disk).

A body's row is its state in the user's frame (the contact tensor turns with Γ: there is no fixed
principal frame), ``(Π, Γ, c, R)`` (18 numbers: ``A_K = −Π̂``, the centre c, zero when it is not
tracked, and R, the identity without attitude), followed by k tangent vectors
``(δΠ, δΓ, δc, δR)`` of the same layout: ``d = 18 (1 + k)``. The step is RKMK in exponential
coordinates with dexp⁻¹ truncated at the method's degree (docs/theory.md §5): the generator is
``ξ = (ω, r ω × Γ)`` on se(3) (``(ω, 0)`` when the centre is not tracked), ω from ``M_K ω = Π``,
``M_K = J + M r² (|Γ|² I − ΓΓᵀ)``, ``J = tr(B_C) I − B_C``; the right action of ``(exp û, t)``,
``t = φ₁(û) u_v``, is::

    Π ← QᵀΠ,   Γ ← QᵀΓ,   c ← c + R t,   R ← R Q,   Q = exp û.

Each tangent vector moves by the derivative of that step (:mod:`lieint.fast.se3_tangent` for
``exp``, ``t`` and the series): ``δω = M_K⁻¹(δΠ − δM_K ω)``,
``δM_K ω = M r² (2⟨Γ, δΓ⟩ ω − ⟨Γ, ω⟩ δΓ − ⟨δΓ, ω⟩ Γ)``; ``δξ = (δω, r (δω × Γ + ω × δΓ))``;
a stage's ``δ(QᵀΠ) = QᵀδΠ − w × QᵀΠ`` (``w = J_r(u_w) δu_w``), the same for Γ; the step's end
``δc₁ = δc + δR t + R δt``, ``δR₁ = δR Q + R₁ ŵ``.

This is the derivative of the map the method computes: the tangent map the complex step of
:mod:`lieint.tangent.flow` computes on the generic path, to round-off (the state is stepped in
vectors here, the generic path's compiled pieces solve a Lyapunov equation in matrices: the two
agree to round-off, not to the bit).

With k = 0 the step is the plain RKMK step of the state alone: one 3D Chaplygin ball's
fixed-step runs in exponential coordinates go through it (:class:`lieint.fast.tangent_layouts.Chaplygin3Layout`),
about six times cheaper a step than the compiled pieces.
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

#: numbers of one block of a row: Π (3), Γ (3), the centre (3), R (9)
BLOCK = 18
#: the block's numbers perturbed additively (Π, Γ, the centre); R follows them
FLAT = 9
# parameters: J (9), M r², r, whether the ball carries R, whether it tracks its centre, then
# (Lyapunov) every, total
_MR2, _RADIUS, _ORIENT, _TRACK, _EVERY, _TOTAL = 9, 10, 11, 12, 13, 14
_RADIUS2 = (2.0 * np.pi) ** 2


@njit(cache=True)
def user_to_rows(A, G, c, R, center, orientation, tangent, Y):
    """The blocks ``Y`` (M, 18) of the user's ``A`` (M, 3, 3), ``Γ`` (M, 3), centre ``c`` (M, 3;
    read only with ``center``) and ``R`` (M, 3, 3; read only with ``orientation``): ``Π = −vee A``
    (its skew part's, as :func:`lieint.fast.top3.minus_vee`), the centre zero when it is not
    tracked, and without attitude R = I for a state and 0 for a tangent vector (``tangent``)."""
    for m in range(Y.shape[0]):
        Y[m, 0] = -0.5 * (A[m, 2, 1] - A[m, 1, 2])
        Y[m, 1] = -0.5 * (A[m, 0, 2] - A[m, 2, 0])
        Y[m, 2] = -0.5 * (A[m, 1, 0] - A[m, 0, 1])
        for i in range(3):
            Y[m, 3 + i] = G[m, i]
            Y[m, 6 + i] = c[m, i] if center else 0.0
        for r in range(3):
            for j in range(3):
                if orientation:
                    Y[m, 9 + 3 * r + j] = R[m, r, j]
                else:
                    Y[m, 9 + 3 * r + j] = 1.0 if (r == j and not tangent) else 0.0


@njit(cache=True)
def rows_to_user(Y, center, orientation, A, G, c, R):
    """:func:`user_to_rows`' inverse: ``A = −Π̂`` (``+0.0`` on the diagonal, as
    :func:`lieint.fast.top3.minus_hat`), Γ, and the centre and R where the ball carries them,
    of the blocks ``Y`` (M, ≥ 18)."""
    for m in range(Y.shape[0]):
        x, y, z = Y[m, 0], Y[m, 1], Y[m, 2]
        A[m, 0, 0], A[m, 0, 1], A[m, 0, 2] = 0.0, z, -y
        A[m, 1, 0], A[m, 1, 1], A[m, 1, 2] = -z, 0.0, x
        A[m, 2, 0], A[m, 2, 1], A[m, 2, 2] = y, -x, 0.0
        for i in range(3):
            G[m, i] = Y[m, 3 + i]
            if center:
                c[m, i] = Y[m, 6 + i]
        if orientation:
            for r in range(3):
                for j in range(3):
                    R[m, r, j] = Y[m, 9 + 3 * r + j]


@njit(cache=True, inline="always")
def _contact_tensor(par, g0, g1, g2):
    """The six entries of ``M_K = J + M r² (|Γ|² I − ΓΓᵀ)`` and the adjugate's six, and det M_K."""
    mr2 = par[_MR2]
    gg = g0 * g0 + g1 * g1 + g2 * g2
    m00 = par[0] + mr2 * (gg - g0 * g0)
    m11 = par[4] + mr2 * (gg - g1 * g1)
    m22 = par[8] + mr2 * (gg - g2 * g2)
    m01 = par[1] - mr2 * g0 * g1
    m02 = par[2] - mr2 * g0 * g2
    m12 = par[5] - mr2 * g1 * g2
    c00 = m11 * m22 - m12 * m12
    c01 = m02 * m12 - m01 * m22
    c02 = m01 * m12 - m02 * m11
    c11 = m00 * m22 - m02 * m02
    c12 = m01 * m02 - m00 * m12
    c22 = m00 * m11 - m01 * m01
    det = m00 * c00 + m01 * c01 + m02 * c02
    return c00, c01, c02, c11, c12, c22, det


@njit(cache=True, inline="always")
def _solve(adj, det, p0, p1, p2):
    """``M_K⁻¹ p`` by the adjugate (symmetric)."""
    c00, c01, c02, c11, c12, c22 = adj
    inv = 1.0 / det
    return (
        (c00 * p0 + c01 * p1 + c02 * p2) * inv,
        (c01 * p0 + c11 * p1 + c12 * p2) * inv,
        (c02 * p0 + c12 * p1 + c22 * p2) * inv,
    )


@njit(cache=True, inline="always")
def _generator(par, track, p0, p1, p2, g0, g1, g2):
    """``ξ = (ω, r ω × Γ)`` (translation 0 when the centre is not tracked) and what ``δω`` needs:
    the adjugate of M_K and its determinant."""
    c00, c01, c02, c11, c12, c22, det = _contact_tensor(par, g0, g1, g2)
    adj = (c00, c01, c02, c11, c12, c22)
    w0, w1, w2 = _solve(adj, det, p0, p1, p2)
    v0, v1, v2 = 0.0, 0.0, 0.0
    if track:
        r = par[_RADIUS]
        v0, v1, v2 = _cross(w0, w1, w2, g0, g1, g2)
        v0, v1, v2 = r * v0, r * v1, r * v2
    return w0, w1, w2, v0, v1, v2, adj, det


@njit(cache=True, inline="always")
def _generator_tangent(par, track, adj, det, w0, w1, w2, g0, g1, g2, dp0, dp1, dp2, dg0, dg1, dg2):
    """``δξ = (δω, r (δω × Γ + ω × δΓ))`` at ``(ω, Γ)`` for the perturbation ``(δΠ, δΓ)``."""
    mr2 = par[_MR2]
    gd = 2.0 * (g0 * dg0 + g1 * dg1 + g2 * dg2)
    gw = g0 * w0 + g1 * w1 + g2 * w2
    dw = dg0 * w0 + dg1 * w1 + dg2 * w2
    # δM_K ω = M r² (2⟨Γ, δΓ⟩ ω − ⟨Γ, ω⟩ δΓ − ⟨δΓ, ω⟩ Γ)
    m0 = mr2 * (gd * w0 - gw * dg0 - dw * g0)
    m1 = mr2 * (gd * w1 - gw * dg1 - dw * g1)
    m2 = mr2 * (gd * w2 - gw * dg2 - dw * g2)
    d0, d1, d2 = _solve(adj, det, dp0 - m0, dp1 - m1, dp2 - m2)
    v0, v1, v2 = 0.0, 0.0, 0.0
    if track:
        r = par[_RADIUS]
        a0, a1, a2 = _cross(d0, d1, d2, g0, g1, g2)
        b0, b1, b2 = _cross(w0, w1, w2, dg0, dg1, dg2)
        v0, v1, v2 = r * (a0 + b0), r * (a1 + b1), r * (a2 + b2)
    return d0, d1, d2, v0, v1, v2


@njit(cache=True)
def form_scratch(fx, meth, par, d):
    """The stage slopes ``K`` (s, 6) and the tangent vectors' ``δK`` (k, s, 6), the stage's ``u``
    (6) and ``δu`` (k, 6), Q and the state's new R (3, 3)."""
    s = meth.b.shape[0]
    k = max(d // BLOCK - 1, 1)
    return np.zeros((s, 6)), np.zeros((k, s, 6)), np.zeros(6), np.zeros((k, 6)), np.zeros((3, 3)), np.zeros((3, 3))


@njit(cache=True)
def form_radius2(fx, y, par, scr):
    """``|ω|²``: the squared ad spectral radius of ξ (so(3), or se(3), whose translations add no
    larger eigenvalue)."""
    w0, w1, w2, _, _, _, _, _ = _generator(par, False, y[0], y[1], y[2], y[3], y[4], y[5])
    return w0 * w0 + w1 * w1 + w2 * w2


@njit(cache=True)
def form_rkmk_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One RKMK step (exponential coordinates, dexp⁻¹ truncated at ``meth.coeffs``) of a ball's
    state and of its tangent vectors in forward mode (module docstring); ``inc`` = the step's
    increment ``(u_w, u_v)``, ``aux[0]`` = ``|ω(y)|²``. Returns the stages, or −1 when a stage
    reaches the dexp⁻¹ radius (as the plain step)."""
    K, dK, u, du, Q, newR = scr[0], scr[1], scr[2], scr[3], scr[4], scr[5]
    d = y.shape[0]
    k = d // BLOCK - 1
    for i in range(d):
        y1[i] = y[i]
    orient, track = par[_ORIENT] != 0.0, par[_TRACK] != 0.0
    A, b, coeffs = meth.A, meth.b, meth.coeffs
    s = b.shape[0]
    p, g = y1[0:3], y1[3:6]
    for i in range(s + 1):  # the stages, then (i = s) the step's end
        combine_stage(i, A, b, h, K, dK, u, du, k)
        if i == 0:  # u = 0 and δu = 0: K₀ = ξ(y), δK₀ = δξ(y)
            w0, w1, w2, v0, v1, v2, adj, det = _generator(par, track, p[0], p[1], p[2], g[0], g[1], g[2])
            K[0, 0], K[0, 1], K[0, 2], K[0, 3], K[0, 4], K[0, 5] = w0, w1, w2, v0, v1, v2
            for m in range(k):
                o = BLOCK * (m + 1)
                x = _generator_tangent(par, track, adj, det, w0, w1, w2, g[0], g[1], g[2],
                                       y1[o], y1[o + 1], y1[o + 2], y1[o + 3], y1[o + 4], y1[o + 5])  # fmt: skip
                for c in range(6):
                    dK[m, 0, c] = x[c]
            continue
        t2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2]
        if i < s and t2 >= _RADIUS2:
            return -1
        beta, gamma, dbeta, dgamma = exponential(u, Q)  # one sine and cosine for Q and the coefficients
        if i == s:  # the step's end: exp(u) turns the block and its tangent vectors
            _turn(y1, k, u, du, Q, beta, gamma, dbeta, dgamma, orient, track, newR)
            for c in range(6):
                if c < inc.shape[0]:
                    inc[c] = u[c]
            aux[0] = K[0, 0] * K[0, 0] + K[0, 1] * K[0, 1] + K[0, 2] * K[0, 2]
            return s
        pi0, pi1, pi2 = rotate_back(Q, p[0], p[1], p[2])
        gi0, gi1, gi2 = rotate_back(Q, g[0], g[1], g[2])
        # a stage: ξ at the moved state and its truncated dexp⁻¹ series
        w0, w1, w2, v0, v1, v2, adj, det = _generator(par, track, pi0, pi1, pi2, gi0, gi1, gi2)
        for m in range(k):
            o = BLOCK * (m + 1)
            r0, r1, r2 = right_jacobian(u, du[m], beta, gamma)
            a0, a1, a2 = rotate_back(Q, y1[o], y1[o + 1], y1[o + 2])
            e0, e1, e2 = _cross(r0, r1, r2, pi0, pi1, pi2)
            b0, b1, b2 = rotate_back(Q, y1[o + 3], y1[o + 4], y1[o + 5])
            f0, f1, f2 = _cross(r0, r1, r2, gi0, gi1, gi2)
            x = _generator_tangent(par, track, adj, det, w0, w1, w2, gi0, gi1, gi2,
                                   a0 - e0, a1 - e1, a2 - e2, b0 - f0, b1 - f1, b2 - f2)  # fmt: skip
            k0, k1, k2, k3, k4, k5 = dexpinv_series_tangent(
                u, du[m], coeffs, w0, w1, w2, v0, v1, v2, x[0], x[1], x[2], x[3], x[4], x[5]
            )
            dK[m, i, 0], dK[m, i, 1], dK[m, i, 2] = k0, k1, k2
            dK[m, i, 3], dK[m, i, 4], dK[m, i, 5] = k3, k4, k5
        k0, k1, k2, k3, k4, k5 = dexpinv_series(u, coeffs, w0, w1, w2, v0, v1, v2)
        K[i, 0], K[i, 1], K[i, 2], K[i, 3], K[i, 4], K[i, 5] = k0, k1, k2, k3, k4, k5
    return s  # not reached: the loop returns at i = s


@njit(cache=True)
def form_products_scratch(fx, meth, par, d):
    """:func:`form_scratch`'s arrays for s = the method's stages, then a stage's block and its k
    tangent vectors."""
    s = meth.c.shape[0]
    k = max(d // BLOCK - 1, 1)
    return (np.zeros((s, 6)), np.zeros((k, s, 6)), np.zeros(6), np.zeros((k, 6)), np.zeros((3, 3)), np.zeros((3, 3)),
            np.zeros(BLOCK * (k + 1)))  # fmt: skip


@njit(cache=True, inline="always")
def _turn(arr, k, u, du, Q, beta, gamma, dbeta, dgamma, attitude, track, newR):
    """The block ``arr[0:18]`` and its k tangent vectors (blocks after it) under the right action of
    ``exp(u)`` moved by ``δu`` (module docstring), in place, ``Q = exp(u_w)`` and the coefficients of
    u given: ``Π ← QᵀΠ``, ``Γ ← QᵀΓ`` and their tangents always; with ``track`` the centre
    ``c ← c + R t`` (``δc ← δc + δR t + R δt``), with ``attitude`` ``R ← RQ`` (``δR ← δR Q + R₁ ŵ``)."""
    pi0, pi1, pi2 = rotate_back(Q, arr[0], arr[1], arr[2])
    gi0, gi1, gi2 = rotate_back(Q, arr[3], arr[4], arr[5])
    if attitude:
        attitude_turned_into(arr, 9, Q, newR)
    for m in range(k):  # the tangent vectors first: they read the block before it moves
        o = BLOCK * (m + 1)
        w0, w1, w2 = right_jacobian(u, du[m], beta, gamma)
        a0, a1, a2 = rotate_back(Q, arr[o], arr[o + 1], arr[o + 2])
        e0, e1, e2 = _cross(w0, w1, w2, pi0, pi1, pi2)
        b0, b1, b2 = rotate_back(Q, arr[o + 3], arr[o + 4], arr[o + 5])
        f0, f1, f2 = _cross(w0, w1, w2, gi0, gi1, gi2)
        if track:
            t0, t1, t2_, dt0, dt1, dt2 = translation(u, du[m], beta, gamma, dbeta, dgamma)
            for r in range(3):
                R0, R1, R2 = arr[9 + 3 * r], arr[10 + 3 * r], arr[11 + 3 * r]
                S0, S1, S2 = arr[o + 9 + 3 * r], arr[o + 10 + 3 * r], arr[o + 11 + 3 * r]
                arr[o + 6 + r] += (S0 * t0 + S1 * t1 + S2 * t2_) + (R0 * dt0 + R1 * dt1 + R2 * dt2)
        arr[o], arr[o + 1], arr[o + 2] = a0 - e0, a1 - e1, a2 - e2
        arr[o + 3], arr[o + 4], arr[o + 5] = b0 - f0, b1 - f1, b2 - f2
        if attitude:
            tangent_attitude_turned(arr, o + 9, Q, newR, w0, w1, w2)
    if track:
        t0, t1, t2_ = phi1(u[0], u[1], u[2], u[3], u[4], u[5], beta, gamma)
        for r in range(3):
            arr[6 + r] += arr[9 + 3 * r] * t0 + arr[10 + 3 * r] * t1 + arr[11 + 3 * r] * t2_
    arr[0], arr[1], arr[2] = pi0, pi1, pi2
    arr[3], arr[4], arr[5] = gi0, gi1, gi2
    if attitude:
        for r in range(3):
            for c in range(3):
                arr[9 + 3 * r + c] = newR[r, c]


@njit(cache=True)
def form_products_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One step of a product of exponentials (the commutator-free and Crouch–Grossman methods) of a
    ball's state and its tangent vectors in forward mode: stage i turns ``(Π, Γ)`` and their tangent
    vectors by its exponentials one after the other (:func:`_turn`), ``K_i = ξ(Π_i, Γ_i)``,
    ``δK_i = δξ``; the step turns the whole block (the centre and R included) by its own. No
    dexp⁻¹, so never out of range; ``aux[0] = |ω(y)|²``."""
    K, dK, u, du, Q, newR, st = scr[0], scr[1], scr[2], scr[3], scr[4], scr[5], scr[6]
    d = y.shape[0]
    k = d // BLOCK - 1
    for i in range(d):
        y1[i] = y[i]
    orient, track = par[_ORIENT] != 0.0, par[_TRACK] != 0.0
    weights, bounds = meth.weights, meth.bounds
    s = bounds.shape[0] - 2
    for i in range(s):
        for m in range(k + 1):  # the stage's point (Π, Γ) and its tangent vectors, from y
            for c in range(6):
                st[BLOCK * m + c] = y1[BLOCK * m + c]
        for e in range(bounds[i], bounds[i + 1]):
            if product_exponent(u, du, K, dK, weights, e, i, h, k):
                beta, gamma, dbeta, dgamma = exponential(u, Q)
                _turn(st, k, u, du, Q, beta, gamma, dbeta, dgamma, False, False, newR)
        w0, w1, w2, v0, v1, v2, adj, det = _generator(par, track, st[0], st[1], st[2], st[3], st[4], st[5])
        K[i, 0], K[i, 1], K[i, 2], K[i, 3], K[i, 4], K[i, 5] = w0, w1, w2, v0, v1, v2
        for m in range(k):
            o = BLOCK * (m + 1)
            x = _generator_tangent(par, track, adj, det, w0, w1, w2, st[3], st[4], st[5],
                                   st[o], st[o + 1], st[o + 2], st[o + 3], st[o + 4], st[o + 5])  # fmt: skip
            for c in range(6):
                dK[m, i, c] = x[c]
    first = bounds[s]
    for e in range(first, bounds[s + 1]):
        o = 6 * (e - first)
        moved = product_exponent(u, du, K, dK, weights, e, s, h, k)
        for c in range(6):
            if o + c < inc.shape[0]:
                inc[o + c] = u[c] if moved else 0.0
        if moved:
            beta, gamma, dbeta, dgamma = exponential(u, Q)
            _turn(y1, k, u, du, Q, beta, gamma, dbeta, dgamma, orient, track, newR)
    aux[0] = K[0, 0] * K[0, 0] + K[0, 1] * K[0, 1] + K[0, 2] * K[0, 2]
    return meth.c.shape[0]


@njit(cache=True)
def form_products_megno_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_products_tangent_step` of the state and one tangent vector, then MEGNO's sums."""
    spent = form_products_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    megno_update(y1, h, BLOCK, FLAT, par[_ORIENT] != 0.0)
    return spent


@njit(cache=True)
def form_products_lyapunov_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_products_tangent_step`, then the re-orthonormalisation when it is due."""
    spent = form_products_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    lyapunov_update(y1, y.shape[0] // BLOCK - 1, BLOCK, FLAT, par[_ORIENT] != 0.0, par[_EVERY], par[_TOTAL])
    return spent


@njit(cache=True)
def form_rkmk_megno_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_rkmk_tangent_step` of the state and one tangent vector, then MEGNO's sums
    (:func:`lieint.fast.tangent_sums.megno_update`); −1 when a stage reached the dexp⁻¹ radius."""
    spent = form_rkmk_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    if spent >= 0:
        megno_update(y1, h, BLOCK, FLAT, par[_ORIENT] != 0.0)
    return spent


@njit(cache=True)
def form_rkmk_lyapunov_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_rkmk_tangent_step`, then the re-orthonormalisation of
    :func:`lieint.fast.tangent_sums.lyapunov_update` when it is due; −1 when a stage reached the
    dexp⁻¹ radius."""
    spent = form_rkmk_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    if spent >= 0:
        k = y.shape[0] // BLOCK - 1
        lyapunov_update(y1, k, BLOCK, FLAT, par[_ORIENT] != 0.0, par[_EVERY], par[_TOTAL])
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
