"""The flattened state of the generic compiled kernel, and the small linear algebra the built-in
systems' pieces share (numba, cached on disk).

A state is one float vector, field after field (:meth:`lieint.LieGroupSystem.field_offsets`):
:func:`mat`, :func:`vec` read an n × n or n-long field at an offset, :func:`put` writes one; the
pose helpers move, differentiate and project the orientation R and the centre q that several
bodies carry; :func:`lyapunov` solves ``B X + X B = C`` for the balls' rolling equation.

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
    "copy_into",
    "lyapunov",
    "lyapunov3",
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
    """X with ``B X + X B = C`` for skew C and symmetric B, exactly skew: for n = 3 by the
    inertia tensor (:func:`lyapunov3`), else in the eigenbasis of B."""
    n = B.shape[0]
    if n == 3:
        return lyapunov3(B, C)
    b, P = np.linalg.eigh(B)
    Ct = mm(mm(P.T, C), P)
    for i in range(n):
        for j in range(n):
            Ct[i, j] /= (b[i] + b[j]) if i != j else (2.0 * b[i] + 1.0)
    return skew_part(mm(mm(P, Ct), P.T))


@njit(cache=True)
def lyapunov3(B, C):
    """n = 3: with ``X = x̂``, ``B x̂ + x̂ B = ((tr B) I − B) x)^``, so x solves ``I x = c``
    (``C = ĉ``, I = (tr B) 1 − B the inertia tensor, symmetric positive definite for a body that
    is not a rod): Gaussian elimination with partial pivoting on the 3×3 system."""
    tr = B[0, 0] + B[1, 1] + B[2, 2]
    M = np.empty((3, 4))
    for i in range(3):
        for j in range(3):
            M[i, j] = -B[i, j]
        M[i, i] += tr
    M[0, 3], M[1, 3], M[2, 3] = C[2, 1], C[0, 2], C[1, 0]
    for col in range(3):
        pivot = col
        for r in range(col + 1, 3):
            if abs(M[r, col]) > abs(M[pivot, col]):
                pivot = r
        if pivot != col:
            for j in range(4):
                M[col, j], M[pivot, j] = M[pivot, j], M[col, j]
        for r in range(col + 1, 3):
            f = M[r, col] / M[col, col]
            for j in range(col, 4):
                M[r, j] -= f * M[col, j]
    x = np.empty(3)
    for i in range(2, -1, -1):
        acc = M[i, 3]
        for j in range(i + 1, 3):
            acc -= M[i, j] * x[j]
        x[i] = acc / M[i, i]
    X = np.zeros((3, 3))
    X[0, 1], X[0, 2], X[1, 2] = -x[2], x[1], -x[0]
    X[1, 0], X[2, 0], X[2, 1] = x[2], -x[1], x[0]
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
    """x scaled to length ``norm``."""
    ss = 0.0
    for i in range(x.shape[0]):
        ss += x[i] * x[i]
    return x * (norm / np.sqrt(ss))


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


@njit(cache=True)
def copy_into(y, out):
    out[:] = y
