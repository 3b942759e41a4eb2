"""Ensemble kernel for the 3D top: bodies in SIMD lanes.

The per-body kernel (:mod:`lieint.fast.top3`) runs one body's steps in scalar code. For
ensembles this kernel stores the bodies structure-of-arrays (``Π`` as ``(3, N)``, the
orientation as a unit quaternion ``q`` as ``(4, N)``, turned into R only at the saved steps)
and runs each operation of an RKMK step as a loop over a block of bodies, which the compiler
vectorises. ``R ← R exp(Û)`` is ``q ← q ⊗ (cos(θ/2), sin(θ/2) U/θ)`` and ``Π ← exp(−Û)Π``
the vector form of Rodrigues' formula, so no 3 × 3 matrix is formed in the loop. The
coefficients ``sin θ/θ``, ``(1 − cos θ)/θ²``, ``cos(θ/2)``, ``sin(θ/2)/θ`` are Taylor polynomials
without divisions (exact to round-off below θ = 0.1, where every stage of a resolved step lies)
with a scalar fix-up for the rare lanes beyond, so the hot loops have no sqrt, sin, cos or
division.

The arithmetic is strict IEEE (no ``fastmath``): with reassociation and contraction allowed,
the compiled code of the parallel and the serial driver could round differently depending on
where and in which process each was compiled, and an ensemble cut into chunks (a dask sweep)
stopped matching one call on all its members bit for bit (1.6e-15 in R, seen with a numba
cache filled by the test suite's order of compilation). Multiply-adds are written as explicit
fused multiply-adds (:func:`lieint.fast.fused.fma`: rounded once by definition, alike in a
SIMD lane and in scalar code), so the strictness costs no throughput.

Why the passes look as they do (each measured, RKMK4, 4,096 bodies; see
``benchmarks/flop_ceiling.py``): one pass per operation, writing one or two arrays of locals, is
what the compiler vectorises (a fused pass writing five arrays stayed scalar: 5 → 20 GFLOP per
CPU-second); the Horner chains of the coefficients get their own pass, so that their latency
does not sit inside the chain of the increment (+15 %); the multiply-adds are fused (+20 %);
the block's arrays are private, padded rows of 128 + 8 doubles, and the shared parameters are
copied per block (a view of an array shared between threads counts references on one cache
line that then bounced between the cores: two threads were 20–30 % slower per thread).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from . import LANES_BLOCK
from .fused import fma
from .quaternions import rotation_into

__all__ = [
    "NAMESPACES", "block_lanes", "blocks_from_state", "blocks_of", "blocks_to_rows", "blocks_to_user", "increment_rows",
    "increments_to_user", "rows_of", "rows_to_blocks",
]  # fmt: skip

_BLOCK = LANES_BLOCK
#: the row length of the block's arrays: the block and 8 doubles (64 bytes) of padding
_ROW = _BLOCK + 8
# (2π)²: the dexp⁻¹ series of so(3) converges for |u| < 2π
_RADIUS2 = (2.0 * np.pi) ** 2


@njit(cache=True, inline="always")
def _cross(a0, a1, a2, b0, b1, b2):
    """``a × b``, each component one product and one fused multiply-subtract."""
    return fma(a1, b2, -(a2 * b1)), fma(a2, b0, -(a0 * b2)), fma(a0, b1, -(a1 * b0))


@njit(cache=True, inline="always")
def _norm2(u, l):
    """``θ² = |u|²`` of lane l."""
    return fma(u[2, l], u[2, l], fma(u[1, l], u[1, l], u[0, l] * u[0, l]))


@njit(cache=True, inline="always")
def _rodrigues(t2):
    """``sin θ/θ`` and ``(1 − cos θ)/θ²`` as even polynomials of degree 10 in θ (Horner's scheme
    in fused multiply-adds), exact to round-off for θ < 0.1 (the first omitted terms, θ¹²/13!
    and θ¹²/14!, are below 2e-22 there)."""
    a = fma(t2, -1.0 / 39916800, 1.0 / 362880)
    a = fma(t2, a, -1.0 / 5040)
    a = fma(t2, a, 1.0 / 120)
    a = fma(t2, a, -1.0 / 6)
    a = fma(t2, a, 1.0)
    b = fma(t2, -1.0 / 479001600, 1.0 / 3628800)
    b = fma(t2, b, -1.0 / 40320)
    b = fma(t2, b, 1.0 / 720)
    b = fma(t2, b, -1.0 / 24)
    b = fma(t2, b, 0.5)
    return a, b


@njit(cache=True, inline="always")
def _half_angle(t2):
    """``cos(θ/2)`` and ``sin(θ/2)/θ`` as polynomials in ``s = θ²/4`` (exact to round-off below θ = 0.1)."""
    s = 0.25 * t2
    ch = fma(s, -1.0 / 3628800, 1.0 / 40320)
    ch = fma(s, ch, -1.0 / 720)
    ch = fma(s, ch, 1.0 / 24)
    ch = fma(s, ch, -1.0 / 2)
    ch = fma(s, ch, 1.0)
    sh = fma(s, -1.0 / 79833600, 1.0 / 725760)
    sh = fma(s, sh, -1.0 / 10080)
    sh = fma(s, sh, 1.0 / 240)
    sh = fma(s, sh, -1.0 / 12)
    sh = fma(s, sh, 0.5)
    return ch, sh


@njit(cache=True, inline="always")
def _rotate_back(u, P, a, b, l):
    """``exp(−û)Π = Π − a u×Π + b u×(u×Π)`` of lane l (a, b: Rodrigues' coefficients)."""
    u0, u1, u2 = u[0, l], u[1, l], u[2, l]
    p0, p1, p2 = P[0, l], P[1, l], P[2, l]
    c0, c1, c2 = _cross(u0, u1, u2, p0, p1, p2)
    e0, e1, e2 = _cross(u0, u1, u2, c0, c1, c2)
    return fma(b, e0, fma(-a, c0, p0)), fma(b, e1, fma(-a, c1, p1)), fma(b, e2, fma(-a, c2, p2))


@njit(cache=True, inline="always")
def _stage_lane(u, P, Iinv, a, b, K, st, l):
    """``ξ = I⁻¹ exp(−û)Π`` of lane l into K[st] (the dexp⁻¹ terms follow in their own pass)."""
    p0, p1, p2 = _rotate_back(u, P, a, b, l)
    K[st, 0, l] = Iinv[0] * p0
    K[st, 1, l] = Iinv[1] * p1
    K[st, 2, l] = Iinv[2] * p2


@njit(cache=True, inline="always")
def _dexpinv2_lane(u, c1, c2, K, st, l):
    """``k ← ξ + c₁(−u)×ξ + c₂(−u)×((−u)×ξ)`` of lane l, ξ = K[st] (dexp⁻¹ of degree 2, RKMK4);
    ``(−u)×ξ`` is written ``ξ×u``."""
    u0, u1, u2 = u[0, l], u[1, l], u[2, l]
    x0, x1, x2 = K[st, 0, l], K[st, 1, l], K[st, 2, l]
    n0, n1, n2 = _cross(x0, x1, x2, u0, u1, u2)
    m0, m1, m2 = _cross(n0, n1, n2, u0, u1, u2)
    K[st, 0, l] = fma(c2, m0, fma(c1, n0, x0))
    K[st, 1, l] = fma(c2, m1, fma(c1, n1, x1))
    K[st, 2, l] = fma(c2, m2, fma(c1, n2, x2))


@njit(cache=True, inline="always")
def _combine(u, K, weights, row, hk, m, L):
    """``u = Σ_{j<m} (hk w_j) K_j`` (every row of u) over the non-zero weights
    ``w_j = weights[row, j]``, accumulated in the order of j; returns whether any weight was
    non-zero (u is left unset otherwise). Every lanes kernel's stage and step combinations."""
    first = True
    for j in range(m):
        w = hk * weights[row, j]
        if w == 0.0:
            continue
        if first:
            for d in range(u.shape[0]):
                for l in range(L):
                    u[d, l] = w * K[j, d, l]
            first = False
        else:
            for d in range(u.shape[0]):
                for l in range(L):
                    u[d, l] = fma(w, K[j, d, l], u[d, l])
    return not first


@njit(cache=True, inline="always")
def _stage_pass(u, P, Iinv, c1, c2, degree, K, st, ca, cb, L):
    """Stage increments of every lane with the polynomial coefficients; returns how many lanes
    need trigonometric ones (``θ ≥ 0.1``), which the caller recomputes.

    Three loops the compiler vectorises (locals only, one or two arrays written): the
    coefficients, ``ξ = I⁻¹ exp(−û)Π``, and for degree 2 the dexp⁻¹ terms. Kept apart, the
    long dependency chains of Horner's scheme and of the two cross products do not sit in one
    chain, and the processor overlaps the lanes."""
    nlarge = 0
    for l in range(L):
        t2 = _norm2(u, l)
        if t2 >= 1e-2:
            nlarge += 1
        ca[l], cb[l] = _rodrigues(t2)
    for l in range(L):
        _stage_lane(u, P, Iinv, ca[l], cb[l], K, st, l)
    if degree == 2:
        for l in range(L):
            _dexpinv2_lane(u, c1, c2, K, st, l)
    return nlarge


@njit(cache=True, inline="always")
def _finish_coefficients(u, ca, cb, ch, sh, trig, l):
    """Rodrigues' coefficients and ``cos(θ/2)``, ``sin(θ/2)/θ`` of the step's increment in lane l;
    trigonometric beyond θ = 0.1 only when ``trig`` (the scalar pass). Returns 1 for a lane
    beyond θ = 0.1, else 0."""
    t2 = _norm2(u, l)
    ca[l], cb[l] = _rodrigues(t2)
    ch[l], sh[l] = _half_angle(t2)
    if t2 < 1e-2:
        return 0
    if trig:
        th = np.sqrt(t2)
        ca[l] = np.sin(th) / th
        cb[l] = (1.0 - np.cos(th)) / t2
        ch[l] = np.cos(0.5 * th)
        sh[l] = np.sin(0.5 * th) / th
    return 1


@njit(cache=True, inline="always")
def _finish_lane(u, P, qb, ca, cb, ch, sh, project, l):
    """``Π ← exp(−Û)Π``, ``q ← q ⊗ (cos(θ/2), sin(θ/2) U/θ)`` (normalised when ``project``) of lane l."""
    P[0, l], P[1, l], P[2, l] = _rotate_back(u, P, ca[l], cb[l], l)
    c, t = ch[l], sh[l]
    w0, w1, w2 = t * u[0, l], t * u[1, l], t * u[2, l]
    q0, q1, q2, q3 = qb[0, l], qb[1, l], qb[2, l], qb[3, l]
    r0 = fma(-q3, w2, fma(-q2, w1, fma(-q1, w0, q0 * c)))
    r1 = fma(-q3, w1, fma(q2, w2, fma(q1, c, q0 * w0)))
    r2 = fma(q3, w0, fma(q2, c, fma(-q1, w2, q0 * w1)))
    r3 = fma(q3, c, fma(-q2, w0, fma(q1, w1, q0 * w2)))
    if project:  # the unit sphere of quaternions is the exact projection for rotations
        n = 1.0 / np.sqrt(fma(r3, r3, fma(r2, r2, fma(r1, r1, r0 * r0))))
        r0, r1, r2, r3 = r0 * n, r1 * n, r2 * n, r3 * n
    qb[0, l], qb[1, l], qb[2, l], qb[3, l] = r0, r1, r2, r3


# -- the lanes as a block form of the one compiled loop (lieint.fast.loop) ---------------------------
# A unit of the loop is a block of L lanes (L = d/7 − 8, chosen per run: 128, or fewer for a small
# ensemble, a multiple of 8): y = (Π (3 rows), q (4 rows)), each row of L + 8 doubles (8 of padding).
# Lanes beyond the ensemble hold Π = 0, q = 1 (harmless: nothing moves them); the rows the loop
# saves are the blocks as they are, turned into the user's A and R by :func:`blocks_to_user`.
# par = (I⁻¹ (3), P (9), orientation, identity frame), as the per-body form's.


@njit(cache=True, inline="always")
def _block_views(y, row):
    return y[: 3 * row].reshape((3, row)), y[3 * row : 7 * row].reshape((4, row))


@njit(cache=True)
def block_prepare(ctx):
    return ctx


@njit(cache=True)
def block_scratch(fx, meth, par, d):
    """The stage slopes K (s, 3, row), u, t, the coefficients' rows and private copies of the
    shared parameters: a view of an array shared between threads counts references on one cache
    line that then bounces between the cores at every stage (measured: 20–30 % of a two-thread
    run)."""
    row = d // 7
    s = meth.b.shape[0]
    return (
        np.zeros((s, 3, row)), np.zeros((3, row)), np.zeros((3, row)), np.zeros(row), np.zeros(row), np.zeros(row),
        np.zeros(row), par[0:3].copy(), meth.A.copy(), meth.b.reshape((1, s)).copy(), meth.coeffs.copy(),
    )  # fmt: skip


@njit(cache=True, error_model="numpy")  # no Python division checks: they would stop the SIMD passes
def block_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One RKMK step (exponential coordinates) of every lane of a block.

    Each pass over the lanes is a loop of local arithmetic writing one or two arrays, so that
    it compiles to SIMD instructions; lanes beyond θ = 0.1 (rare: coarse steps) are redone in
    scalar passes with trigonometric coefficients. Every lane's arithmetic is the same in both
    (strict IEEE, same expressions), so a body's result does not depend on its neighbours.
    ``inc`` receives the increments U (3 rows), ``aux[0]`` the largest ``|w|²`` of the block."""
    K, u, tt, ca, cb, ch, sh = scr[0], scr[1], scr[2], scr[3], scr[4], scr[5], scr[6]
    Iinv, A, b, coeffs = scr[7], scr[8], scr[9], scr[10]
    d = y.shape[0]
    row = d // 7
    L = row - 8
    for i in range(d):
        y1[i] = y[i]
    P, qb = _block_views(y1, row)
    s = b.shape[1]
    degree = coeffs.shape[0] - 1
    bad = False
    for st in range(s):
        nonzero = _combine(u, K, A, st, h, st, L)
        if not nonzero:
            for dd in range(3):
                for l in range(L):
                    K[st, dd, l] = Iinv[dd] * P[dd, l]
            continue
        # one fused pass: Rodrigues' coefficients, Π_i = exp(−û)Π = Π − a u×Π + b u×(u×Π),
        # ξ = I⁻¹Π_i and, for degree 2 (RKMK4), k = ξ + c₁(−u)×ξ + c₂(−u)×((−u)×ξ)
        if degree == 2:
            nlarge = _stage_pass(u, P, Iinv, coeffs[1], coeffs[2], 2, K, st, ca, cb, L)
        else:
            nlarge = _stage_pass(u, P, Iinv, 0.0, 0.0, 0, K, st, ca, cb, L)
        if nlarge:  # rare: lanes beyond θ = 0.1 get trigonometric coefficients
            c1, c2 = (coeffs[1], coeffs[2]) if degree == 2 else (0.0, 0.0)
            for l in range(L):
                bad |= _norm2(u, l) >= _RADIUS2
            if bad:  # a stage left the dexp⁻¹ radius: the block stops here (as the generic path)
                return -1
            for l in range(L):
                t2 = _norm2(u, l)
                if t2 >= 1e-2:
                    th = np.sqrt(t2)
                    _stage_lane(u, P, Iinv, np.sin(th) / th, (1.0 - np.cos(th)) / t2, K, st, l)
                    if degree == 2:
                        _dexpinv2_lane(u, c1, c2, K, st, l)
        if degree != 2:
            for dd in range(3):
                for l in range(L):
                    tt[dd, l] = K[st, dd, l]
            for deg in range(1, degree + 1):
                cf = coeffs[deg]
                for l in range(L):
                    # ad_{−u} t = (−u) × t = t × u
                    n0, n1, n2 = _cross(tt[0, l], tt[1, l], tt[2, l], u[0, l], u[1, l], u[2, l])
                    tt[0, l], tt[1, l], tt[2, l] = n0, n1, n2
                    K[st, 0, l] = fma(cf, n0, K[st, 0, l])
                    K[st, 1, l] = fma(cf, n1, K[st, 1, l])
                    K[st, 2, l] = fma(cf, n2, K[st, 2, l])
    largest = 0.0
    for l in range(L):
        w2 = K[0, 0, l] * K[0, 0, l] + K[0, 1, l] * K[0, 1, l] + K[0, 2, l] * K[0, 2, l]
        largest = max(largest, w2)
    aux[0] = largest
    # U = h Σ b_j K_j; Π ← exp(−Û)Π; q ← q ⊗ exp(Û) (R ← R exp(Û))
    _combine(u, K, b, 0, h, s, L)
    nlarge = 0
    for l in range(L):
        nlarge += _finish_coefficients(u, ca, cb, ch, sh, False, l)
    if nlarge:  # rare: a step beyond θ = 0.1
        for l in range(L):
            _finish_coefficients(u, ca, cb, ch, sh, True, l)
    for l in range(L):
        _finish_lane(u, P, qb, ca, cb, ch, sh, False, l)
    if inc.shape[0] >= 3 * row:
        for dd in range(3):
            for l in range(row):
                inc[dd * row + l] = u[dd, l] if l < L else 0.0
    return s


@njit(cache=True)
def block_project(fx, y, par, out, scr):
    """Every lane's quaternion onto the unit sphere: the exact projection of its rotation."""
    d = y.shape[0]
    row = d // 7
    for i in range(d):
        out[i] = y[i]
    qb = _block_views(out, row)[1]
    for l in range(row - 8):
        r0, r1, r2, r3 = qb[0, l], qb[1, l], qb[2, l], qb[3, l]
        n = 1.0 / np.sqrt(fma(r3, r3, fma(r2, r2, fma(r1, r1, r0 * r0))))
        qb[0, l], qb[1, l], qb[2, l], qb[3, l] = r0 * n, r1 * n, r2 * n, r3 * n


@njit(cache=True)
def block_radius2(fx, y, par, scr):
    """The largest ``|w|²`` of the block's lanes."""
    row = y.shape[0] // 7
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


def block_lanes(N: int) -> int:
    """Lanes per block for an ensemble of N bodies: :data:`LANES_BLOCK`, or N rounded up to a
    multiple of 8 when that is fewer."""
    return min(_BLOCK, -(-N // 8) * 8)


@njit(cache=True)
def _to_blocks(pi, q, L, Y):
    """Blocks of L lanes ``Y`` (nblocks, 7 (L + 8)) from ``Π`` (N, 3) and quaternions (4, N)."""
    row = L + 8
    N = pi.shape[0]
    for blk in range(Y.shape[0]):
        for l in range(row):
            m = blk * L + l
            real = l < L and m < N
            for i in range(3):
                Y[blk, i * row + l] = pi[m, i] if real else 0.0
            for i in range(4):
                Y[blk, (3 + i) * row + l] = q[i, m] if real else (1.0 if i == 0 else 0.0)


@njit(cache=True)
def _from_blocks(Y, L, N, P, identity, orient, out_A, out_R):
    """The user's A (and R) of rows of blocks ``Y`` (m, nblocks, d) into ``out_A``, ``out_R``
    (m, N, 3, 3): ``A = −(P Π)^``, ``R = R(q) Pᵀ``."""
    row = L + 8
    for r in range(Y.shape[0]):
        for m in range(N):
            blk, l = m // L, m % L
            y = Y[r, blk]
            p0, p1, p2 = y[l], y[row + l], y[2 * row + l]
            x, yy, z = p0, p1, p2
            if not identity:
                x = P[0, 0] * p0 + P[0, 1] * p1 + P[0, 2] * p2
                yy = P[1, 0] * p0 + P[1, 1] * p1 + P[1, 2] * p2
                z = P[2, 0] * p0 + P[2, 1] * p1 + P[2, 2] * p2
            A = out_A[r, m]
            A[0, 0], A[0, 1], A[0, 2] = 0.0, z, -yy
            A[1, 0], A[1, 1], A[1, 2] = -z, 0.0, x
            A[2, 0], A[2, 1], A[2, 2] = yy, -x, 0.0
            if not orient:
                continue
            R = out_R[r, m]
            rotation_into(y[3 * row + l], y[4 * row + l], y[5 * row + l], y[6 * row + l], R)
            if not identity:
                for i in range(3):
                    r0, r1, r2 = R[i, 0], R[i, 1], R[i, 2]
                    for j in range(3):
                        R[i, j] = r0 * P[j, 0] + r1 * P[j, 1] + r2 * P[j, 2]


@njit(cache=True)
def rows_to_blocks(X, L, Y):
    """Blocks of L lanes ``Y`` (nblocks, rows (L + 8)) from the bodies' rows ``X`` (N, rows): row
    k of a block holds entry k of its bodies; a spare lane copies the block's first body."""
    row = L + 8
    N, rows = X.shape
    for blk in range(Y.shape[0]):
        for l in range(row):
            m = blk * L + l
            if not (l < L and m < N):
                m = blk * L
            for k in range(rows):
                Y[blk, k * row + l] = X[m, k]


@njit(cache=True)
def blocks_to_rows(Y, L, N, X):
    """The bodies' rows ``X`` (m, N, rows) of rows of blocks ``Y`` (m, nblocks, rows (L + 8))."""
    row = L + 8
    for r in range(Y.shape[0]):
        for m in range(N):
            blk, l = m // L, m % L
            for k in range(X.shape[2]):
                X[r, m, k] = Y[r, blk, k * row + l]


def blocks_of(X, N: int, rows: int) -> np.ndarray:
    """The blocks of an ensemble of N bodies from their rows ``X`` (N, rows)."""
    L = block_lanes(N)
    Y = np.empty((-(-N // L), rows * (L + 8)))
    rows_to_blocks(np.ascontiguousarray(X, dtype=float), L, Y)
    return Y


def rows_of(Y, N: int, rows: int) -> np.ndarray:
    """The bodies' rows (m, N, rows) of rows of blocks (m, nblocks, rows (L + 8))."""
    L = Y.shape[-1] // rows - 8
    blocks = np.ascontiguousarray(Y).reshape(-1, *Y.shape[-2:])
    X = np.empty((blocks.shape[0], N, rows))
    blocks_to_rows(blocks, L, N, X)
    return X


def increment_rows(U, N: int, rows: int) -> np.ndarray:
    """The bodies' increments (m, N, rows) of rows of blocks' increments (m, nblocks, rows (L + 8))."""
    m, blocks, row = U.shape[0], U.shape[-2], U.shape[-1] // rows
    u = U.reshape(m, blocks, rows, row)[..., : row - 8]  # (m, blocks, rows, L)
    return np.moveaxis(u, 2, -1).reshape(m, blocks * (row - 8), rows)[:, :N]


def blocks_from_state(pi, q, N: int) -> np.ndarray:
    """The blocks of an ensemble of N bodies (``Π`` (N, 3) in the principal frame, quaternions
    (4, N) of ``R P``)."""
    L = block_lanes(N)
    Y = np.empty((-(-N // L), 7 * (L + 8)))
    _to_blocks(np.ascontiguousarray(pi), np.ascontiguousarray(q), L, Y)
    return Y


def blocks_to_user(Y, N: int, P, identity: bool, orientation: bool):
    """``(A, R)`` of rows of blocks (m, nblocks, d) as ``(m, N, 3, 3)`` arrays (R None without
    orientation)."""
    L = Y.shape[-1] // 7 - 8
    rows = np.ascontiguousarray(Y).reshape(-1, *Y.shape[-2:])
    out_A = np.empty((rows.shape[0], N, 3, 3))
    out_R = np.empty((rows.shape[0], N if orientation else 0, 3, 3))
    _from_blocks(rows, L, N, np.ascontiguousarray(P, dtype=float), bool(identity), bool(orientation), out_A, out_R)
    return out_A, (out_R if orientation else None)


def increments_to_user(U, N: int, P, identity: bool):
    """The increments of rows of blocks (m, nblocks, 3 row) as the user's vectors (m, N, 3)."""
    u = increment_rows(U, N, 3)
    return u if identity else u @ np.asarray(P).T
