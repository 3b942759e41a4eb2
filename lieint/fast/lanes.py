"""Ensemble kernel for the 3D top: bodies in SIMD lanes.

The per-body kernel (:mod:`lieint.fast.top3`) runs one body's steps in scalar code. For
ensembles this kernel stores the bodies structure-of-arrays (``Π`` as ``(3, N)``, ``R`` as
``(3, 3, N)``) and runs each operation of an RKMK step as a loop over a block of bodies, which
the compiler vectorises. Rodrigues' coefficients use their Taylor polynomials (exact to
round-off below θ = 0.1, where every stage of a resolved step lies) with a scalar fix-up for
the rare lanes beyond, so the hot loop has no sqrt, sin or cos.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["run_lanes"]

_BLOCK = 64


@njit(cache=True, inline="always")
def _coefficients(t2):
    # sin θ/θ and (1 − cos θ)/θ² as even polynomials (Horner, multiplications only: a vector
    # division costs several multiplications)
    a = 1.0 + t2 * (-1.0 / 6 + t2 * (1.0 / 120 + t2 * (-1.0 / 5040 + t2 * (1.0 / 362880 + t2 * (-1.0 / 39916800)))))
    b = 0.5 + t2 * (-1.0 / 24 + t2 * (1.0 / 720 + t2 * (-1.0 / 40320 + t2 * (1.0 / 3628800 + t2 * (-1.0 / 479001600)))))
    return a, b


@njit(cache=True, inline="always")
def _fix_large(t2, a, b, lanes):
    for l in range(lanes):
        if t2[l] >= 1e-2:
            th = np.sqrt(t2[l])
            a[l] = np.sin(th) / th
            b[l] = (1.0 - np.cos(th)) / t2[l]


@njit(cache=True, parallel=True, fastmath={"contract", "reassoc", "nsz", "arcp"})
def run_lanes(pi, R, Iinv, A, b, c, coeffs, h, h_last, k_from, k_to, nsteps, save_steps, project, out_pi, out_R):
    """RKMK (exp coordinates) on bodies in lanes. ``pi`` (3, N) and ``R`` (3, 3, N) are updated
    in place; states after the listed global save steps go to ``out_pi`` (m, 3, N), ``out_R``."""
    N = pi.shape[1]
    s = b.shape[0]
    degree = coeffs.shape[0] - 1
    nblocks = (N + _BLOCK - 1) // _BLOCK
    for blk in prange(nblocks):
        l0 = blk * _BLOCK
        L = min(_BLOCK, N - l0)
        K = np.zeros((s, 3, _BLOCK))
        u = np.zeros((3, _BLOCK))
        t2 = np.zeros(_BLOCK)
        ca = np.zeros(_BLOCK)
        cb = np.zeros(_BLOCK)
        x = np.zeros((3, _BLOCK))
        tt = np.zeros((3, _BLOCK))
        P = np.zeros((3, _BLOCK))
        Rb = np.zeros((3, 3, _BLOCK))
        Q = np.zeros((3, 3, _BLOCK))
        for i in range(3):
            for l in range(L):
                P[i, l] = pi[i, l0 + l]
            for j in range(3):
                for l in range(L):
                    Rb[i, j, l] = R[i, j, l0 + l]
        slot = 0
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
                for l in range(L):
                    t2[l] = u[0, l] * u[0, l] + u[1, l] * u[1, l] + u[2, l] * u[2, l]
                    ca[l], cb[l] = _coefficients(t2[l])
                _fix_large(t2, ca, cb, L)
                for l in range(L):
                    # Π_i = exp(−û)Π = Π − a u×Π + b u×(u×Π); ξ = I⁻¹ Π_i
                    c0_ = u[1, l] * P[2, l] - u[2, l] * P[1, l]
                    c1_ = u[2, l] * P[0, l] - u[0, l] * P[2, l]
                    c2_ = u[0, l] * P[1, l] - u[1, l] * P[0, l]
                    e0 = u[1, l] * c2_ - u[2, l] * c1_
                    e1 = u[2, l] * c0_ - u[0, l] * c2_
                    e2 = u[0, l] * c1_ - u[1, l] * c0_
                    x[0, l] = Iinv[0] * (P[0, l] - ca[l] * c0_ + cb[l] * e0)
                    x[1, l] = Iinv[1] * (P[1, l] - ca[l] * c1_ + cb[l] * e1)
                    x[2, l] = Iinv[2] * (P[2, l] - ca[l] * c2_ + cb[l] * e2)
                for d in range(3):
                    for l in range(L):
                        K[st, d, l] = x[d, l]
                        tt[d, l] = x[d, l]
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
                a_, b_ = ca[l], cb[l]
                x_, y_, z_ = u[0, l], u[1, l], u[2, l]
                Q[0, 0, l] = 1.0 - b_ * (y_ * y_ + z_ * z_)
                Q[1, 1, l] = 1.0 - b_ * (x_ * x_ + z_ * z_)
                Q[2, 2, l] = 1.0 - b_ * (x_ * x_ + y_ * y_)
                Q[0, 1, l] = -a_ * z_ + b_ * x_ * y_
                Q[1, 0, l] = a_ * z_ + b_ * x_ * y_
                Q[0, 2, l] = a_ * y_ + b_ * x_ * z_
                Q[2, 0, l] = -a_ * y_ + b_ * x_ * z_
                Q[1, 2, l] = -a_ * x_ + b_ * y_ * z_
                Q[2, 1, l] = a_ * x_ + b_ * y_ * z_
            # Π ← QᵀΠ and R ← R Q, in separate short loops (each vectorises on its own)
            for l in range(L):
                p0 = Q[0, 0, l] * P[0, l] + Q[1, 0, l] * P[1, l] + Q[2, 0, l] * P[2, l]
                p1 = Q[0, 1, l] * P[0, l] + Q[1, 1, l] * P[1, l] + Q[2, 1, l] * P[2, l]
                p2 = Q[0, 2, l] * P[0, l] + Q[1, 2, l] * P[1, l] + Q[2, 2, l] * P[2, l]
                P[0, l] = p0
                P[1, l] = p1
                P[2, l] = p2
            for r in range(3):
                for l in range(L):
                    r0 = Rb[r, 0, l] * Q[0, 0, l] + Rb[r, 1, l] * Q[1, 0, l] + Rb[r, 2, l] * Q[2, 0, l]
                    r1 = Rb[r, 0, l] * Q[0, 1, l] + Rb[r, 1, l] * Q[1, 1, l] + Rb[r, 2, l] * Q[2, 1, l]
                    r2 = Rb[r, 0, l] * Q[0, 2, l] + Rb[r, 1, l] * Q[1, 2, l] + Rb[r, 2, l] * Q[2, 2, l]
                    Rb[r, 0, l] = r0
                    Rb[r, 1, l] = r1
                    Rb[r, 2, l] = r2
            if project:
                for l in range(L):
                    # one Newton–Schulz step R ← R (3I − RᵀR)/2
                    m00 = 3.0 - (Rb[0, 0, l] ** 2 + Rb[1, 0, l] ** 2 + Rb[2, 0, l] ** 2)
                    m11 = 3.0 - (Rb[0, 1, l] ** 2 + Rb[1, 1, l] ** 2 + Rb[2, 1, l] ** 2)
                    m22 = 3.0 - (Rb[0, 2, l] ** 2 + Rb[1, 2, l] ** 2 + Rb[2, 2, l] ** 2)
                    m01 = -(Rb[0, 0, l] * Rb[0, 1, l] + Rb[1, 0, l] * Rb[1, 1, l] + Rb[2, 0, l] * Rb[2, 1, l])
                    m02 = -(Rb[0, 0, l] * Rb[0, 2, l] + Rb[1, 0, l] * Rb[1, 2, l] + Rb[2, 0, l] * Rb[2, 2, l])
                    m12 = -(Rb[0, 1, l] * Rb[0, 2, l] + Rb[1, 1, l] * Rb[1, 2, l] + Rb[2, 1, l] * Rb[2, 2, l])
                    for r in range(3):
                        r0 = 0.5 * (Rb[r, 0, l] * m00 + Rb[r, 1, l] * m01 + Rb[r, 2, l] * m02)
                        r1 = 0.5 * (Rb[r, 0, l] * m01 + Rb[r, 1, l] * m11 + Rb[r, 2, l] * m12)
                        r2 = 0.5 * (Rb[r, 0, l] * m02 + Rb[r, 1, l] * m12 + Rb[r, 2, l] * m22)
                        Rb[r, 0, l], Rb[r, 1, l], Rb[r, 2, l] = r0, r1, r2
            if slot < save_steps.shape[0] and save_steps[slot] == k + 1:
                for i in range(3):
                    for l in range(L):
                        out_pi[slot, i, l0 + l] = P[i, l]
                    for j in range(3):
                        for l in range(L):
                            out_R[slot, i, j, l0 + l] = Rb[i, j, l]
                slot += 1
        for i in range(3):
            for l in range(L):
                pi[i, l0 + l] = P[i, l]
            for j in range(3):
                for l in range(L):
                    R[i, j, l0 + l] = Rb[i, j, l]
