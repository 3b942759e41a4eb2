"""The tangent maps of the 3D rolling ball's RKMK methods as forms of the one compiled loop
(forward mode, numba, cached on disk): the ball with an offset centre of mass, under gravity
along the plane's normal, on an incline, or without gravity.

A body's row is its state in the user's frame, ``(ω, Γ, c, G, R)`` (21 numbers: ``Ω = ω̂``; the
centre c zero when it is not tracked, G zero unless the ball is on an incline, R = I without
attitude), followed by k tangent vectors ``(δω, δΓ, δc, δG, δR)`` of the same layout:
``d = 21 (1 + k)``. The step is RKMK on ``SE(3) × so(3)`` (``SO(3) × so(3)`` without the centre)
in exponential coordinates with dexp⁻¹ truncated at the method's degree, as
:mod:`lieint.fast.rolling_lanes` takes it in lanes: the generator is ``ξ = ((ω, r ω × Γ), ω̇)``
with ω̇ from the rolling equation's 3 × 3 system::

    M_K ω̇ = F,   F = (M_K ω) × ω + M (κ + X_G) × (N + G),   N = ω × (ω × κ),   κ = rΓ,
    M_K = J + M (e I − X_G κᵀ − κ X_Gᵀ − κκᵀ),   e = 2⟨X_G, κ⟩ + |κ|²,   J = tr(B_C) I − B_C

(G the gravity's body vector: ``⟨g, ν⟩ Γ`` along the normal, the field G on an incline, zero
without gravity), and the right action of ``((exp û, t), δ)``, ``t = φ₁(û) u_v``, is::

    ω ← ω + δ,   Γ ← QᵀΓ,   G ← QᵀG,   c ← c + R t,   R ← R Q,   Q = exp û;

the so(3) factor is abelian: its slopes need no dexp⁻¹ and only the pose's rotation meets the
dexp⁻¹ radius. Each tangent vector moves by the derivative of that step, by hand:

* ω̇ by ``δω̇ = M_K⁻¹(δF − δM_K ω̇)`` (the adjugate of M_K solves both), with
  ``δM_K x = M (δe x − (κ + X_G)⟨δκ, x⟩ − δκ⟨κ + X_G, x⟩)``, ``δe = 2⟨κ + X_G, δκ⟩``, ``δκ = rδΓ``,
  ``δF = (δM_K ω + M_K δω) × ω + (M_K ω) × δω + M δκ × (N + G) + M (κ + X_G) × (δN + δG)``,
  ``δN = δω × (ω × κ) + ω × (δω × κ + ω × δκ)``;
* the translation ``r ω × Γ`` by ``r (δω × Γ + ω × δΓ)``;
* the pose's exponential, the translation t, the truncated dexp⁻¹ series and the attitude as in
  :mod:`lieint.fast.chaplygin3_tangent` (``δ(Qᵀx) = Qᵀδx − w × Qᵀx``, ``w = J_r(u_w) δu_w``;
  ``δc₁ = δc + δR t + R δt``; ``δR₁ = δR Q + R₁ ŵ``), the abelian factor by ``δω₁ = δω + δ(δ)``.

This is the derivative of the map the method computes: the tangent map the complex step of
:mod:`lieint.tangent.flow` computes on the generic path, to round-off (the generic path's
compiled pieces solve the rolling equation's Lyapunov system in matrices: the two agree to
round-off, not to the bit). With k = 0 the step is the plain step of the state alone: one 3D
rolling ball's fixed-step runs in exponential coordinates go through it
(:class:`lieint.fast.tangent_layouts.RollingBall3Layout`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .se3_tangent import (
    attitude_turned_into,
    coefficients,
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
from .top3 import _RADIUS2, _cross

__all__ = ["BLOCK", "FLAT", "MEGNO_SLOTS", "NAMESPACES"]

#: numbers of one block of a row: ω (3), Γ (3), the centre (3), G (3), R (9)
BLOCK = 21
#: the block's numbers perturbed additively (ω, Γ, c, G); R follows them
FLAT = 12
#: where the centre, G and R start in a block
_C, _G, _R = 6, 9, 12
#: a stage's slope: the pose's (u_w, u_v) (6), then the so(3) factor's δ (3)
WIDTH = 9
# parameters: J (9), M, r, ν (3), whether the centre is tracked, the gravity mode (0 none, 1 along
# ν, 2 tilted: G a field), ⟨g, ν⟩, |g|, X_G (3) — rolling_lanes' — then whether the ball carries R,
# then (Lyapunov) every, total
_MASS, _RADIUS, _TRACK, _MODE, _G_NORMAL, _X_G, _ORIENT, _EVERY, _TOTAL = 9, 10, 14, 15, 16, 18, 21, 22, 23


@njit(cache=True, inline="always")
def _dot(a0, a1, a2, b0, b1, b2):
    return a0 * b0 + a1 * b1 + a2 * b2


@njit(cache=True, inline="always")
def _contact(par, g0, g1, g2):
    """κ = rΓ and the six entries of the symmetric ``M_K``, of its adjugate and ``1/det M_K``."""
    M, r = par[_MASS], par[_RADIUS]
    x0, x1, x2 = par[_X_G], par[_X_G + 1], par[_X_G + 2]
    k0, k1, k2 = r * g0, r * g1, r * g2
    e = k0 * (k0 + 2.0 * x0) + k1 * (k1 + 2.0 * x1) + k2 * (k2 + 2.0 * x2)
    m00 = par[0] + M * (e - k0 * (k0 + 2.0 * x0))
    m11 = par[4] + M * (e - k1 * (k1 + 2.0 * x1))
    m22 = par[8] + M * (e - k2 * (k2 + 2.0 * x2))
    m01 = par[1] - M * (x0 * k1 + k0 * (k1 + x1))
    m02 = par[2] - M * (x0 * k2 + k0 * (k2 + x2))
    m12 = par[5] - M * (x1 * k2 + k1 * (k2 + x2))
    c00 = m11 * m22 - m12 * m12
    c01 = m02 * m12 - m01 * m22
    c02 = m01 * m12 - m02 * m11
    c11 = m00 * m22 - m02 * m02
    c12 = m01 * m02 - m00 * m12
    c22 = m00 * m11 - m01 * m01
    inv = 1.0 / (m00 * c00 + m01 * c01 + m02 * c02)
    return (k0, k1, k2), (m00, m01, m02, m11, m12, m22), (c00, c01, c02, c11, c12, c22), inv


@njit(cache=True, inline="always")
def _sym(m, x0, x1, x2):
    """``S x`` for the symmetric S of six entries ``(s00, s01, s02, s11, s12, s22)``."""
    s00, s01, s02, s11, s12, s22 = m
    return s00 * x0 + s01 * x1 + s02 * x2, s01 * x0 + s11 * x1 + s12 * x2, s02 * x0 + s12 * x1 + s22 * x2


@njit(cache=True, inline="always")
def _gravity(par, g0, g1, g2, G0, G1, G2):
    """The gravity's body vector: ``⟨g, ν⟩ Γ`` (mode 1), the field G (mode 2), zero (mode 0); the
    same map takes δΓ, δG to its derivative."""
    mode = par[_MODE]
    if mode == 1.0:
        c = par[_G_NORMAL]
        return c * g0, c * g1, c * g2
    if mode == 2.0:
        return G0, G1, G2
    return 0.0, 0.0, 0.0


@njit(cache=True, inline="always")
def _acceleration(par, w0, w1, w2, g0, g1, g2, f0, f1, f2):
    """ω̇ at (ω, Γ) with the gravity vector f, and what its derivative reuses: κ, M_K, its adjugate
    and ``1/det``, ``M_K ω`` and N (module docstring)."""
    k, mk, adj, inv = _contact(par, g0, g1, g2)
    M = par[_MASS]
    a0, a1, a2 = _sym(mk, w0, w1, w2)
    c0, c1, c2 = _cross(a0, a1, a2, w0, w1, w2)
    n0, n1, n2 = _cross(w0, w1, w2, k[0], k[1], k[2])
    n0, n1, n2 = _cross(w0, w1, w2, n0, n1, n2)
    x0, x1, x2 = par[_X_G], par[_X_G + 1], par[_X_G + 2]
    d0, d1, d2 = _cross(k[0] + x0, k[1] + x1, k[2] + x2, n0 + f0, n1 + f1, n2 + f2)
    F0, F1, F2 = c0 + M * d0, c1 + M * d1, c2 + M * d2
    s0, s1, s2 = _sym(adj, F0, F1, F2)
    return (s0 * inv, s1 * inv, s2 * inv), k, mk, adj, inv, (a0, a1, a2), (n0, n1, n2)


@njit(cache=True, inline="always")
def _acceleration_tangent(par, w0, w1, w2, wd, k, mk, adj, inv, a, n, f0, f1, f2, dw0, dw1, dw2, dg0, dg1, dg2,
                          df0, df1, df2):  # fmt: skip
    """``δω̇`` at (ω, Γ) for the perturbation (δω, δΓ) and the gravity's δf (module docstring)."""
    M, r = par[_MASS], par[_RADIUS]
    kx0, kx1, kx2 = k[0] + par[_X_G], k[1] + par[_X_G + 1], k[2] + par[_X_G + 2]
    dk0, dk1, dk2 = r * dg0, r * dg1, r * dg2
    de = 2.0 * _dot(kx0, kx1, kx2, dk0, dk1, dk2)
    # δM_K x = M (δe x − (κ + X_G)⟨δκ, x⟩ − δκ⟨κ + X_G, x⟩), at x = ω and x = ω̇
    p, q = _dot(dk0, dk1, dk2, w0, w1, w2), _dot(kx0, kx1, kx2, w0, w1, w2)
    dm0, dm1, dm2 = (
        M * (de * w0 - kx0 * p - dk0 * q),
        M * (de * w1 - kx1 * p - dk1 * q),
        M * (de * w2 - kx2 * p - dk2 * q),
    )
    p, q = _dot(dk0, dk1, dk2, wd[0], wd[1], wd[2]), _dot(kx0, kx1, kx2, wd[0], wd[1], wd[2])
    e0 = M * (de * wd[0] - kx0 * p - dk0 * q)
    e1 = M * (de * wd[1] - kx1 * p - dk1 * q)
    e2 = M * (de * wd[2] - kx2 * p - dk2 * q)
    # δ(M_K ω) = δM_K ω + M_K δω; δ((M_K ω) × ω) = δ(M_K ω) × ω + (M_K ω) × δω
    b0, b1, b2 = _sym(mk, dw0, dw1, dw2)
    c0, c1, c2 = _cross(dm0 + b0, dm1 + b1, dm2 + b2, w0, w1, w2)
    h0, h1, h2 = _cross(a[0], a[1], a[2], dw0, dw1, dw2)
    # δN = δω × (ω × κ) + ω × (δω × κ + ω × δκ)
    u0, u1, u2 = _cross(w0, w1, w2, k[0], k[1], k[2])
    v0, v1, v2 = _cross(dw0, dw1, dw2, u0, u1, u2)
    s0, s1, s2 = _cross(dw0, dw1, dw2, k[0], k[1], k[2])
    t0, t1, t2 = _cross(w0, w1, w2, dk0, dk1, dk2)
    z0, z1, z2 = _cross(w0, w1, w2, s0 + t0, s1 + t1, s2 + t2)
    dn0, dn1, dn2 = v0 + z0, v1 + z1, v2 + z2
    # M δκ × (N + G) + M (κ + X_G) × (δN + δG)
    l0, l1, l2 = _cross(dk0, dk1, dk2, n[0] + f0, n[1] + f1, n[2] + f2)
    m0, m1, m2 = _cross(kx0, kx1, kx2, dn0 + df0, dn1 + df1, dn2 + df2)
    F0 = c0 + h0 + M * (l0 + m0) - e0
    F1 = c1 + h1 + M * (l1 + m1) - e1
    F2 = c2 + h2 + M * (l2 + m2) - e2
    x0, x1, x2 = _sym(adj, F0, F1, F2)
    return x0 * inv, x1 * inv, x2 * inv


@njit(cache=True, inline="always")
def _state_slope(par, rt, w0, w1, w2, g0, g1, g2, G0, G1, G2):
    """The slope's parts at a stage's state (ω, Γ, G): ω̇, what its derivative reuses, the gravity
    vector and the translation ``r ω × Γ`` (rt = 0 without the centre)."""
    f0, f1, f2 = _gravity(par, g0, g1, g2, G0, G1, G2)
    wd, k, mk, adj, inv, a, n = _acceleration(par, w0, w1, w2, g0, g1, g2, f0, f1, f2)
    v0, v1, v2 = _cross(w0, w1, w2, g0, g1, g2)
    return wd, k, mk, adj, inv, a, n, (f0, f1, f2), (rt * v0, rt * v1, rt * v2)


@njit(cache=True)
def form_scratch(fx, meth, par, d):
    """The stage slopes ``K`` (s, 9) and the tangent vectors' ``δK`` (k, s, 9), the stage's ``u``
    (9) and ``δu`` (k, 9), Q and the state's new R (3, 3)."""
    s = meth.b.shape[0]
    k = max(d // BLOCK - 1, 1)
    return (np.zeros((s, WIDTH)), np.zeros((k, s, WIDTH)), np.zeros(WIDTH), np.zeros((k, WIDTH)), np.zeros((3, 3)),
            np.zeros((3, 3)))  # fmt: skip


@njit(cache=True)
def form_radius2(fx, y, par, scr):
    """``|ω|²``: the squared ad spectral radius of the pose's rotation (the so(3) factor is abelian)."""
    return y[0] * y[0] + y[1] * y[1] + y[2] * y[2]


@njit(cache=True)
def form_rkmk_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One RKMK step (exponential coordinates on se(3) × so(3), dexp⁻¹ truncated at
    ``meth.coeffs``) of a ball's state and of its tangent vectors in forward mode (module
    docstring); ``inc`` = the step's increment ``(u_w, u_v, δ)``, ``aux[0]`` = ``|ω(y)|²``. Returns
    the stages, or −1 when a stage reaches the dexp⁻¹ radius (as the plain step)."""
    K, dK, u, du, Q, newR = scr[0], scr[1], scr[2], scr[3], scr[4], scr[5]
    d = y.shape[0]
    k = d // BLOCK - 1
    for i in range(d):
        y1[i] = y[i]
    orient, track, tilted = par[_ORIENT] != 0.0, par[_TRACK] != 0.0, par[_MODE] == 2.0
    rt = par[_RADIUS] if track else 0.0
    A, b, coeffs = meth.A, meth.b, meth.coeffs
    s = b.shape[0]
    for i in range(s + 1):  # the stages, then (i = s) the step's end
        combine_stage(i, A, b, h, K, dK, u, du, k)
        if i == 0:  # u = 0 and δu = 0: the slopes at y itself, no dexp⁻¹
            Q[0, 0], Q[0, 1], Q[0, 2] = 1.0, 0.0, 0.0
            Q[1, 0], Q[1, 1], Q[1, 2] = 0.0, 1.0, 0.0
            Q[2, 0], Q[2, 1], Q[2, 2] = 0.0, 0.0, 1.0
            beta, gamma, dbeta, dgamma = coefficients(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
        else:
            t2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2]
            if i < s and t2 >= _RADIUS2:
                return -1
            beta, gamma, dbeta, dgamma = exponential(u, Q)  # one sine and cosine for Q and the coefficients
        if i == s:  # the step's end: ((exp û_w, t), δ) moves the block and its tangent vectors
            _turn(y1, k, u, du, Q, beta, gamma, dbeta, dgamma, tilted, orient, track, newR)
            for c in range(WIDTH):
                if c < inc.shape[0]:
                    inc[c] = u[c]
            aux[0] = K[0, 0] * K[0, 0] + K[0, 1] * K[0, 1] + K[0, 2] * K[0, 2]
            return s
        wi0, wi1, wi2 = y1[0] + u[6], y1[1] + u[7], y1[2] + u[8]
        gi0, gi1, gi2 = rotate_back(Q, y1[3], y1[4], y1[5])
        Gi0, Gi1, Gi2 = 0.0, 0.0, 0.0
        if tilted:
            Gi0, Gi1, Gi2 = rotate_back(Q, y1[_G], y1[_G + 1], y1[_G + 2])
        # a stage: ξ at the moved state; the pose's part through its truncated dexp⁻¹ series
        wd, kap, mk, adj, inv, a, n, f, v = _state_slope(par, rt, wi0, wi1, wi2, gi0, gi1, gi2, Gi0, Gi1, Gi2)
        for m in range(k):
            o = BLOCK * (m + 1)
            r0, r1, r2 = right_jacobian(u, du[m], beta, gamma)
            dw0, dw1, dw2 = y1[o] + du[m, 6], y1[o + 1] + du[m, 7], y1[o + 2] + du[m, 8]
            b0, b1, b2 = rotate_back(Q, y1[o + 3], y1[o + 4], y1[o + 5])
            f0, f1, f2 = _cross(r0, r1, r2, gi0, gi1, gi2)
            dg0, dg1, dg2 = b0 - f0, b1 - f1, b2 - f2
            dG0, dG1, dG2 = 0.0, 0.0, 0.0
            if tilted:
                b0, b1, b2 = rotate_back(Q, y1[o + _G], y1[o + _G + 1], y1[o + _G + 2])
                f0, f1, f2 = _cross(r0, r1, r2, Gi0, Gi1, Gi2)
                dG0, dG1, dG2 = b0 - f0, b1 - f1, b2 - f2
            df0, df1, df2 = _gravity(par, dg0, dg1, dg2, dG0, dG1, dG2)
            x0, x1, x2 = _acceleration_tangent(par, wi0, wi1, wi2, wd, kap, mk, adj, inv, a, n, f[0], f[1], f[2],
                                               dw0, dw1, dw2, dg0, dg1, dg2, df0, df1, df2)  # fmt: skip
            p0, p1, p2 = _cross(dw0, dw1, dw2, gi0, gi1, gi2)
            q0, q1, q2 = _cross(wi0, wi1, wi2, dg0, dg1, dg2)
            dv0, dv1, dv2 = rt * (p0 + q0), rt * (p1 + q1), rt * (p2 + q2)
            if i == 0:
                k0, k1, k2, k3, k4, k5 = dw0, dw1, dw2, dv0, dv1, dv2
            else:
                k0, k1, k2, k3, k4, k5 = dexpinv_series_tangent(
                    u, du[m], coeffs, wi0, wi1, wi2, v[0], v[1], v[2], dw0, dw1, dw2, dv0, dv1, dv2
                )
            dK[m, i, 0], dK[m, i, 1], dK[m, i, 2] = k0, k1, k2
            dK[m, i, 3], dK[m, i, 4], dK[m, i, 5] = k3, k4, k5
            dK[m, i, 6], dK[m, i, 7], dK[m, i, 8] = x0, x1, x2
        if i == 0:
            k0, k1, k2, k3, k4, k5 = wi0, wi1, wi2, v[0], v[1], v[2]
        else:
            k0, k1, k2, k3, k4, k5 = dexpinv_series(u, coeffs, wi0, wi1, wi2, v[0], v[1], v[2])
        K[i, 0], K[i, 1], K[i, 2], K[i, 3], K[i, 4], K[i, 5] = k0, k1, k2, k3, k4, k5
        K[i, 6], K[i, 7], K[i, 8] = wd[0], wd[1], wd[2]
    return s  # not reached: the loop returns at i = s


@njit(cache=True)
def form_products_scratch(fx, meth, par, d):
    """:func:`form_scratch`'s arrays for s = the method's stages, then a stage's block and its k
    tangent vectors."""
    s = meth.c.shape[0]
    k = max(d // BLOCK - 1, 1)
    return (np.zeros((s, WIDTH)), np.zeros((k, s, WIDTH)), np.zeros(WIDTH), np.zeros((k, WIDTH)), np.zeros((3, 3)),
            np.zeros((3, 3)), np.zeros(BLOCK * (k + 1)))  # fmt: skip


@njit(cache=True)  # not inlined: inlined into the RKMK step it slowed the plain step by a third
def _turn(arr, k, u, du, Q, beta, gamma, dbeta, dgamma, tilted, attitude, track, newR):
    """The block ``arr[0:21]`` and its k tangent vectors (blocks after it) under the right action of
    ``((exp û_w, t), δ)`` moved by ``δu`` (module docstring), in place, ``Q = exp(u_w)`` and the
    coefficients of u given: ``ω ← ω + δ``, ``Γ ← QᵀΓ`` (on an incline ``G ← QᵀG``) and their
    tangents always; with ``track`` the centre ``c ← c + R t``, with ``attitude`` ``R ← RQ``, and
    their tangents."""
    gi0, gi1, gi2 = rotate_back(Q, arr[3], arr[4], arr[5])
    Gi0, Gi1, Gi2 = 0.0, 0.0, 0.0
    if tilted:
        Gi0, Gi1, Gi2 = rotate_back(Q, arr[_G], arr[_G + 1], arr[_G + 2])
    if attitude:
        attitude_turned_into(arr, _R, Q, newR)
    for m in range(k):  # the tangent vectors first: they read the block before it moves
        o = BLOCK * (m + 1)
        w0, w1, w2 = right_jacobian(u, du[m], beta, gamma)
        a0, a1, a2 = rotate_back(Q, arr[o + 3], arr[o + 4], arr[o + 5])
        e0, e1, e2 = _cross(w0, w1, w2, gi0, gi1, gi2)
        if tilted:
            b0, b1, b2 = rotate_back(Q, arr[o + _G], arr[o + _G + 1], arr[o + _G + 2])
            f0, f1, f2 = _cross(w0, w1, w2, Gi0, Gi1, Gi2)
            arr[o + _G], arr[o + _G + 1], arr[o + _G + 2] = b0 - f0, b1 - f1, b2 - f2
        if track:
            t0, t1, t2_, dt0, dt1, dt2 = translation(u, du[m], beta, gamma, dbeta, dgamma)
            for r in range(3):
                R0, R1, R2 = arr[_R + 3 * r], arr[_R + 1 + 3 * r], arr[_R + 2 + 3 * r]
                S0, S1, S2 = arr[o + _R + 3 * r], arr[o + _R + 1 + 3 * r], arr[o + _R + 2 + 3 * r]
                arr[o + _C + r] += (S0 * t0 + S1 * t1 + S2 * t2_) + (R0 * dt0 + R1 * dt1 + R2 * dt2)
        arr[o], arr[o + 1], arr[o + 2] = arr[o] + du[m, 6], arr[o + 1] + du[m, 7], arr[o + 2] + du[m, 8]
        arr[o + 3], arr[o + 4], arr[o + 5] = a0 - e0, a1 - e1, a2 - e2
        if attitude:
            tangent_attitude_turned(arr, o + _R, Q, newR, w0, w1, w2)
    if track:
        t0, t1, t2_ = phi1(u[0], u[1], u[2], u[3], u[4], u[5], beta, gamma)
        for r in range(3):
            arr[_C + r] += arr[_R + 3 * r] * t0 + arr[_R + 1 + 3 * r] * t1 + arr[_R + 2 + 3 * r] * t2_
    arr[0], arr[1], arr[2] = arr[0] + u[6], arr[1] + u[7], arr[2] + u[8]
    arr[3], arr[4], arr[5] = gi0, gi1, gi2
    if tilted:
        arr[_G], arr[_G + 1], arr[_G + 2] = Gi0, Gi1, Gi2
    if attitude:
        for r in range(3):
            for c in range(3):
                arr[_R + 3 * r + c] = newR[r, c]


@njit(cache=True)
def form_products_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One step of a product of exponentials (the commutator-free and Crouch–Grossman methods) of a
    ball's state and its tangent vectors in forward mode: stage i moves ``(ω, Γ, G)`` and their
    tangent vectors by its exponentials one after the other (:func:`_turn`), ``K_i = ξ`` there and
    ``δK_i = δξ``; the step moves the whole block (the centre and R included) by its own. No
    dexp⁻¹, so never out of range; ``aux[0] = |ω(y)|²``."""
    K, dK, u, du, Q, newR, st = scr[0], scr[1], scr[2], scr[3], scr[4], scr[5], scr[6]
    d = y.shape[0]
    k = d // BLOCK - 1
    for i in range(d):
        y1[i] = y[i]
    orient, track, tilted = par[_ORIENT] != 0.0, par[_TRACK] != 0.0, par[_MODE] == 2.0
    rt = par[_RADIUS] if track else 0.0
    weights, bounds = meth.weights, meth.bounds
    s = bounds.shape[0] - 2
    for i in range(s):
        for m in range(k + 1):  # the stage's point (ω, Γ, G) and its tangent vectors, from y
            for c in range(12):
                st[BLOCK * m + c] = y1[BLOCK * m + c]
        for e in range(bounds[i], bounds[i + 1]):
            if product_exponent(u, du, K, dK, weights, e, i, h, k):
                beta, gamma, dbeta, dgamma = exponential(u, Q)
                _turn(st, k, u, du, Q, beta, gamma, dbeta, dgamma, tilted, False, False, newR)
        w0, w1, w2, g0, g1, g2 = st[0], st[1], st[2], st[3], st[4], st[5]
        G0, G1, G2 = st[_G], st[_G + 1], st[_G + 2]
        wd, kap, mk, adj, inv, a, n, f, v = _state_slope(par, rt, w0, w1, w2, g0, g1, g2, G0, G1, G2)
        K[i, 0], K[i, 1], K[i, 2], K[i, 3], K[i, 4], K[i, 5] = w0, w1, w2, v[0], v[1], v[2]
        K[i, 6], K[i, 7], K[i, 8] = wd[0], wd[1], wd[2]
        for m in range(k):
            o = BLOCK * (m + 1)
            dw0, dw1, dw2, dg0, dg1, dg2 = st[o], st[o + 1], st[o + 2], st[o + 3], st[o + 4], st[o + 5]
            df0, df1, df2 = _gravity(par, dg0, dg1, dg2, st[o + _G], st[o + _G + 1], st[o + _G + 2])
            x0, x1, x2 = _acceleration_tangent(par, w0, w1, w2, wd, kap, mk, adj, inv, a, n, f[0], f[1], f[2],
                                               dw0, dw1, dw2, dg0, dg1, dg2, df0, df1, df2)  # fmt: skip
            p0, p1, p2 = _cross(dw0, dw1, dw2, g0, g1, g2)
            q0, q1, q2 = _cross(w0, w1, w2, dg0, dg1, dg2)
            dK[m, i, 0], dK[m, i, 1], dK[m, i, 2] = dw0, dw1, dw2
            dK[m, i, 3], dK[m, i, 4], dK[m, i, 5] = rt * (p0 + q0), rt * (p1 + q1), rt * (p2 + q2)
            dK[m, i, 6], dK[m, i, 7], dK[m, i, 8] = x0, x1, x2
    first = bounds[s]
    for e in range(first, bounds[s + 1]):
        o = WIDTH * (e - first)
        moved = product_exponent(u, du, K, dK, weights, e, s, h, k)
        for c in range(WIDTH):
            if o + c < inc.shape[0]:
                inc[o + c] = u[c] if moved else 0.0
        if moved:
            beta, gamma, dbeta, dgamma = exponential(u, Q)
            _turn(y1, k, u, du, Q, beta, gamma, dbeta, dgamma, tilted, orient, track, newR)
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
