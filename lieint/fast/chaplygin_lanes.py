"""Ensemble kernel for the 3D Chaplygin ball: bodies in SIMD lanes.

The ball's per-body path (its compiled pieces, :mod:`lieint.fast.balls`) solves a Lyapunov
equation for Ω at every stage. In 3D, with ``A_K = −Π̂`` and ``Ω = ω̂``, the equation
``B_K Ω + Ω B_K = −A_K`` is the symmetric 3 × 3 system ``M_K ω = Π`` with
``M_K = tr(B_K) I − B_K = J + M r² (|Γ|² I − ΓΓᵀ)``, ``J = tr(B_C) I − B_C``: this kernel solves
it in every lane by the adjugate (Cramer's rule: no pivoting, so the same operations in every
lane). The bodies of a block are stored structure-of-arrays in the user's frame (the contact
tensor turns with Γ: there is no fixed principal frame): ``Π``, the attitude as a unit quaternion
q, ``Γ`` and the centre c (zero rows without one).

The RKMK step is the generic path's (:mod:`lieint.methods.rkmk`) in vectors: the generator is
``ξ = (ω, r ω × Γ)`` on se(3) (``(ω, 0)`` when the centre is not tracked: so(3)), the right
action of ``(exp û, t)``, ``t = φ₁(û) v``, is::

    Π ← exp(−û)Π,   Γ ← exp(−û)Γ,   c ← c + R t,   q ← q ⊗ (cos(θ/2), sin(θ/2) u/θ),

with the bracket, the coefficients, the strict IEEE arithmetic with explicit fused multiply-adds
and the spare lanes (copies of the block's first body) of :mod:`lieint.fast.heavy_lanes`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

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
from .quaternions import matrices_from_lanes
from .top3 import minus_hat

__all__ = ["NAMESPACES", "blocks_from_state", "blocks_to_user", "increments_to_user", "move_centres", "project_poses"]

#: rows of a block: Π (3), q (4), Γ (3), the centre (3)
ROWS = 13
#: the parameters: J = tr(B_C) I − B_C (9), M r², r, ν (3), whether the centre is tracked
_MR2, _RADIUS, _NORMAL, _TRACK = 9, 10, 11, 14


@njit(cache=True, inline="always")
def _angular_velocity(p0, p1, p2, g0, g1, g2, J, mr2):
    """ω from ``M_K ω = Π``, ``M_K = J + M r² (|Γ|² I − ΓΓᵀ)``, by the adjugate of M_K."""
    gg = fma(g2, g2, fma(g1, g1, g0 * g0))
    m00 = fma(mr2, gg - g0 * g0, J[0])
    m11 = fma(mr2, gg - g1 * g1, J[4])
    m22 = fma(mr2, gg - g2 * g2, J[8])
    m01 = fma(-mr2, g0 * g1, J[1])
    m02 = fma(-mr2, g0 * g2, J[2])
    m12 = fma(-mr2, g1 * g2, J[5])
    c00 = fma(m11, m22, -(m12 * m12))
    c01 = fma(m02, m12, -(m01 * m22))
    c02 = fma(m01, m12, -(m02 * m11))
    c11 = fma(m00, m22, -(m02 * m02))
    c12 = fma(m01, m02, -(m00 * m12))
    c22 = fma(m00, m11, -(m01 * m01))
    inv = 1.0 / fma(m02, c02, fma(m01, c01, m00 * c00))
    w0 = fma(c02, p2, fma(c01, p1, c00 * p0)) * inv
    w1 = fma(c12, p2, fma(c11, p1, c01 * p0)) * inv
    w2 = fma(c22, p2, fma(c12, p1, c02 * p0)) * inv
    return w0, w1, w2


@njit(cache=True, inline="always")
def _views(y, row):
    """Π, q, Γ and the centre of a block's flat state."""
    return (
        y[: 3 * row].reshape((3, row)), y[3 * row : 7 * row].reshape((4, row)),
        y[7 * row : 10 * row].reshape((3, row)), y[10 * row :].reshape((3, row)),
    )  # fmt: skip


@njit(cache=True)
def block_prepare(ctx):
    return ctx


@njit(cache=True)
def block_scratch(fx, meth, par, d):
    """The stage slopes K (s, 6, row), the increment u and the bracket's term t (6, row), the
    coefficients' rows and private copies of the parameters (:mod:`lieint.fast.lanes`)."""
    row = d // ROWS
    s = meth.b.shape[0]
    return (
        np.zeros((s, INCREMENT_ROWS, row)), np.zeros((INCREMENT_ROWS, row)), np.zeros((INCREMENT_ROWS, row)),
        np.zeros(row), np.zeros(row), np.zeros(row), np.zeros(row), np.zeros(row),
        par.copy(), meth.A.copy(), meth.b.reshape((1, s)).copy(), meth.coeffs.copy(),
    )  # fmt: skip


@njit(cache=True, inline="always")
def _slope_into(p0, p1, p2, g0, g1, g2, par, K, st, l):
    """``K[st]`` of lane l: ``ξ = (ω, r ω × Γ)`` (the translation zero without the centre)."""
    w0, w1, w2 = _angular_velocity(p0, p1, p2, g0, g1, g2, par[0:9], par[_MR2])
    K[st, 0, l], K[st, 1, l], K[st, 2, l] = w0, w1, w2
    r = par[_RADIUS] * par[_TRACK]
    v0, v1, v2 = _cross(w0, w1, w2, g0, g1, g2)
    K[st, 3, l], K[st, 4, l], K[st, 5, l] = r * v0, r * v1, r * v2


@njit(cache=True, inline="always")
def move_centres(u, qb, C, cb, cc, L):
    """``c ← c + R t`` in every lane, ``t = φ₁(û_w) u_v = u_v + c_b u_w × u_v + c_c u_w × (u_w × u_v)``,
    R the attitude q before the step (the translation of the right action on SE(3))."""
    for l in range(L):
        u0, u1, u2 = u[0, l], u[1, l], u[2, l]
        v0, v1, v2 = u[3, l], u[4, l], u[5, l]
        n0, n1, n2 = _cross(u0, u1, u2, v0, v1, v2)
        m0, m1, m2 = _cross(u0, u1, u2, n0, n1, n2)
        t0 = fma(cc[l], m0, fma(cb[l], n0, v0))
        t1 = fma(cc[l], m1, fma(cb[l], n1, v1))
        t2 = fma(cc[l], m2, fma(cb[l], n2, v2))
        # R t = t + 2w (x × t) + 2 x × (x × t) for q = (w, x)
        w, x0, x1, x2 = qb[0, l], qb[1, l], qb[2, l], qb[3, l]
        e0, e1, e2 = _cross(x0, x1, x2, t0, t1, t2)
        f0, f1, f2 = _cross(x0, x1, x2, e0, e1, e2)
        C[0, l] = C[0, l] + fma(2.0, f0, fma(2.0 * w, e0, t0))
        C[1, l] = C[1, l] + fma(2.0, f1, fma(2.0 * w, e1, t1))
        C[2, l] = C[2, l] + fma(2.0, f2, fma(2.0 * w, e2, t2))


@njit(cache=True, inline="always")
def project_poses(qb, G, C, n0, n1, n2, r, track, L):
    """Every lane's quaternion and Γ onto their unit spheres and, when the centre is tracked,
    the centre back onto the plane ``⟨c, ν⟩ = r``."""
    for l in range(L):
        r0, r1, r2, r3 = qb[0, l], qb[1, l], qb[2, l], qb[3, l]
        m = 1.0 / np.sqrt(fma(r3, r3, fma(r2, r2, fma(r1, r1, r0 * r0))))
        qb[0, l], qb[1, l], qb[2, l], qb[3, l] = r0 * m, r1 * m, r2 * m, r3 * m
        g0, g1, g2 = G[0, l], G[1, l], G[2, l]
        m = 1.0 / np.sqrt(fma(g2, g2, fma(g1, g1, g0 * g0)))
        G[0, l], G[1, l], G[2, l] = g0 * m, g1 * m, g2 * m
        if track:
            off = fma(C[2, l], n2, fma(C[1, l], n1, C[0, l] * n0)) - r
            C[0, l], C[1, l], C[2, l] = C[0, l] - off * n0, C[1, l] - off * n1, C[2, l] - off * n2


@njit(cache=True, error_model="numpy")  # no Python division checks: they would stop the SIMD passes
def block_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One RKMK step (exponential coordinates on se(3)) of every lane of a block; −1 when a
    stage of a lane left the dexp⁻¹ radius. ``inc`` receives the increments (u_w, u_v), ``aux[0]``
    the largest ``|ω|²`` of ξ(y) over the block."""
    K, u, tt, ca, cb, cc, ch, sh = scr[0], scr[1], scr[2], scr[3], scr[4], scr[5], scr[6], scr[7]
    pr, A, b, coeffs = scr[8], scr[9], scr[10], scr[11]
    d = y.shape[0]
    row = d // ROWS
    L = row - 8
    for i in range(d):
        y1[i] = y[i]
    P, qb, G, C = _views(y1, row)
    s = b.shape[1]
    for st in range(s):
        if not _combine(u, K, A, st, h, st, L):
            for l in range(L):
                _slope_into(P[0, l], P[1, l], P[2, l], G[0, l], G[1, l], G[2, l], pr, K, st, l)
            continue
        if _coefficients(u, ca, cb, cc, L):
            return -1  # a stage left the dexp⁻¹ radius: the block stops here (as the generic path)
        for l in range(L):
            u0, u1, u2 = u[0, l], u[1, l], u[2, l]
            p0, p1, p2 = _rotated_back(u0, u1, u2, P[0, l], P[1, l], P[2, l], ca[l], cb[l])
            g0, g1, g2 = _rotated_back(u0, u1, u2, G[0, l], G[1, l], G[2, l], ca[l], cb[l])
            _slope_into(p0, p1, p2, g0, g1, g2, pr, K, st, l)
        _dexpinv_pass(u, K, tt, coeffs, st, L)
    largest = 0.0
    for l in range(L):
        w2 = K[0, 0, l] * K[0, 0, l] + K[0, 1, l] * K[0, 1, l] + K[0, 2, l] * K[0, 2, l]
        largest = max(largest, w2)
    aux[0] = largest
    # U = h Σ b_j K_j; (Π, Γ) ← exp(−Û_w)(Π, Γ); c ← c + R φ₁(Û_w) U_v; q ← q ⊗ exp(Û_w)
    _combine(u, K, b, 0, h, s, L)
    _step_coefficients(u, ca, cb, cc, ch, sh, L)
    for l in range(L):
        u0, u1, u2 = u[0, l], u[1, l], u[2, l]
        P[0, l], P[1, l], P[2, l] = _rotated_back(u0, u1, u2, P[0, l], P[1, l], P[2, l], ca[l], cb[l])
        G[0, l], G[1, l], G[2, l] = _rotated_back(u0, u1, u2, G[0, l], G[1, l], G[2, l], ca[l], cb[l])
    if pr[_TRACK] != 0.0:
        move_centres(u, qb, C, cb, cc, L)
    _turn_quaternions(u, qb, ch, sh, L)
    if inc.shape[0] >= INCREMENT_ROWS * row:
        for dd in range(INCREMENT_ROWS):
            for l in range(row):
                inc[dd * row + l] = u[dd, l] if l < L else 0.0
    return s


@njit(cache=True)
def block_project(fx, y, par, out, scr):
    """Every lane's quaternion and Γ onto their unit spheres, the centre back onto the plane
    ``⟨c, ν⟩ = r``."""
    d = y.shape[0]
    row = d // ROWS
    for i in range(d):
        out[i] = y[i]
    _, qb, G, C = _views(out, row)
    project_poses(qb, G, C, par[_NORMAL], par[_NORMAL + 1], par[_NORMAL + 2], par[_RADIUS], par[_TRACK] != 0.0, row - 8)


@njit(cache=True)
def block_radius2(fx, y, par, scr):
    """The largest ``|ω|²`` of the block's lanes (the ad spectral radius of ξ on se(3) is |ω|)."""
    row = y.shape[0] // ROWS
    P, _, G, _ = _views(y, row)
    largest = 0.0
    for l in range(row - 8):
        w0, w1, w2 = _angular_velocity(P[0, l], P[1, l], P[2, l], G[0, l], G[1, l], G[2, l], par[0:9], par[_MR2])
        largest = max(largest, w0 * w0 + w1 * w1 + w2 * w2)
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


def blocks_from_state(pi, q, gamma, center, N: int) -> np.ndarray:
    """The blocks of an ensemble of N balls (``Π``, ``Γ``, the centre (N, 3), quaternions (4, N))."""
    return blocks_of(np.concatenate([pi, np.asarray(q).T, gamma, center], axis=1), N, ROWS)


def blocks_to_user(Y, N: int, orientation: bool, center: bool):
    """``(A, Γ, R, c)`` of rows of blocks (m, nblocks, d) (R, c None where the state has none)."""
    X = rows_of(Y, N, ROWS)
    A = minus_hat(X[..., :3])
    R = matrices_from_lanes(np.swapaxes(X[..., 3:7], 1, 2)) if orientation else None
    return A, X[..., 7:10].copy(), R, (X[..., 10:13].copy() if center else None)


def increments_to_user(U, N: int):
    """The increments of rows of blocks (m, nblocks, 6 row) as ``(u_w, u_v)``, two ``(m, N, 3)``."""
    u = increment_rows(U, N, INCREMENT_ROWS)
    return u[..., :3], u[..., 3:]
