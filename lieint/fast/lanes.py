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
cache filled by the test suite's order of compilation). Strict arithmetic costs about 20% of
the throughput (15.2 → 12.2 million body-steps per CPU-second, 4096 bodies, RKMK4).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .top3 import rodrigues_coefficients as _coefficients

__all__ = ["matrix_to_quaternion", "quaternion_to_matrix", "run_lanes"]

_BLOCK = 64
# (2π)²: the dexp⁻¹ series of so(3) converges for |u| < 2π
_RADIUS2 = (2.0 * np.pi) ** 2


@njit(cache=True, inline="always")
def _rotate_back(u, P, a, b, l):
    """``exp(−û)Π = Π − a u×Π + b u×(u×Π)`` of lane l (a, b: Rodrigues' coefficients)."""
    c0_ = u[1, l] * P[2, l] - u[2, l] * P[1, l]
    c1_ = u[2, l] * P[0, l] - u[0, l] * P[2, l]
    c2_ = u[0, l] * P[1, l] - u[1, l] * P[0, l]
    e0 = u[1, l] * c2_ - u[2, l] * c1_
    e1 = u[2, l] * c0_ - u[0, l] * c2_
    e2 = u[0, l] * c1_ - u[1, l] * c0_
    return P[0, l] - a * c0_ + b * e0, P[1, l] - a * c1_ + b * e1, P[2, l] - a * c2_ + b * e2


@njit(cache=True, inline="always")
def _stage_lane(u, P, Iinv, a, b, c1, c2, degree, K, st, l):
    """Stage increment of lane l: ξ = I⁻¹ exp(−û)Π, then the degree-2 dexp⁻¹ terms when
    degree == 2 (other degrees add theirs in separate passes)."""
    p0, p1, p2 = _rotate_back(u, P, a, b, l)
    x0, x1, x2 = Iinv[0] * p0, Iinv[1] * p1, Iinv[2] * p2
    if degree == 2:
        n0 = -(u[1, l] * x2 - u[2, l] * x1)
        n1 = -(u[2, l] * x0 - u[0, l] * x2)
        n2 = -(u[0, l] * x1 - u[1, l] * x0)
        m0 = -(u[1, l] * n2 - u[2, l] * n1)
        m1 = -(u[2, l] * n0 - u[0, l] * n2)
        m2 = -(u[0, l] * n1 - u[1, l] * n0)
        x0 += c1 * n0 + c2 * m0
        x1 += c1 * n1 + c2 * m1
        x2 += c1 * n2 + c2 * m2
    K[st, 0, l] = x0
    K[st, 1, l] = x1
    K[st, 2, l] = x2


@njit(cache=True, inline="always")
def _half_angle(t2):
    """``cos(θ/2)`` and ``sin(θ/2)/θ`` as polynomials in ``s = θ²/4`` (exact to round-off below θ = 0.1)."""
    s = 0.25 * t2
    ch = 1.0 + s * (-1.0 / 2 + s * (1.0 / 24 + s * (-1.0 / 720 + s * (1.0 / 40320 + s * (-1.0 / 3628800)))))
    sh = 0.5 + s * (-1.0 / 12 + s * (1.0 / 240 + s * (-1.0 / 10080 + s * (1.0 / 725760 + s * (-1.0 / 79833600)))))
    return ch, sh


@njit(cache=True, inline="always")
def _fix_large(t2, a, b, lanes):
    for l in range(lanes):
        if t2[l] >= 1e-2:
            th = np.sqrt(t2[l])
            a[l] = np.sin(th) / th
            b[l] = (1.0 - np.cos(th)) / t2[l]


@njit(cache=True)
def _lanes_block(
    blk, pi, q, Iinv, A, b, c, coeffs, h, h_last, k_from, k_to, nsteps, save_steps, project, out_pi, out_q
):
    """Block ``blk`` of lanes over steps k_from < k ≤ k_to; returns -1 or the step at which a
    stage increment reached the dexp⁻¹ radius ``|u| = 2π`` (the block stops there)."""
    N = pi.shape[1]
    s = b.shape[0]
    degree = coeffs.shape[0] - 1
    status = -1
    l0 = blk * _BLOCK
    L = min(_BLOCK, N - l0)
    K = np.zeros((s, 3, _BLOCK))
    u = np.zeros((3, _BLOCK))
    t2 = np.zeros(_BLOCK)
    ca = np.zeros(_BLOCK)
    cb = np.zeros(_BLOCK)
    tt = np.zeros((3, _BLOCK))
    P = np.zeros((3, _BLOCK))
    qb = np.zeros((4, _BLOCK))
    for i in range(3):
        for l in range(L):
            P[i, l] = pi[i, l0 + l]
    for i in range(4):
        for l in range(L):
            qb[i, l] = q[i, l0 + l]
    slot = 0
    bad = False
    for k in range(k_from, k_to):
        hk = h if k < nsteps - 1 else h_last
        for st in range(s):
            for d in range(3):
                for l in range(L):
                    u[d, l] = 0.0
            nonzero = False
            for j in range(st):
                w = hk * A[st, j]
                if w != 0.0:
                    nonzero = True
                    for d in range(3):
                        for l in range(L):
                            u[d, l] += w * K[j, d, l]
            if not nonzero:
                for d in range(3):
                    for l in range(L):
                        K[st, d, l] = Iinv[d] * P[d, l]
                continue
            # one fused pass: Rodrigues' coefficients, Π_i = exp(−û)Π = Π − a u×Π + b u×(u×Π),
            # ξ = I⁻¹Π_i and, for degree 2 (RKMK4), k = ξ + c₁(−u)×ξ + c₂(−u)×((−u)×ξ)
            c1, c2 = (coeffs[1], coeffs[2]) if degree == 2 else (0.0, 0.0)
            large = False
            for l in range(L):
                t2[l] = u[0, l] * u[0, l] + u[1, l] * u[1, l] + u[2, l] * u[2, l]
                large |= t2[l] >= 1e-2
                a_, b_ = _coefficients(t2[l])
                ca[l], cb[l] = a_, b_
                _stage_lane(u, P, Iinv, a_, b_, c1, c2, degree, K, st, l)
            if large:  # rare: lanes beyond θ = 0.1 get trigonometric coefficients
                for l in range(L):
                    bad |= t2[l] >= _RADIUS2
                if bad:  # a stage left the dexp⁻¹ radius: the run stops here (as the generic path)
                    break
                for l in range(L):
                    if t2[l] >= 1e-2:
                        th = np.sqrt(t2[l])
                        ca[l] = np.sin(th) / th
                        cb[l] = (1.0 - np.cos(th)) / t2[l]
                        _stage_lane(u, P, Iinv, ca[l], cb[l], c1, c2, degree, K, st, l)
            if degree != 2:
                for d in range(3):
                    for l in range(L):
                        tt[d, l] = K[st, d, l]
                for dd in range(1, degree + 1):
                    cf = coeffs[dd]
                    for l in range(L):
                        # ad_{−u} t = (−u) × t
                        n0 = -(u[1, l] * tt[2, l] - u[2, l] * tt[1, l])
                        n1 = -(u[2, l] * tt[0, l] - u[0, l] * tt[2, l])
                        n2 = -(u[0, l] * tt[1, l] - u[1, l] * tt[0, l])
                        tt[0, l], tt[1, l], tt[2, l] = n0, n1, n2
                        K[st, 0, l] += cf * n0
                        K[st, 1, l] += cf * n1
                        K[st, 2, l] += cf * n2
        if bad:
            status = k
            break
        # U = h Σ b_j K_j; Q = exp(Û); Π ← QᵀΠ; R ← R Q
        for d in range(3):
            for l in range(L):
                u[d, l] = 0.0
        for j in range(s):
            w = hk * b[j]
            for d in range(3):
                for l in range(L):
                    u[d, l] += w * K[j, d, l]
        for l in range(L):
            t2[l] = u[0, l] * u[0, l] + u[1, l] * u[1, l] + u[2, l] * u[2, l]
            ca[l], cb[l] = _coefficients(t2[l])
        _fix_large(t2, ca, cb, L)
        for l in range(L):
            P[0, l], P[1, l], P[2, l] = _rotate_back(u, P, ca[l], cb[l], l)  # Π ← exp(−Û)Π
        for l in range(L):
            ca[l], cb[l] = _half_angle(t2[l])  # reused: cos(θ/2), sin(θ/2)/θ
        for l in range(L):
            if t2[l] >= 1e-2:  # rare: a stage beyond θ = 0.1
                th = np.sqrt(t2[l])
                ca[l] = np.cos(0.5 * th)
                cb[l] = np.sin(0.5 * th) / th
        for l in range(L):
            # q ← q ⊗ (cos(θ/2), sin(θ/2) U/θ)
            ch, sh = ca[l], cb[l]
            w0, w1, w2 = sh * u[0, l], sh * u[1, l], sh * u[2, l]
            q0, q1, q2, q3 = qb[0, l], qb[1, l], qb[2, l], qb[3, l]
            qb[0, l] = q0 * ch - q1 * w0 - q2 * w1 - q3 * w2
            qb[1, l] = q0 * w0 + q1 * ch + q2 * w2 - q3 * w1
            qb[2, l] = q0 * w1 - q1 * w2 + q2 * ch + q3 * w0
            qb[3, l] = q0 * w2 + q1 * w1 - q2 * w0 + q3 * ch
        if project:
            for l in range(L):
                # the unit sphere of quaternions is the exact projection for rotations
                n = 1.0 / np.sqrt(qb[0, l] ** 2 + qb[1, l] ** 2 + qb[2, l] ** 2 + qb[3, l] ** 2)
                qb[0, l] *= n
                qb[1, l] *= n
                qb[2, l] *= n
                qb[3, l] *= n
        if slot < save_steps.shape[0] and save_steps[slot] == k + 1:
            for i in range(3):
                for l in range(L):
                    out_pi[slot, i, l0 + l] = P[i, l]
            for i in range(4):
                for l in range(L):
                    out_q[slot, i, l0 + l] = qb[i, l]
            slot += 1
    for i in range(3):
        for l in range(L):
            pi[i, l0 + l] = P[i, l]
    for i in range(4):
        for l in range(L):
            q[i, l0 + l] = qb[i, l]
    return status


@njit(cache=True, parallel=True)
def _lanes_parallel(pi, q, Iinv, A, b, c, coeffs, h, h_last, k_from, k_to, nsteps, save_steps, project, out_pi, out_q):
    nblocks = (pi.shape[1] + _BLOCK - 1) // _BLOCK
    status = np.empty(nblocks, dtype=np.int64)
    for blk in prange(nblocks):
        status[blk] = _lanes_block(
            blk, pi, q, Iinv, A, b, c, coeffs, h, h_last, k_from, k_to, nsteps, save_steps, project, out_pi, out_q
        )
    return status


@njit(cache=True)
def _lanes_serial(pi, q, Iinv, A, b, c, coeffs, h, h_last, k_from, k_to, nsteps, save_steps, project, out_pi, out_q):
    nblocks = (pi.shape[1] + _BLOCK - 1) // _BLOCK
    status = np.empty(nblocks, dtype=np.int64)
    for blk in range(nblocks):
        status[blk] = _lanes_block(
            blk, pi, q, Iinv, A, b, c, coeffs, h, h_last, k_from, k_to, nsteps, save_steps, project, out_pi, out_q
        )
    return status


def run_lanes(
    pi, q, Iinv, A, b, c, coeffs, h, h_last, k_from, k_to, nsteps, save_steps, project, out_pi, out_q, parallel
):
    """RKMK (exp coordinates) on bodies in lanes. ``pi`` (3, N) and the quaternions ``q`` (4, N)
    are updated in place; states after the listed global save steps go to ``out_pi`` (m, 3, N)
    and ``out_q`` (m, 4, N). Blocks of lanes run in threads when ``parallel``. Returns -1, or
    the first step at which a stage left the dexp⁻¹ radius."""
    run = _lanes_parallel if parallel else _lanes_serial
    status = run(pi, q, Iinv, A, b, c, coeffs, h, h_last, k_from, k_to, nsteps, save_steps, project, out_pi, out_q)
    bad = status[status >= 0]
    return int(bad.min()) if bad.size else -1


def quaternion_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of unit quaternions ``(..., 4)`` = (w, x, y, z)."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def matrix_to_quaternion(R: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(..., 4)`` of rotation matrices, by the largest of the four pivots
    (Shepperd's method), so the result is accurate for every rotation."""
    R = np.asarray(R, dtype=float)
    tr = np.trace(R, axis1=-2, axis2=-1)
    diag = np.diagonal(R, axis1=-2, axis2=-1)
    pivots = np.concatenate([tr[..., None], diag], axis=-1)
    k = np.argmax(pivots, axis=-1)
    q = np.empty(R.shape[:-2] + (4,))
    r = lambda i, j: R[..., i, j]  # noqa: E731
    cases = [
        (1 + tr, r(2, 1) - r(1, 2), r(0, 2) - r(2, 0), r(1, 0) - r(0, 1)),
        (r(2, 1) - r(1, 2), 1 + 2 * r(0, 0) - tr, r(0, 1) + r(1, 0), r(0, 2) + r(2, 0)),
        (r(0, 2) - r(2, 0), r(0, 1) + r(1, 0), 1 + 2 * r(1, 1) - tr, r(1, 2) + r(2, 1)),
        (r(1, 0) - r(0, 1), r(0, 2) + r(2, 0), r(1, 2) + r(2, 1), 1 + 2 * r(2, 2) - tr),
    ]
    for case, comps in enumerate(cases):
        sel = k == case
        v = np.stack(comps, -1)
        q[sel] = v[sel] / (2 * np.sqrt(np.stack(comps, -1)[sel][..., case : case + 1]))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)
