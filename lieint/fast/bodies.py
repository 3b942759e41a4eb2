"""Compiled pieces of the built-in systems on SO(n)/SE(n) × Rᵐ, for :mod:`lieint.fast.generic`.

Each system's ``compiled()`` names its pieces (``"pieces": "heavy_top"``) and packs its
parameters into one float vector whose first entries are ``n`` and the offsets of its fields
in the flattened state; these functions read that layout. The equations are the generic
path's, in the lecture's notation (MATH.md §3–§5):

* Euler top, ``Q·(A, R) = (QᵀAQ, RQ)``, ``ξ = Ω(A)`` (its adaptive pairs for n ≥ 4);
* heavy top, ``(Q, v)·(A, Γ, R) = (Qᵀ(A + v∧Γ)Q, QᵀΓ, RQ)``, ``ξ = (Ω(A), M X_G)``;
* free body, ``(Q, p, w)·(A, R, q, v) = (QᵀAQ, RQ, q + p, v + w)``, ``ξ = (Ω(A), v, g)``;
* Chaplygin ball, ``(Q, v)·(A_K, Γ, R, q) = (QᵀA_KQ, QᵀΓ, RQ, q + Rv)``,
  ``ξ = (Ω, rΩΓ)`` with ``A_K = −(B_K Ω + Ω B_K)``, ``B_K = B_C + M r² ΓΓᵀ``;
* rolling ball, ``((Q, v), δ)·(Ω, Γ, G, R, q) = (Ω + δ, QᵀΓ, QᵀG, RQ, q + Rv)``,
  ``ξ = ((Ω, rΩΓ), Ω̇)`` with Ω̇ from the rolling equation (a Lyapunov solve in the eigenbasis
  of ``B_K(Γ)``).

The pieces are compiled lazily, for the signatures of :mod:`lieint.fast.generic`, when a run of
their system first needs them (:class:`lieint.fast.generic.CompiledPieces`), so a run of one
system never compiles another's. The Lyapunov equation ``B X + X B = C`` is solved in the eigenbasis of B as
:func:`lieint.systems.mass.solve_lyapunov_sym` does, and every Ω is made exactly skew.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .generic import CompiledPieces
from .skew import _project, mv
from .skew import mm_loops as mm

__all__ = ["PIECES"]

# -- shared helpers ----------------------------------------------------------------------------


@njit(cache=True)
def _mat(x, off, n):
    """``x[off : off + n²]`` as a C-contiguous n×n copy (loops: lean to compile)."""
    X = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            X[i, j] = x[off + i * n + j]
    return X


@njit(cache=True)
def _vec(x, off, n):
    """``x[off : off + n]`` as a copy."""
    v = np.empty(n)
    for i in range(n):
        v[i] = x[off + i]
    return v


@njit(cache=True)
def _put(out, off, X):
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
def _skew(X):
    """``(X − Xᵀ)/2``, exactly skew."""
    n = X.shape[0]
    out = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            out[i, j] = 0.5 * (X[i, j] - X[j, i])
    return out


@njit(cache=True)
def _wedge(u, v):
    """``u ∧ v = u vᵀ − v uᵀ``."""
    n = u.shape[0]
    out = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            out[i, j] = u[i] * v[j] - v[i] * u[j]
    return out


@njit(cache=True)
def _lyapunov(B, C):
    """X with ``B X + X B = C`` for skew C and symmetric B, exactly skew: for n = 3 by the
    inertia tensor (:func:`_lyapunov3`), else in the eigenbasis of B."""
    n = B.shape[0]
    if n == 3:
        return _lyapunov3(B, C)
    b, P = np.linalg.eigh(B)
    Ct = mm(mm(P.T, C), P)
    for i in range(n):
        for j in range(n):
            Ct[i, j] /= (b[i] + b[j]) if i != j else (2.0 * b[i] + 1.0)
    return _skew(mm(mm(P, Ct), P.T))


@njit(cache=True)
def _lyapunov3(B, C):
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


@njit(cache=True)
def _conj_into(Q, C, out, off):
    """``out[off : off + n²] = QᵀCQ`` (row-major)."""
    n = Q.shape[0]
    D = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += C[i, k] * Q[k, j]
            D[i, j] = acc
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += Q[k, i] * D[k, j]
            out[off + i * n + j] = acc


@njit(cache=True)
def _rotate_back_into(Q, y, yoff, out, ooff):
    """``out[ooff : ooff + n] = Qᵀ y[yoff : yoff + n]``."""
    n = Q.shape[0]
    for i in range(n):
        acc = 0.0
        for k in range(n):
            acc += Q[k, i] * y[yoff + k]
        out[ooff + i] = acc


@njit(cache=True)
def _times_into(y, off, Q, out):
    """``out[off : off + n²] = R Q`` for the matrix R stored at ``y[off : off + n²]``."""
    n = Q.shape[0]
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += y[off + i * n + k] * Q[k, j]
            out[off + i * n + j] = acc


@njit(cache=True)
def _normalized(x, norm):
    """x scaled to length ``norm``."""
    ss = 0.0
    for i in range(x.shape[0]):
        ss += x[i] * x[i]
    return x * (norm / np.sqrt(ss))


@njit(cache=True)
def _move_pose(Q, t, y, out, oR, oC, n):
    """``R ← RQ`` and ``q ← q + R t`` (the old R) where the state carries them."""
    if oR >= 0:
        _times_into(y, oR, Q, out)
        if oC >= 0:
            for i in range(n):
                acc = y[oC + i]
                for k in range(n):
                    acc += y[oR + i * n + k] * t[k]
                out[oC + i] = acc


@njit(cache=True)
def _pose_rate(Om, V, y, out, oR, oC, n):
    """``Ṙ = RΩ``, ``q̇ = R V``."""
    if oR >= 0:
        R = _mat(y, oR, n)
        _put(out, oR, mm(R, Om))
        if oC >= 0:
            _put(out, oC, mv(R, V))


@njit(cache=True)
def _project_pose(y, out, oR, oC, n, normal, radius):
    """R onto SO(n) (polar factor); the centre back onto the plane ``⟨q, ν⟩ = r``."""
    if oR >= 0:
        _put(out, oR, _project(_mat(y, oR, n)))
        if oC >= 0:
            q = _vec(y, oC, n)
            _put(out, oC, q - (np.dot(q, normal) - radius) * normal)


@njit(cache=True)
def _copy(y, out):
    out[:] = y


# -- the rigid body with constant B: heavy top and free body ------------------------------------
# params: n, oR, ident, P (n²), M = −1/(b_i + b_j) (n², 0 on the diagonal), then the system's own


@njit(cache=True)
def _top_omega(A, par, n):
    """Ω(A): ``Ω_ij = −Ã_ij/(b_i + b_j)`` in the eigenbasis P of B (``Ã = PᵀAP``,
    ``Ω = P Ω̃ Pᵀ``), made exactly skew; loops (lean to compile)."""
    M = _mat(par, 3 + n * n, n)
    if par[2] != 0.0:
        X = np.empty((n, n))
        for i in range(n):
            for j in range(n):
                X[i, j] = A[i, j] * M[i, j]
        return _skew(X)
    P = _mat(par, 3, n)
    AP = np.zeros((n, n))
    for i in range(n):
        for k in range(n):
            for j in range(n):
                AP[i, j] += A[i, k] * P[k, j]
    W = np.zeros((n, n))  # (PᵀAP) ∘ M
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += P[k, i] * AP[k, j]
            W[i, j] = acc * M[i, j]
    WP = np.zeros((n, n))  # W Pᵀ
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += W[i, k] * P[j, k]
            WP[i, j] = acc
    X = np.zeros((n, n))
    for i in range(n):
        for k in range(n):
            for j in range(n):
                X[i, j] += P[i, k] * WP[k, j]
    return _skew(X)


@njit(cache=True)
def _omega_into(y, par, W):
    """``W = Ω(A)`` for the momentum A stored first in y."""
    n = W.shape[0]
    if par[2] != 0.0:  # diagonal B: Ω_ij = −A_ij/(b_i + b_j), made exactly skew
        m = 3 + n * n
        for i in range(n):
            for j in range(n):
                W[i, j] = 0.5 * (y[i * n + j] * par[m + i * n + j] - y[j * n + i] * par[m + j * n + i])
    else:
        W[:, :] = _top_omega(_mat(y, 0, n), par, n)


@njit(cache=True)
def _conj_skew_into(Q, y, out):
    """``out[: n²] = skew(QᵀAQ)`` for the momentum A stored first in y (the Euler top's action,
    made exactly skew as the generic one)."""
    n = Q.shape[0]
    _conj_into(Q, _mat(y, 0, n), out, 0)
    for i in range(n):
        for j in range(i, n):
            d = 0.5 * (out[i * n + j] - out[j * n + i])
            out[i * n + j] = d
            out[j * n + i] = -d


# Euler top (its adaptive pairs for n ≥ 4): fields A, [R]; no own params
@njit(cache=True)
def _top_generator(y, par, W, v, a):
    _omega_into(y, par, W)


@njit(cache=True)
def _top_action(Q, t, a, y, par, out):
    _conj_skew_into(Q, y, out)
    oR = int(par[1])
    if oR >= 0:
        _times_into(y, oR, Q, out)


@njit(cache=True)
def _top_field(y, par, out):
    n = int(par[0])
    A = _mat(y, 0, n)
    Om = _top_omega(A, par, n)
    _put(out, 0, mm(A, Om) - mm(Om, A))
    oR = int(par[1])
    if oR >= 0:
        _put(out, oR, mm(_mat(y, oR, n), Om))


@njit(cache=True)
def _top_projection(y, par, out):
    n = int(par[0])
    _copy(y, out)
    _put(out, 0, _skew(_mat(y, 0, n)))
    _project_pose(y, out, int(par[1]), -1, n, np.empty(0), 0.0)


# heavy top: fields A, Gamma, [R]; own params M X_G (n), |g|
@njit(cache=True)
def _heavy_generator(y, par, W, v, a):
    n = W.shape[0]
    _omega_into(y, par, W)
    v[:] = par[3 + 2 * n * n : 3 + 2 * n * n + n]


@njit(cache=True)
def _heavy_action(Q, t, a, y, par, out):
    n = Q.shape[0]
    nn = n * n
    C = np.empty((n, n))  # A + t ∧ Γ
    for i in range(n):
        for j in range(n):
            C[i, j] = y[i * n + j] + t[i] * y[nn + j] - y[nn + i] * t[j]
    _conj_into(Q, C, out, 0)
    _rotate_back_into(Q, y, nn, out, nn)
    oR = int(par[1])
    if oR >= 0:
        _times_into(y, oR, Q, out)


@njit(cache=True)
def _heavy_field(y, par, out):
    n = int(par[0])
    A, G = _mat(y, 0, n), _vec(y, n * n, n)
    Om = _top_omega(A, par, n)
    MXG = _vec(par, 3 + 2 * n * n, n)
    _put(out, 0, mm(A, Om) - mm(Om, A) + _wedge(MXG, G))
    _put(out, n * n, -mv(Om, G))
    oR = int(par[1])
    if oR >= 0:
        _put(out, oR, mm(_mat(y, oR, n), Om))


@njit(cache=True)
def _heavy_projection(y, par, out):
    n = int(par[0])
    _put(out, 0, _skew(_mat(y, 0, n)))
    _put(out, n * n, _normalized(_vec(y, n * n, n), par[3 + 2 * n * n + n]))
    _project_pose(y, out, int(par[1]), -1, n, np.empty(0), 0.0)


# free body: fields A, [R], center, velocity; own params oC, g (n)
@njit(cache=True)
def _free_generator(y, par, W, v, a):
    n = W.shape[0]
    _omega_into(y, par, W)
    oC = int(par[3 + 2 * n * n])
    a[:n] = y[oC + n : oC + 2 * n]
    a[n:] = par[4 + 2 * n * n : 4 + 2 * n * n + n]


@njit(cache=True)
def _free_action(Q, t, a, y, par, out):
    n = Q.shape[0]
    _conj_skew_into(Q, y, out)
    oR, oC = int(par[1]), int(par[3 + 2 * n * n])
    if oR >= 0:
        _times_into(y, oR, Q, out)
    for i in range(2 * n):
        out[oC + i] = y[oC + i] + a[i]


@njit(cache=True)
def _free_field(y, par, out):
    n = int(par[0])
    A = _mat(y, 0, n)
    Om = _top_omega(A, par, n)
    _put(out, 0, mm(A, Om) - mm(Om, A))
    oR, oC = int(par[1]), int(par[3 + 2 * n * n])
    if oR >= 0:
        _put(out, oR, mm(_mat(y, oR, n), Om))
    for i in range(n):
        out[oC + i] = y[oC + n + i]
        out[oC + n + i] = par[4 + 2 * n * n + i]


@njit(cache=True)
def _free_projection(y, par, out):
    n = int(par[0])
    _copy(y, out)
    _put(out, 0, _skew(_mat(y, 0, n)))
    _project_pose(y, out, int(par[1]), -1, n, np.empty(0), 0.0)


# -- the balls ---------------------------------------------------------------------------------
# Chaplygin: fields A, Gamma, [R], [center]; params n, oR, oC, M r², r, B_C (n²), ν (n)


@njit(cache=True)
def _chaplygin_omega(y, par, n):
    """Ω from ``A_K = −(B_K Ω + Ω B_K)``, ``B_K = B_C + M r² ΓΓᵀ``."""
    G = _vec(y, n * n, n)
    BK = _mat(par, 5, n)
    for i in range(n):
        for j in range(n):
            BK[i, j] += par[3] * G[i] * G[j]
    return _lyapunov(BK, -_mat(y, 0, n)), G


@njit(cache=True)
def _chaplygin_generator(y, par, W, v, a):
    n = W.shape[0]
    Om, G = _chaplygin_omega(y, par, n)
    W[:, :] = Om
    if v.size:
        v[:] = par[4] * mv(Om, G)


@njit(cache=True)
def _chaplygin_action(Q, t, a, y, par, out):
    n = Q.shape[0]
    _conj_into(Q, _mat(y, 0, n), out, 0)
    _rotate_back_into(Q, y, n * n, out, n * n)
    _move_pose(Q, t, y, out, int(par[1]), int(par[2]), n)


@njit(cache=True)
def _chaplygin_field(y, par, out):
    n = int(par[0])
    Om, G = _chaplygin_omega(y, par, n)
    A = _mat(y, 0, n)
    _put(out, 0, mm(A, Om) - mm(Om, A))
    _put(out, n * n, -mv(Om, G))
    _pose_rate(Om, par[4] * mv(Om, G), y, out, int(par[1]), int(par[2]), n)


@njit(cache=True)
def _chaplygin_projection(y, par, out):
    n = int(par[0])
    _copy(y, out)
    _put(out, 0, _skew(_mat(y, 0, n)))
    _put(out, n * n, _normalized(_vec(y, n * n, n), 1.0))
    _project_pose(y, out, int(par[1]), int(par[2]), n, _vec(par, 5 + n * n, n), par[4])


# rolling ball: fields Omega, Gamma, [G], [R], [center]; params n, oR, oC, oG, M, r, gravity mode
# (0: none, 1: along ν, c = ⟨g, ν⟩; 2: tilted, G a field), c, |g|, B_C (n²), X_G (n), ν (n)


@njit(cache=True)
def _ball_acceleration(y, par, n):
    """Ω̇ of the rolling equation: ``B_K Ω̇ + Ω̇ B_K = [B_K, Ω²] − M (κ + X_G) ∧ (Ω²κ + G)``,
    ``κ = rΓ``, ``B_K = B_C + M(X_G κᵀ + κ X_Gᵀ) + M κκᵀ``."""
    Om = _mat(y, 0, n)
    M, r = par[4], par[5]
    k = r * _vec(y, n * n, n)
    XG = _vec(par, 9 + n * n, n)
    BK = _mat(par, 9, n)
    for i in range(n):
        for j in range(n):
            BK[i, j] += M * (k[i] * k[j] + XG[i] * k[j] + k[i] * XG[j])
    Om2 = mm(Om, Om)
    force = mv(Om2, k)
    mode = par[6]
    if mode == 1.0:
        force = force + par[7] * _vec(y, n * n, n)
    elif mode == 2.0:
        force = force + _vec(y, int(par[3]), n)
    C = mm(BK, Om2) - mm(Om2, BK) - M * _wedge(k + XG, force)
    return _lyapunov(BK, C)


@njit(cache=True)
def _ball_generator(y, par, W, v, a):
    n = W.shape[0]
    Om = _mat(y, 0, n)
    W[:, :] = Om
    if v.size:
        v[:] = par[5] * mv(Om, _vec(y, n * n, n))
    _put(a, 0, _ball_acceleration(y, par, n))


@njit(cache=True)
def _ball_action(Q, t, a, y, par, out):
    n = Q.shape[0]
    for i in range(n * n):
        out[i] = y[i] + a[i]
    _rotate_back_into(Q, y, n * n, out, n * n)
    oG = int(par[3])
    if oG >= 0:
        _rotate_back_into(Q, y, oG, out, oG)
    _move_pose(Q, t, y, out, int(par[1]), int(par[2]), n)


@njit(cache=True)
def _ball_field(y, par, out):
    n = int(par[0])
    Om = _mat(y, 0, n)
    _put(out, 0, _ball_acceleration(y, par, n))
    G = _vec(y, n * n, n)
    _put(out, n * n, -mv(Om, G))
    oG = int(par[3])
    if oG >= 0:
        _put(out, oG, -mv(Om, _vec(y, oG, n)))
    _pose_rate(Om, par[5] * mv(Om, G), y, out, int(par[1]), int(par[2]), n)


@njit(cache=True)
def _ball_projection(y, par, out):
    n = int(par[0])
    _copy(y, out)
    _put(out, 0, _skew(_mat(y, 0, n)))
    _put(out, n * n, _normalized(_vec(y, n * n, n), 1.0))
    oG = int(par[3])
    if oG >= 0:
        _put(out, oG, _normalized(_vec(y, oG, n), par[8]))
    _project_pose(y, out, int(par[1]), int(par[2]), n, _vec(par, 9 + n * n + n, n), par[5])


#: the built-in systems' pieces, by the name their ``compiled()`` declares
PIECES = {
    "euler_top": CompiledPieces(_top_generator, _top_action, _top_field, _top_projection),
    "heavy_top": CompiledPieces(_heavy_generator, _heavy_action, _heavy_field, _heavy_projection),
    "free_body": CompiledPieces(_free_generator, _free_action, _free_field, _free_projection),
    "chaplygin_ball": CompiledPieces(_chaplygin_generator, _chaplygin_action, _chaplygin_field, _chaplygin_projection),
    "rolling_ball": CompiledPieces(_ball_generator, _ball_action, _ball_field, _ball_projection),
}
