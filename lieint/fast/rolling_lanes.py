"""Ensemble kernel for the 3D rolling ball (offset centre of mass, gravity, incline): bodies in
SIMD lanes.

The ball's per-body path (its compiled pieces, :mod:`lieint.fast.balls`) solves the rolling
equation's Lyapunov system for Ω̇ at every stage. In 3D, with ``Ω = ω̂``, the equation
``B_K Ω̇ + Ω̇ B_K = [B_K, Ω²] − M (κ + X_G) ∧ (Ω²κ + G)`` (``κ = rΓ``,
``B_K = B_C + M (X_G κᵀ + κ X_Gᵀ) + M κκᵀ``, G the gravity's body vector: ``⟨g, ν⟩ Γ`` with
gravity along ν, the field G on an incline, none without gravity) is the 3 × 3 system::

    M_K ω̇ = (M_K ω) × ω + M (κ + X_G) × (ω × (ω × κ) + G),   M_K = tr(B_K) I − B_K

(``B x̂ + x̂ B = ((tr B) I − B) x ^`` for a symmetric B, ``vee(a ∧ b) = b × a``), solved in every
lane by the adjugate of M_K, as :mod:`lieint.fast.chaplygin_lanes` solves the Chaplygin ball's.
The bodies of a block are stored structure-of-arrays in the user's frame: ω, the attitude as a
unit quaternion q, Γ, the centre c and G (zero rows where the ball has none).

The RKMK step is the generic path's on ``SE(3) × so(3)`` (``SO(3) × so(3)`` when the centre is
not tracked) in vectors: the generator is ``ξ = ((ω, r ω × Γ), ω̇)``, the right action of
``((exp û, t), δ)`` with ``t = φ₁(û) v`` is::

    ω ← ω + δ,   Γ ← exp(−û)Γ,   G ← exp(−û)G,   c ← c + R t,   q ← q ⊗ (cos(θ/2), sin(θ/2) u/θ);

the so(3) factor is abelian, so its slopes need no dexp⁻¹ and only the pose's rotation meets the
dexp⁻¹ radius. The bracket, the coefficients, the strict IEEE arithmetic with explicit fused
multiply-adds and the spare lanes (copies of the block's first body) are
:mod:`lieint.fast.heavy_lanes`'s.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .chaplygin_lanes import move_centres, project_poses
from .fused import fma
from .heavy_lanes import (
    INCREMENT_ROWS,
    _coefficients,
    _dexpinv_pass,
    _rotated_back,
    _step_coefficients,
    _turn_quaternions,
)
from .lanes import _combine, _cross, blocks_of, increment_rows, rows_of

__all__ = ["NAMESPACES", "blocks_from_state", "blocks_to_rows", "increments_to_user"]

#: rows of a block: ω (3), q (4), Γ (3), the centre (3), G (3)
ROWS = 16
#: rows of a step's increment: the pose's (u_w, u_v) (6), then δ (3)
STEP_ROWS = INCREMENT_ROWS + 3
#: the parameters: J = tr(B_C) I − B_C (9), M, r, ν (3), whether the centre is tracked, the
#: gravity mode (0 none, 1 along ν, 2 tilted: G a field), ⟨g, ν⟩, |g|, X_G (3)
_MASS, _RADIUS, _NORMAL, _TRACK, _MODE, _G_NORMAL, _G_NORM, _X_G = 9, 10, 11, 14, 15, 16, 17, 18
PARAMS = 21


@njit(cache=True, inline="always")
def _acceleration(w0, w1, w2, g0, g1, g2, f0, f1, f2, par):
    """ω̇ of lane (ω, Γ) with the gravity vector ``f`` = G: ``M_K ω̇ = (M_K ω) × ω + M (κ + X_G) ×
    (ω × (ω × κ) + G)``, by the adjugate of the symmetric ``M_K = J + M (e I − X_G κᵀ − κ X_Gᵀ −
    κκᵀ)``, ``e = 2⟨X_G, κ⟩ + |κ|²``."""
    M, r = par[_MASS], par[_RADIUS]
    x0, x1, x2 = par[_X_G], par[_X_G + 1], par[_X_G + 2]
    k0, k1, k2 = r * g0, r * g1, r * g2
    e = fma(k2, k2 + 2.0 * x2, fma(k1, k1 + 2.0 * x1, k0 * (k0 + 2.0 * x0)))
    m00 = fma(M, e - k0 * (k0 + 2.0 * x0), par[0])
    m11 = fma(M, e - k1 * (k1 + 2.0 * x1), par[4])
    m22 = fma(M, e - k2 * (k2 + 2.0 * x2), par[8])
    m01 = fma(-M, fma(x0, k1, k0 * (k1 + x1)), par[1])
    m02 = fma(-M, fma(x0, k2, k0 * (k2 + x2)), par[2])
    m12 = fma(-M, fma(x1, k2, k1 * (k2 + x2)), par[5])
    # the right-hand side: (M_K ω) × ω + M (κ + X_G) × (ω × (ω × κ) + G)
    a0 = fma(m02, w2, fma(m01, w1, m00 * w0))
    a1 = fma(m12, w2, fma(m11, w1, m01 * w0))
    a2 = fma(m22, w2, fma(m12, w1, m02 * w0))
    c0, c1, c2 = _cross(a0, a1, a2, w0, w1, w2)
    n0, n1, n2 = _cross(w0, w1, w2, k0, k1, k2)
    n0, n1, n2 = _cross(w0, w1, w2, n0, n1, n2)
    d0, d1, d2 = _cross(k0 + x0, k1 + x1, k2 + x2, n0 + f0, n1 + f1, n2 + f2)
    c0, c1, c2 = fma(M, d0, c0), fma(M, d1, c1), fma(M, d2, c2)
    # the adjugate of M_K
    j00 = fma(m11, m22, -(m12 * m12))
    j01 = fma(m02, m12, -(m01 * m22))
    j02 = fma(m01, m12, -(m02 * m11))
    j11 = fma(m00, m22, -(m02 * m02))
    j12 = fma(m01, m02, -(m00 * m12))
    j22 = fma(m00, m11, -(m01 * m01))
    inv = 1.0 / fma(m02, j02, fma(m01, j01, m00 * j00))
    return (
        fma(j02, c2, fma(j01, c1, j00 * c0)) * inv,
        fma(j12, c2, fma(j11, c1, j01 * c0)) * inv,
        fma(j22, c2, fma(j12, c1, j02 * c0)) * inv,
    )


@njit(cache=True, inline="always")
def _views(y, row):
    """ω, q, Γ, the centre and G of a block's flat state."""
    return (
        y[: 3 * row].reshape((3, row)), y[3 * row : 7 * row].reshape((4, row)),
        y[7 * row : 10 * row].reshape((3, row)), y[10 * row : 13 * row].reshape((3, row)),
        y[13 * row :].reshape((3, row)),
    )  # fmt: skip


@njit(cache=True)
def block_prepare(ctx):
    return ctx


@njit(cache=True)
def block_scratch(fx, meth, par, d):
    """The pose's stage slopes K and the so(3) factor's Kd (s, 6 | 3, row), their increments u,
    ud and the bracket's term t, the coefficients' rows and private copies of the parameters
    (:mod:`lieint.fast.lanes`)."""
    row = d // ROWS
    s = meth.b.shape[0]
    return (
        np.zeros((s, INCREMENT_ROWS, row)), np.zeros((s, 3, row)), np.zeros((INCREMENT_ROWS, row)),
        np.zeros((3, row)), np.zeros((INCREMENT_ROWS, row)),
        np.zeros(row), np.zeros(row), np.zeros(row), np.zeros(row), np.zeros(row),
        par.copy(), meth.A.copy(), meth.b.reshape((1, s)).copy(), meth.coeffs.copy(),
    )  # fmt: skip


@njit(cache=True, inline="always")
def _slope_into(w0, w1, w2, g0, g1, g2, G, par, K, Kd, st, l):
    """``K[st]``, ``Kd[st]`` of lane l at the state (ω, Γ, G): ``ξ = ((ω, r ω × Γ), ω̇)`` (the
    translation zero without the centre)."""
    mode = par[_MODE]
    if mode == 1.0:
        c = par[_G_NORMAL]
        f0, f1, f2 = c * g0, c * g1, c * g2
    elif mode == 2.0:
        f0, f1, f2 = G
    else:
        f0, f1, f2 = 0.0, 0.0, 0.0
    Kd[st, 0, l], Kd[st, 1, l], Kd[st, 2, l] = _acceleration(w0, w1, w2, g0, g1, g2, f0, f1, f2, par)
    K[st, 0, l], K[st, 1, l], K[st, 2, l] = w0, w1, w2
    r = par[_RADIUS] * par[_TRACK]
    v0, v1, v2 = _cross(w0, w1, w2, g0, g1, g2)
    K[st, 3, l], K[st, 4, l], K[st, 5, l] = r * v0, r * v1, r * v2


@njit(cache=True, error_model="numpy")  # no Python division checks: they would stop the SIMD passes
def block_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One RKMK step (exponential coordinates on se(3) × so(3)) of every lane of a block; −1 when
    a stage of a lane left the dexp⁻¹ radius. ``inc`` receives the increments (u_w, u_v, δ),
    ``aux[0]`` the largest ``|ω|²`` over the block."""
    K, Kd, u, ud, tt = scr[0], scr[1], scr[2], scr[3], scr[4]
    ca, cb, cc, ch, sh = scr[5], scr[6], scr[7], scr[8], scr[9]
    pr, A, b, coeffs = scr[10], scr[11], scr[12], scr[13]
    d = y.shape[0]
    row = d // ROWS
    L = row - 8
    for i in range(d):
        y1[i] = y[i]
    W, qb, Gm, C, Gv = _views(y1, row)
    s = b.shape[1]
    for st in range(s):
        _combine(ud, Kd, A, st, h, st, L)  # every stage's weights also weigh the pose (below)
        if not _combine(u, K, A, st, h, st, L):
            for l in range(L):
                G = (Gv[0, l], Gv[1, l], Gv[2, l])
                _slope_into(W[0, l], W[1, l], W[2, l], Gm[0, l], Gm[1, l], Gm[2, l], G, pr, K, Kd, st, l)
            continue
        if _coefficients(u, ca, cb, cc, L):
            return -1  # a stage left the dexp⁻¹ radius: the block stops here (as the generic path)
        for l in range(L):
            u0, u1, u2 = u[0, l], u[1, l], u[2, l]
            g0, g1, g2 = _rotated_back(u0, u1, u2, Gm[0, l], Gm[1, l], Gm[2, l], ca[l], cb[l])
            G = _rotated_back(u0, u1, u2, Gv[0, l], Gv[1, l], Gv[2, l], ca[l], cb[l])
            w0, w1, w2 = W[0, l] + ud[0, l], W[1, l] + ud[1, l], W[2, l] + ud[2, l]
            _slope_into(w0, w1, w2, g0, g1, g2, G, pr, K, Kd, st, l)
        _dexpinv_pass(u, K, tt, coeffs, st, L)  # the so(3) factor is abelian: its dexp⁻¹ is 1
    largest = 0.0
    for l in range(L):
        largest = max(largest, W[0, l] * W[0, l] + W[1, l] * W[1, l] + W[2, l] * W[2, l])
    aux[0] = largest
    # U = h Σ b_j K_j; ω ← ω + U_δ; (Γ, G) ← exp(−Û_w)(Γ, G); c ← c + R φ₁(Û_w) U_v; q ← q ⊗ exp(Û_w)
    _combine(u, K, b, 0, h, s, L)
    _combine(ud, Kd, b, 0, h, s, L)
    _step_coefficients(u, ca, cb, cc, ch, sh, L)
    tilted = pr[_MODE] == 2.0
    for l in range(L):
        u0, u1, u2 = u[0, l], u[1, l], u[2, l]
        W[0, l], W[1, l], W[2, l] = W[0, l] + ud[0, l], W[1, l] + ud[1, l], W[2, l] + ud[2, l]
        Gm[0, l], Gm[1, l], Gm[2, l] = _rotated_back(u0, u1, u2, Gm[0, l], Gm[1, l], Gm[2, l], ca[l], cb[l])
        if tilted:
            Gv[0, l], Gv[1, l], Gv[2, l] = _rotated_back(u0, u1, u2, Gv[0, l], Gv[1, l], Gv[2, l], ca[l], cb[l])
    if pr[_TRACK] != 0.0:
        move_centres(u, qb, C, cb, cc, L)
    _turn_quaternions(u, qb, ch, sh, L)
    if inc.shape[0] >= STEP_ROWS * row:
        for dd in range(STEP_ROWS):
            for l in range(row):
                if l >= L:
                    inc[dd * row + l] = 0.0
                else:
                    inc[dd * row + l] = u[dd, l] if dd < INCREMENT_ROWS else ud[dd - INCREMENT_ROWS, l]
    return s


@njit(cache=True)
def block_project(fx, y, par, out, scr):
    """Every lane's quaternion and Γ onto their unit spheres, G onto ``|G| = |g|`` on an incline,
    the centre back onto the plane ``⟨c, ν⟩ = r``."""
    d = y.shape[0]
    row = d // ROWS
    for i in range(d):
        out[i] = y[i]
    _, qb, Gm, C, Gv = _views(out, row)
    L = row - 8
    project_poses(qb, Gm, C, par[_NORMAL], par[_NORMAL + 1], par[_NORMAL + 2], par[_RADIUS], par[_TRACK] != 0.0, L)
    if par[_MODE] == 2.0:
        g = par[_G_NORM]
        for l in range(L):
            g0, g1, g2 = Gv[0, l], Gv[1, l], Gv[2, l]
            m = g / np.sqrt(fma(g2, g2, fma(g1, g1, g0 * g0)))
            Gv[0, l], Gv[1, l], Gv[2, l] = g0 * m, g1 * m, g2 * m


@njit(cache=True)
def block_radius2(fx, y, par, scr):
    """The largest ``|ω|²`` of the block's lanes (the ad spectral radius of ξ's rotation)."""
    row = y.shape[0] // ROWS
    W = y[: 3 * row].reshape((3, row))
    largest = 0.0
    for l in range(row - 8):
        largest = max(largest, W[0, l] * W[0, l] + W[1, l] * W[1, l] + W[2, l] * W[2, l])
    return largest


#: the names of :mod:`lieint.fast.loop` this form binds (fixed-step RKMK in exponential coordinates)
NAMESPACES = {
    "rkmk": {
        "prepare": block_prepare,
        "scratch": block_scratch,
        "step": block_step,
        "project": block_project,
        "radius2": block_radius2,
    }
}


# -- conversions between the user's fields and the blocks ---------------------------------------


def blocks_from_state(omega, q, gamma, center, G, N: int) -> np.ndarray:
    """The blocks of an ensemble of N balls (ω, Γ, the centre, G (N, 3), quaternions (4, N))."""
    return blocks_of(np.concatenate([omega, np.asarray(q).T, gamma, center, G], axis=1), N, ROWS)


def blocks_to_rows(Y, N: int) -> np.ndarray:
    """The bodies' rows (m, N, 16) of rows of blocks: ω, q, Γ, the centre, G."""
    return rows_of(Y, N, ROWS)


def increments_to_user(U, N: int):
    """The increments of rows of blocks (m, nblocks, 9 row) as ``(u_w, u_v, δ)``, three ``(m, N, 3)``."""
    u = increment_rows(U, N, STEP_ROWS)
    return u[..., :3], u[..., 3:6], u[..., 6:]
