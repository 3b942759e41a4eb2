"""Ensemble kernel for the 3D heavy top: bodies in SIMD lanes.

The heavy top's per-body path (its compiled pieces, :mod:`lieint.fast.bodies`, through
:mod:`lieint.fast.generic`) steps one body's 3 × 3 matrices at a time. For ensembles this kernel
works as :mod:`lieint.fast.lanes` does for the free 3D top: the bodies of a block are stored
structure-of-arrays in the principal frame of the top (``Π`` with ``A = −Π̂``, the attitude as a
unit quaternion ``q`` of ``R P``, the body gravity ``Γ``) and each operation of an RKMK step on
``se(3)`` is one loop over the block, which the compiler vectorises.

The RKMK step on ``SE(3)`` (the generic path's, :mod:`lieint.methods.rkmk`), in vectors: the
generator is ``ξ = (w, v) = (I⁻¹Π, M X_G)`` (the translation part constant), the right action of
``(exp û, t)`` with ``t = φ₁(û) v = v + c_b u × v + c_c u × (u × v)`` is::

    Π ← exp(−û)(Π + t × Γ),   Γ ← exp(−û) Γ,   q ← q ⊗ (cos(θ/2), sin(θ/2) u/θ)

(``A + t∧Γ = −(Π + t × Γ)^``), and the bracket of ``se(3)`` is
``ad_{−u}(x, y) = (x × u_w, y × u_w + x × u_v)``. The coefficients ``sin θ/θ``,
``(1 − cos θ)/θ²``, ``(θ − sin θ)/θ³``, ``cos(θ/2)``, ``sin(θ/2)/θ`` are Taylor polynomials below
θ = 0.1 (every stage of a resolved step) and trigonometric in a scalar fix-up beyond.

The arithmetic is strict IEEE with explicit fused multiply-adds (:mod:`lieint.fast.fused`), the
same expressions in every lane: a body's result depends neither on its neighbours nor on its
position, and an ensemble cut into chunks gives one call's bits. A block's spare lanes (beyond
the ensemble) hold a copy of its first body, so that they move as a real top does (a heavy top
with Γ = 0 would not survive the projection onto ``|Γ| = |g|``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .fused import fma
from .lanes import _combine, _cross, _half_angle, _rodrigues, blocks_of, increment_rows
from .quaternions import rotation_into

__all__ = ["NAMESPACES", "blocks_from_state", "blocks_to_user", "increments_to_user"]

#: rows of a block: Π (3), q (4), Γ (3): the first seven are the free top's (:mod:`lieint.fast.lanes`)
ROWS = 10
#: rows of a step's increment: u_w (3), u_v (3)
INCREMENT_ROWS = 6
# (2π)²: the dexp⁻¹ series of se(3) converges for |u_w| < 2π
_RADIUS2 = (2.0 * np.pi) ** 2


@njit(cache=True, inline="always")
def _phi3(t2):
    """``(θ − sin θ)/θ³ = Σ_k (−1)^k θ^{2k}/(2k + 3)!`` to degree 10 in θ (Horner's scheme in fused
    multiply-adds), exact to round-off for θ < 0.1 (the first omitted term is below 1e-24)."""
    c = fma(t2, -1.0 / 6227020800, 1.0 / 39916800)
    c = fma(t2, c, -1.0 / 362880)
    c = fma(t2, c, 1.0 / 5040)
    c = fma(t2, c, -1.0 / 120)
    return fma(t2, c, 1.0 / 6)


@njit(cache=True, inline="always")
def _norm2_of(u, l):
    """``θ² = |u_w|²`` of lane l (the rotation rows 0–2 of u)."""
    return fma(u[2, l], u[2, l], fma(u[1, l], u[1, l], u[0, l] * u[0, l]))


@njit(cache=True, inline="always")
def _trig(t2):
    """The three rotation coefficients by trigonometry (θ ≥ 0.1, scalar)."""
    th = np.sqrt(t2)
    s, c = np.sin(th), np.cos(th)
    return s / th, (1.0 - c) / t2, (th - s) / (t2 * th)


@njit(cache=True, inline="always")
def _coefficients(u, ca, cb, cc, L):
    """``sin θ/θ``, ``(1 − cos θ)/θ²``, ``(θ − sin θ)/θ³`` of every lane's u_w: a polynomial pass,
    then a scalar pass with trigonometry for lanes beyond θ = 0.1. Returns whether a lane's θ
    reached the dexp⁻¹ radius 2π."""
    nlarge = 0
    for l in range(L):
        t2 = _norm2_of(u, l)
        if t2 >= 1e-2:
            nlarge += 1
        ca[l], cb[l] = _rodrigues(t2)
        cc[l] = _phi3(t2)
    if nlarge == 0:
        return False
    out = False
    for l in range(L):
        t2 = _norm2_of(u, l)
        if t2 >= 1e-2:
            out |= t2 >= _RADIUS2
            ca[l], cb[l], cc[l] = _trig(t2)
    return out


@njit(cache=True, inline="always")
def _moved_momentum(u, P, G, a, b, c, l):
    """``exp(−û)(Π + t × Γ)`` of lane l, ``t = φ₁(û) v = v + b u × v + c u × (u × v)``."""
    u0, u1, u2 = u[0, l], u[1, l], u[2, l]
    v0, v1, v2 = u[3, l], u[4, l], u[5, l]
    n0, n1, n2 = _cross(u0, u1, u2, v0, v1, v2)
    m0, m1, m2 = _cross(u0, u1, u2, n0, n1, n2)
    t0, t1, t2 = fma(c, m0, fma(b, n0, v0)), fma(c, m1, fma(b, n1, v1)), fma(c, m2, fma(b, n2, v2))
    g0, g1, g2 = G[0, l], G[1, l], G[2, l]
    x0, x1, x2 = _cross(t0, t1, t2, g0, g1, g2)
    x0, x1, x2 = P[0, l] + x0, P[1, l] + x1, P[2, l] + x2
    return _rotated_back(u0, u1, u2, x0, x1, x2, a, b)


@njit(cache=True, inline="always")
def _rotated_back(u0, u1, u2, x0, x1, x2, a, b):
    """``exp(−û)x = x − a u × x + b u × (u × x)``."""
    c0, c1, c2 = _cross(u0, u1, u2, x0, x1, x2)
    e0, e1, e2 = _cross(u0, u1, u2, c0, c1, c2)
    return fma(b, e0, fma(-a, c0, x0)), fma(b, e1, fma(-a, c1, x1)), fma(b, e2, fma(-a, c2, x2))


@njit(cache=True, inline="always")
def _dexpinv_pass(u, K, tt, coeffs, st, L):
    """``K[st] ← Σ_d c_d ad_{−u}^d K[st]`` (dexp⁻¹ of se(3) truncated at the method's degree),
    ``ad_{−u}(x, y) = (x × u_w, y × u_w + x × u_v)``; ``tt`` holds the current term."""
    for dd in range(INCREMENT_ROWS):
        for l in range(L):
            tt[dd, l] = K[st, dd, l]
    for deg in range(1, coeffs.shape[0]):
        cf = coeffs[deg]
        for l in range(L):
            x0, x1, x2 = tt[0, l], tt[1, l], tt[2, l]
            w0, w1, w2 = u[0, l], u[1, l], u[2, l]
            n0, n1, n2 = _cross(x0, x1, x2, w0, w1, w2)
            a0, a1, a2 = _cross(tt[3, l], tt[4, l], tt[5, l], w0, w1, w2)
            b0, b1, b2 = _cross(x0, x1, x2, u[3, l], u[4, l], u[5, l])
            tt[0, l], tt[1, l], tt[2, l] = n0, n1, n2
            tt[3, l], tt[4, l], tt[5, l] = a0 + b0, a1 + b1, a2 + b2
        if cf != 0.0:
            for dd in range(INCREMENT_ROWS):
                for l in range(L):
                    K[st, dd, l] = fma(cf, tt[dd, l], K[st, dd, l])


@njit(cache=True, inline="always")
def _step_coefficients(u, ca, cb, cc, ch, sh, L):
    """The rotation coefficients of the step's increment and ``cos(θ/2)``, ``sin(θ/2)/θ``."""
    _coefficients(u, ca, cb, cc, L)
    for l in range(L):
        ch[l], sh[l] = _half_angle(_norm2_of(u, l))
    for l in range(L):
        t2 = _norm2_of(u, l)
        if t2 >= 1e-2:
            th = np.sqrt(t2)
            ch[l], sh[l] = np.cos(0.5 * th), np.sin(0.5 * th) / th


@njit(cache=True, inline="always")
def _turn_quaternions(u, qb, ch, sh, L):
    """``q ← q ⊗ (cos(θ/2), sin(θ/2) u_w/θ)`` of every lane (``R ← R exp(û_w)``)."""
    for l in range(L):
        c, t = ch[l], sh[l]
        w0, w1, w2 = t * u[0, l], t * u[1, l], t * u[2, l]
        q0, q1, q2, q3 = qb[0, l], qb[1, l], qb[2, l], qb[3, l]
        qb[0, l] = fma(-q3, w2, fma(-q2, w1, fma(-q1, w0, q0 * c)))
        qb[1, l] = fma(-q3, w1, fma(q2, w2, fma(q1, c, q0 * w0)))
        qb[2, l] = fma(q3, w0, fma(q2, c, fma(-q1, w2, q0 * w1)))
        qb[3, l] = fma(q3, c, fma(-q2, w0, fma(q1, w1, q0 * w2)))


@njit(cache=True, inline="always")
def _views(y, row):
    """Π (3, row), q (4, row) and Γ (3, row) of a block's flat state."""
    return y[: 3 * row].reshape((3, row)), y[3 * row : 7 * row].reshape((4, row)), y[7 * row :].reshape((3, row))


@njit(cache=True)
def block_prepare(ctx):
    return ctx


@njit(cache=True)
def block_scratch(fx, meth, par, d):
    """The stage slopes K (s, 6, row), the increment u and the bracket's term t (6, row), the
    coefficients' rows, and private copies of the shared parameters (a view of an array shared
    between threads counts references on one cache line: :mod:`lieint.fast.lanes`)."""
    row = d // ROWS
    s = meth.b.shape[0]
    return (
        np.zeros((s, INCREMENT_ROWS, row)), np.zeros((INCREMENT_ROWS, row)), np.zeros((INCREMENT_ROWS, row)),
        np.zeros(row), np.zeros(row), np.zeros(row), np.zeros(row), np.zeros(row),
        par[0:6].copy(), meth.A.copy(), meth.b.reshape((1, s)).copy(), meth.coeffs.copy(),
    )  # fmt: skip


@njit(cache=True, inline="always")
def _generator_into(P, Iinv, MX, K, st, L):
    """``K[st] = ξ = (I⁻¹Π, M X_G)`` of every lane."""
    for dd in range(3):
        for l in range(L):
            K[st, dd, l] = Iinv[dd] * P[dd, l]
    for dd in range(3):
        for l in range(L):
            K[st, 3 + dd, l] = MX[dd]


@njit(cache=True, error_model="numpy")  # no Python division checks: they would stop the SIMD passes
def block_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One RKMK step (exponential coordinates on se(3)) of every lane of a block; −1 when a
    stage of a lane left the dexp⁻¹ radius. ``inc`` receives the increments (u_w, u_v) (six
    rows), ``aux[0]`` the largest ``|w|²`` of ξ(y) over the block."""
    K, u, tt, ca, cb, cc, ch, sh = scr[0], scr[1], scr[2], scr[3], scr[4], scr[5], scr[6], scr[7]
    Iinv, A, b, coeffs = scr[8][0:3], scr[9], scr[10], scr[11]
    MX = scr[8][3:6]
    d = y.shape[0]
    row = d // ROWS
    L = row - 8
    for i in range(d):
        y1[i] = y[i]
    P, qb, G = _views(y1, row)
    s = b.shape[1]
    for st in range(s):
        if not _combine(u, K, A, st, h, st, L):
            _generator_into(P, Iinv, MX, K, st, L)
            continue
        if _coefficients(u, ca, cb, cc, L):
            return -1  # a stage left the dexp⁻¹ radius: the block stops here (as the generic path)
        for l in range(L):  # the stage state's momentum, and ξ's rotation part I⁻¹Π_i
            p0, p1, p2 = _moved_momentum(u, P, G, ca[l], cb[l], cc[l], l)
            K[st, 0, l] = Iinv[0] * p0
            K[st, 1, l] = Iinv[1] * p1
            K[st, 2, l] = Iinv[2] * p2
        for dd in range(3):
            for l in range(L):
                K[st, 3 + dd, l] = MX[dd]
        _dexpinv_pass(u, K, tt, coeffs, st, L)
    largest = 0.0
    for l in range(L):
        w2 = K[0, 0, l] * K[0, 0, l] + K[0, 1, l] * K[0, 1, l] + K[0, 2, l] * K[0, 2, l]
        largest = max(largest, w2)
    aux[0] = largest
    # U = h Σ b_j K_j; (Π, Γ) ← exp(U)·(Π, Γ); q ← q ⊗ exp(Û_w)
    _combine(u, K, b, 0, h, s, L)
    _step_coefficients(u, ca, cb, cc, ch, sh, L)
    for l in range(L):
        p0, p1, p2 = _moved_momentum(u, P, G, ca[l], cb[l], cc[l], l)
        g0, g1, g2 = _rotated_back(u[0, l], u[1, l], u[2, l], G[0, l], G[1, l], G[2, l], ca[l], cb[l])
        P[0, l], P[1, l], P[2, l] = p0, p1, p2
        G[0, l], G[1, l], G[2, l] = g0, g1, g2
    _turn_quaternions(u, qb, ch, sh, L)
    if inc.shape[0] >= INCREMENT_ROWS * row:
        for dd in range(INCREMENT_ROWS):
            for l in range(row):
                inc[dd * row + l] = u[dd, l] if l < L else 0.0
    return s


@njit(cache=True)
def block_project(fx, y, par, out, scr):
    """Every lane's quaternion onto the unit sphere (the exact projection of its rotation) and
    its Γ onto the sphere ``|Γ| = |g|``."""
    d = y.shape[0]
    row = d // ROWS
    for i in range(d):
        out[i] = y[i]
    _, qb, G = _views(out, row)
    g = par[6]
    for l in range(row - 8):
        r0, r1, r2, r3 = qb[0, l], qb[1, l], qb[2, l], qb[3, l]
        n = 1.0 / np.sqrt(fma(r3, r3, fma(r2, r2, fma(r1, r1, r0 * r0))))
        qb[0, l], qb[1, l], qb[2, l], qb[3, l] = r0 * n, r1 * n, r2 * n, r3 * n
        g0, g1, g2 = G[0, l], G[1, l], G[2, l]
        m = g / np.sqrt(fma(g2, g2, fma(g1, g1, g0 * g0)))
        G[0, l], G[1, l], G[2, l] = g0 * m, g1 * m, g2 * m


@njit(cache=True)
def block_radius2(fx, y, par, scr):
    """The largest ``|w|²`` of the block's lanes, ``w = I⁻¹Π`` (the ad spectral radius of ξ on
    se(3) is |w|: the translation adds no eigenvalue)."""
    row = y.shape[0] // ROWS
    P = y[: 3 * row].reshape((3, row))
    largest = 0.0
    for l in range(row - 8):
        w0, w1, w2 = par[0] * P[0, l], par[1] * P[1, l], par[2] * P[2, l]
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


@njit(cache=True)
def _from_blocks(Y, L, N, P, identity, orient, out_A, out_G, out_R):
    """The user's A, Γ (and R) of rows of blocks ``Y`` (m, nblocks, d): ``A = −(P Π)^``,
    ``Γ = P Γ̃``, ``R = R(q) Pᵀ``."""
    row = L + 8
    for r in range(Y.shape[0]):
        for m in range(N):
            blk, l = m // L, m % L
            y = Y[r, blk]
            p0, p1, p2 = y[l], y[row + l], y[2 * row + l]
            g0, g1, g2 = y[7 * row + l], y[8 * row + l], y[9 * row + l]
            if not identity:
                p0, p1, p2 = (
                    P[0, 0] * p0 + P[0, 1] * p1 + P[0, 2] * p2,
                    P[1, 0] * p0 + P[1, 1] * p1 + P[1, 2] * p2,
                    P[2, 0] * p0 + P[2, 1] * p1 + P[2, 2] * p2,
                )
                g0, g1, g2 = (
                    P[0, 0] * g0 + P[0, 1] * g1 + P[0, 2] * g2,
                    P[1, 0] * g0 + P[1, 1] * g1 + P[1, 2] * g2,
                    P[2, 0] * g0 + P[2, 1] * g1 + P[2, 2] * g2,
                )
            A = out_A[r, m]
            A[0, 0], A[0, 1], A[0, 2] = 0.0, p2, -p1
            A[1, 0], A[1, 1], A[1, 2] = -p2, 0.0, p0
            A[2, 0], A[2, 1], A[2, 2] = p1, -p0, 0.0
            out_G[r, m, 0], out_G[r, m, 1], out_G[r, m, 2] = g0, g1, g2
            if not orient:
                continue
            R = out_R[r, m]
            rotation_into(y[3 * row + l], y[4 * row + l], y[5 * row + l], y[6 * row + l], R)
            if not identity:
                for i in range(3):
                    r0, r1, r2 = R[i, 0], R[i, 1], R[i, 2]
                    for j in range(3):
                        R[i, j] = r0 * P[j, 0] + r1 * P[j, 1] + r2 * P[j, 2]


def blocks_from_state(pi, q, gamma, N: int) -> np.ndarray:
    """The blocks of an ensemble of N heavy tops (``Π`` (N, 3) and ``Γ`` (N, 3) in the principal
    frame, quaternions (4, N) of ``R P``)."""
    return blocks_of(np.concatenate([pi, np.asarray(q).T, gamma], axis=1), N, ROWS)


def blocks_to_user(Y, N: int, P, identity: bool, orientation: bool):
    """``(A, Γ, R)`` of rows of blocks (m, nblocks, d) as ``(m, N, 3, 3)``, ``(m, N, 3)`` and
    ``(m, N, 3, 3)`` arrays (R None without orientation)."""
    L = Y.shape[-1] // ROWS - 8
    rows = np.ascontiguousarray(Y).reshape(-1, *Y.shape[-2:])
    out_A = np.empty((rows.shape[0], N, 3, 3))
    out_G = np.empty((rows.shape[0], N, 3))
    out_R = np.empty((rows.shape[0], N if orientation else 0, 3, 3))
    P = np.ascontiguousarray(P, dtype=float)
    _from_blocks(rows, L, N, P, bool(identity), bool(orientation), out_A, out_G, out_R)
    return out_A, out_G, (out_R if orientation else None)


def increments_to_user(U, N: int, P, identity: bool):
    """The increments of rows of blocks (m, nblocks, 6 row) as the user's ``(u_w, u_v)``, two
    ``(m, N, 3)`` arrays."""
    u = increment_rows(U, N, INCREMENT_ROWS)
    w, v = u[..., :3], u[..., 3:]
    if identity:
        return w, v
    P = np.asarray(P)
    return w @ P.T, v @ P.T
