"""The flattened state of the generic compiled kernel, and the small linear algebra the built-in
systems' pieces share (numba, cached on disk).

A state is one float vector, field after field (:meth:`lieint.LieGroupSystem.field_offsets`):
:func:`mat`, :func:`vec` read an n × n or n-long field at an offset, :func:`put` writes one; the
pose helpers move, differentiate and project the orientation R and the centre q that several
bodies carry; :func:`lyapunov_pairs` solves ``B X + X B = C`` for the balls' rolling equation.

The generators and actions — called at every stage — use the helpers that allocate nothing and
take their temporaries in the pieces' ``work`` vector (:func:`conj_flat_into`,
:func:`lyapunov_pairs`, the pose movers), compiled without reference counts
(:data:`lieint.fast._jit.NO_REFCOUNT`); the vector fields and projections (classical RK and
``project=True``) use the allocating ones.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._jit import NO_REFCOUNT
from .products import mm_loops as mm
from .products import mv
from .skew import _project

__all__ = [
    "conj_flat_into",
    "lyapunov",
    "lyapunov_pairs",
    "mat",
    "move_pose",
    "normalized",
    "pairs",
    "pose_rate",
    "project_pose",
    "put",
    "rotate_back_into",
    "skew_from_pairs",
    "skew_matrix_from_pairs",
    "skew_part",
    "times_into",
    "vec",
    "wedge",
]


@njit(cache=True)
def mat(x, off, n):
    """``x[off : off + n²]`` as a C-contiguous n×n copy (loops: lean to compile)."""
    X = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            X[i, j] = x[off + i * n + j]
    return X


@njit(cache=True)
def vec(x, off, n):
    """``x[off : off + n]`` as a copy."""
    v = np.empty(n)
    for i in range(n):
        v[i] = x[off + i]
    return v


@njit(cache=True)
def put(out, off, X):
    """``out[off : off + X.size] = X`` (row-major; X a vector or a matrix)."""
    if X.ndim == 1:
        for i in range(X.shape[0]):
            out[off + i] = X[i]
    else:
        n, m = X.shape[0], X.shape[-1]
        for i in range(n):
            for j in range(m):
                out[off + i * m + j] = X[i, j]


@njit(cache=True)
def skew_part(X):
    """``(X − Xᵀ)/2``, exactly skew."""
    n = X.shape[0]
    out = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            out[i, j] = 0.5 * (X[i, j] - X[j, i])
    return out


@njit(cache=True)
def wedge(u, v):
    """``u ∧ v = u vᵀ − v uᵀ``."""
    n = u.shape[0]
    out = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            out[i, j] = u[i] * v[j] - v[i] * u[j]
    return out


@njit(cache=True)
def lyapunov(B, C):
    """X with ``B X + X B = C`` for skew C and symmetric positive definite B (n × n, C-contiguous),
    exactly skew: :func:`lyapunov_pairs` with work arrays of its own."""
    n = B.shape[0]
    k = n * (n - 1) // 2
    L = np.empty(k * (k + 1))
    lyapunov_pairs(B.reshape(n * n), C.reshape(n * n), n, L)
    X = np.empty((n, n))
    skew_matrix_from_pairs(L, n, X)
    return X


@njit(cache=True, **NO_REFCOUNT)
def conj_flat_into(Q, x, xoff, out, ooff, D):
    """``out[ooff : ooff + n²] = QᵀCQ`` for ``C = x[xoff : xoff + n²]`` (row-major); D: n²
    scratch."""
    n = Q.shape[0]
    for i in range(n):  # D = C Q
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += x[xoff + i * n + k] * Q[k, j]
            D[i * n + j] = acc
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += Q[k, i] * D[k * n + j]
            out[ooff + i * n + j] = acc


def pairs(n: int) -> int:
    """``n(n − 1)/2``: the unknowns of a skew n × n matrix (:func:`lyapunov_pairs`)."""
    return n * (n - 1) // 2


@njit(cache=True, **NO_REFCOUNT)
def _pair(a, b, n):
    """The index of the unknown ``X_ab`` (a < b) among the pairs in row-major order."""
    return a * n - a * (a + 1) // 2 + (b - a - 1)


@njit(cache=True, **NO_REFCOUNT)
def lyapunov_pairs(B, C, n, L):
    """Solve ``B X + X B = C`` for skew X (C skew, B symmetric positive definite; B and C flat,
    row-major) on the ``k = n(n − 1)/2`` unknowns ``x_p = X_ab``, ``a < b``: the equations at the
    entries ``i < j`` form a k × k system (symmetric positive definite: on skew matrices
    ``X ↦ BX + XB`` is, with eigenvalues ``b_i + b_j``), solved by Gaussian elimination with
    partial pivoting in ``L`` (``k(k + 1)`` scratch); the solution is left in its last column
    (:func:`skew_from_pairs` reads it). No eigendecomposition and no allocation: for n = 3, 4,
    6 the system is 3, 6, 15 unknowns."""
    k = n * (n - 1) // 2
    cols = k + 1
    for e in range(k * cols):
        L[e] = 0.0
    q = 0
    for i in range(n):
        for j in range(i + 1, n):
            row = q * cols
            for m in range(n):  # (BX)_ij = Σ_m B_im X_mj
                if m < j:
                    L[row + _pair(m, j, n)] += B[i * n + m]
                elif m > j:
                    L[row + _pair(j, m, n)] -= B[i * n + m]
            for m in range(n):  # (XB)_ij = Σ_m X_im B_mj
                if m > i:
                    L[row + _pair(i, m, n)] += B[m * n + j]
                elif m < i:
                    L[row + _pair(m, i, n)] -= B[m * n + j]
            L[row + k] = C[i * n + j]
            q += 1
    for c in range(k):
        p = c
        for r in range(c + 1, k):
            if abs(L[r * cols + c]) > abs(L[p * cols + c]):
                p = r
        if L[p * cols + c] == 0.0:  # B not positive definite (or not finite): X is NaN, reported
            for r in range(k):
                L[r * cols + k] = np.nan
            return
        if p != c:
            for j in range(c, cols):
                L[c * cols + j], L[p * cols + j] = L[p * cols + j], L[c * cols + j]
        for r in range(c + 1, k):
            f = L[r * cols + c] / L[c * cols + c]
            if f != 0.0:
                for j in range(c, cols):
                    L[r * cols + j] -= f * L[c * cols + j]
    for r in range(k - 1, -1, -1):
        acc = L[r * cols + k]
        for j in range(r + 1, k):
            acc -= L[r * cols + j] * L[j * cols + k]
        L[r * cols + k] = acc / L[r * cols + r]


@njit(cache=True, **NO_REFCOUNT)
def skew_from_pairs(L, n, X, off):
    """``X[off : off + n²]`` (flat, row-major) the skew matrix whose pairs
    :func:`lyapunov_pairs` left in the last column of L."""
    k = n * (n - 1) // 2
    cols = k + 1
    for i in range(n):
        X[off + i * n + i] = 0.0
    q = 0
    for i in range(n):
        for j in range(i + 1, n):
            x = L[q * cols + k]
            X[off + i * n + j] = x
            X[off + j * n + i] = -x
            q += 1


@njit(cache=True, **NO_REFCOUNT)
def skew_matrix_from_pairs(L, n, X):
    """:func:`skew_from_pairs` into an n × n matrix X."""
    k = n * (n - 1) // 2
    cols = k + 1
    for i in range(n):
        X[i, i] = 0.0
    q = 0
    for i in range(n):
        for j in range(i + 1, n):
            x = L[q * cols + k]
            X[i, j] = x
            X[j, i] = -x
            q += 1


@njit(cache=True, **NO_REFCOUNT)
def rotate_back_into(Q, y, yoff, out, ooff):
    """``out[ooff : ooff + n] = Qᵀ y[yoff : yoff + n]``."""
    n = Q.shape[0]
    for i in range(n):
        acc = 0.0
        for k in range(n):
            acc += Q[k, i] * y[yoff + k]
        out[ooff + i] = acc


@njit(cache=True, **NO_REFCOUNT)
def times_into(y, off, Q, out):
    """``out[off : off + n²] = R Q`` for the matrix R stored at ``y[off : off + n²]``."""
    n = Q.shape[0]
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += y[off + i * n + k] * Q[k, j]
            out[off + i * n + j] = acc


@njit(cache=True)
def normalized(x, norm):
    """x scaled to length ``norm`` (NaN for x = 0: no direction to keep, the state is reported)."""
    ss = 0.0
    for i in range(x.shape[0]):
        ss += x[i] * x[i]
    return x * (norm / np.sqrt(ss)) if ss > 0.0 else x * np.nan


@njit(cache=True, **NO_REFCOUNT)
def move_pose(Q, t, y, out, oR, oC, n):
    """``R ← RQ`` and ``q ← q + R t`` (the old R) where the state carries them."""
    if oR >= 0:
        times_into(y, oR, Q, out)
        if oC >= 0:
            for i in range(n):
                acc = y[oC + i]
                for k in range(n):
                    acc += y[oR + i * n + k] * t[k]
                out[oC + i] = acc


@njit(cache=True)
def pose_rate(Om, V, y, out, oR, oC, n):
    """``Ṙ = RΩ``, ``q̇ = R V``."""
    if oR >= 0:
        R = mat(y, oR, n)
        put(out, oR, mm(R, Om))
        if oC >= 0:
            put(out, oC, mv(R, V))


@njit(cache=True)
def project_pose(y, out, oR, oC, n, normal, radius):
    """R onto SO(n) (polar factor); the centre back onto the plane ``⟨q, ν⟩ = r``."""
    if oR >= 0:
        put(out, oR, _project(mat(y, oR, n)))
        if oC >= 0:
            q = vec(y, oC, n)
            put(out, oC, q - (np.dot(q, normal) - radius) * normal)
