"""Ensemble kernel for the 4D Euler top: bodies in SIMD lanes, so(4) as so(3) ⊕ so(3).

The n-dimensional top's per-body path (:mod:`lieint.fast.topn`) steps one body's 4 × 4 matrices
at a time. In four dimensions the algebra splits: with unit quaternions acting on ``R⁴ = H``,
every rotation is ``x ↦ p x q̄`` (p, q unit quaternions, defined up to a common sign), and

    φ(α, β): x ↦ ½ (α x − x β)      (α, β imaginary quaternions, i.e. vectors of R³)

is a Lie algebra isomorphism ``so(3) ⊕ so(3) → so(4)`` with the cross product on each half:
``[φ(α, β), φ(γ, δ)] = φ(α × γ, β × δ)``, ``exp φ(α, β): x ↦ e^{α/2} x e^{−β/2}``, and the ad
spectral radius of φ(α, β) is ``max(|α|, |β|)`` (= θ₁ + θ₂, the sum of its rotation angles). So
RKMK on SO(4) is the 3D top's RKMK on each half, coupled only by the generator: the momentum
``Ã = φ(a)`` of the principal frame, ``Ω̃ = M ∘ Ã`` (:func:`lieint.fast.topn.inertia_factors`)
is ``φ(M₆ a)`` with a constant 6 × 6 matrix M₆. The right action ``Q · (Ã, R̃) = (QᵀÃQ, R̃Q)`` of
``Q = exp φ(u)`` is::

    a_α ← exp(−û_α) a_α,   a_β ← exp(−û_β) a_β,   p ← p ⊗ e^{u_α/2},   q ← q ⊗ e^{u_β/2}

with ``R̃ x = p x q̄``: the free 3D top's and the heavy top's passes (:mod:`lieint.fast.lanes`,
:mod:`lieint.fast.heavy_lanes`: Rodrigues' coefficients by polynomials below θ = 0.1, the quaternion
turns, strict IEEE arithmetic with explicit fused multiply-adds, spare lanes copying the block's
first body) on two vectors and two quaternions per body. A block stores a (6), p (4), q (4).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .fused import fma
from .heavy_lanes import _coefficients, _norm2_of, _rotated_back, _step_coefficients, _turn_quaternions
from .lanes import _combine, _cross, blocks_of, increment_rows, rows_of
from .quaternions import lanes_from_matrices

__all__ = [
    "NAMESPACES", "algebra_basis", "blocks_from_state", "blocks_to_principal", "generator_matrix",
    "increments_to_principal", "pairs_of_rotations",
]  # fmt: skip

#: rows of a block: a = (a_α, a_β) (6), p (4), q (4)
ROWS = 14
#: rows of a step's increment: u = (u_α, u_β)
INCREMENT_ROWS = 6


# -- the isomorphism so(3) ⊕ so(3) → so(4), worked out once in numpy ---------------------------


def _quaternion_product(a, b):
    """The Hamilton product of quaternions ``(w, x, y, z)`` (the trailing axis)."""
    a0, a1, a2, a3 = np.moveaxis(np.asarray(a, dtype=float), -1, 0)
    b0, b1, b2, b3 = np.moveaxis(np.asarray(b, dtype=float), -1, 0)
    return np.stack(
        [
            a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
            a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0,
        ],
        axis=-1,
    )


def algebra_basis() -> np.ndarray:
    """``F`` (16, 6): column k the flattened 4 × 4 matrix of φ(e_k) (``½ e_k x`` for k < 3, ``−½ x e_k``
    beyond). Its columns are orthonormal (entries 0, ±½), so ``a = Fᵀ vec(A)`` inverts
    ``vec(A) = F a`` on so(4)."""
    E = np.eye(4)
    left = [np.column_stack([_quaternion_product(E[k], E[j]) for j in range(4)]) for k in (1, 2, 3)]
    right = [np.column_stack([_quaternion_product(E[j], E[k]) for j in range(4)]) for k in (1, 2, 3)]
    return np.column_stack([0.5 * m.ravel() for m in left] + [-0.5 * m.ravel() for m in right])


def generator_matrix(M: np.ndarray) -> np.ndarray:
    """M₆ (6, 6), ``φ⁻¹(M ∘ φ(a)) = M₆ a``: the inertia operator in the algebra's coordinates."""
    F = algebra_basis()
    return F.T @ (M.ravel()[:, None] * F)


# -- the kernel -------------------------------------------------------------------------------------


@njit(cache=True, inline="always")
def _views(y, row):
    """a (6, row), p (4, row) and q (4, row) of a block's flat state."""
    return y[: 6 * row].reshape((6, row)), y[6 * row : 10 * row].reshape((4, row)), y[10 * row :].reshape((4, row))


@njit(cache=True)
def block_prepare(ctx):
    return ctx


@njit(cache=True)
def block_scratch(fx, meth, par, d):
    """The stage slopes K (s, 6, row), the increment u and the bracket's term t (6, row), the two
    halves' coefficient rows, and private copies of M₆ and the method's numbers
    (:mod:`lieint.fast.lanes`)."""
    row = d // ROWS
    s = meth.b.shape[0]
    return (
        np.zeros((s, INCREMENT_ROWS, row)), np.zeros((INCREMENT_ROWS, row)), np.zeros((INCREMENT_ROWS, row)),
        np.zeros((10, row)), par.copy(), meth.A.copy(), meth.b.reshape((1, s)).copy(), meth.coeffs.copy(),
    )  # fmt: skip


@njit(cache=True, inline="always")
def _generator_lane(a0, a1, a2, a3, a4, a5, G, K, st, l):
    """``K[st]`` of lane l: ``M₆ a``."""
    for i in range(6):
        o = 6 * i
        acc = fma(G[o + 2], a2, fma(G[o + 1], a1, G[o] * a0))
        K[st, i, l] = fma(G[o + 5], a5, fma(G[o + 4], a4, fma(G[o + 3], a3, acc)))


@njit(cache=True, inline="always")
def _dexpinv_pass(u, K, tt, coeffs, st, L):
    """``K[st] ← Σ_d c_d ad_{−u}^d K[st]`` on so(3) ⊕ so(3), ``ad_{−u}(x, y) = (x × u_α, y × u_β)``."""
    for dd in range(INCREMENT_ROWS):
        for l in range(L):
            tt[dd, l] = K[st, dd, l]
    for deg in range(1, coeffs.shape[0]):
        cf = coeffs[deg]
        for l in range(L):
            n0, n1, n2 = _cross(tt[0, l], tt[1, l], tt[2, l], u[0, l], u[1, l], u[2, l])
            m0, m1, m2 = _cross(tt[3, l], tt[4, l], tt[5, l], u[3, l], u[4, l], u[5, l])
            tt[0, l], tt[1, l], tt[2, l] = n0, n1, n2
            tt[3, l], tt[4, l], tt[5, l] = m0, m1, m2
        if cf != 0.0:
            for dd in range(INCREMENT_ROWS):
                for l in range(L):
                    K[st, dd, l] = fma(cf, tt[dd, l], K[st, dd, l])


@njit(cache=True, error_model="numpy")  # no Python division checks: they would stop the SIMD passes
def block_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One RKMK step (exponential coordinates on so(3) ⊕ so(3)) of every lane of a block; −1 when
    a stage of a lane left the dexp⁻¹ radius (``max(|u_α|, |u_β|) ≥ 2π``). ``inc`` receives the
    increments u, ``aux[0]`` the largest squared ad spectral radius ``max(|ω_α|², |ω_β|²)`` of
    ξ(y) over the block."""
    K, u, tt, c, G, A, b, coeffs = scr[0], scr[1], scr[2], scr[3], scr[4], scr[5], scr[6], scr[7]
    d = y.shape[0]
    row = d // ROWS
    L = row - 8
    for i in range(d):
        y1[i] = y[i]
    a, p, q = _views(y1, row)
    ua, ub = u[:3], u[3:]
    ca, cb, cc, da, db, dc = c[0], c[1], c[2], c[3], c[4], c[5]
    s = b.shape[1]
    for st in range(s):
        if not _combine(u, K, A, st, h, st, L):
            for l in range(L):
                _generator_lane(a[0, l], a[1, l], a[2, l], a[3, l], a[4, l], a[5, l], G, K, st, l)
            continue
        out = _coefficients(ua, ca, cb, cc, L)
        if _coefficients(ub, da, db, dc, L) or out:
            return -1  # a stage left the dexp⁻¹ radius: the block stops here (as the per-body path)
        for l in range(L):
            x0, x1, x2 = _rotated_back(u[0, l], u[1, l], u[2, l], a[0, l], a[1, l], a[2, l], ca[l], cb[l])
            x3, x4, x5 = _rotated_back(u[3, l], u[4, l], u[5, l], a[3, l], a[4, l], a[5, l], da[l], db[l])
            _generator_lane(x0, x1, x2, x3, x4, x5, G, K, st, l)
        _dexpinv_pass(u, K, tt, coeffs, st, L)
    largest = 0.0
    for l in range(L):
        largest = max(largest, _norm2_of(K[0], l), _norm2_of(K[0, 3:], l))
    aux[0] = largest
    # U = h Σ b_j K_j; a ← (exp(−Û_α) a_α, exp(−Û_β) a_β); p ← p ⊗ e^{U_α/2}; q ← q ⊗ e^{U_β/2}
    _combine(u, K, b, 0, h, s, L)
    _step_coefficients(ua, ca, cb, cc, c[6], c[7], L)
    _step_coefficients(ub, da, db, dc, c[8], c[9], L)
    for l in range(L):
        a[0, l], a[1, l], a[2, l] = _rotated_back(u[0, l], u[1, l], u[2, l], a[0, l], a[1, l], a[2, l], ca[l], cb[l])
        a[3, l], a[4, l], a[5, l] = _rotated_back(u[3, l], u[4, l], u[5, l], a[3, l], a[4, l], a[5, l], da[l], db[l])
    _turn_quaternions(ua, p, c[6], c[7], L)
    _turn_quaternions(ub, q, c[8], c[9], L)
    if inc.shape[0] >= INCREMENT_ROWS * row:
        for dd in range(INCREMENT_ROWS):
            for l in range(row):
                inc[dd * row + l] = u[dd, l] if l < L else 0.0
    return s


@njit(cache=True, inline="always")
def _normalize(quaternions, L):
    """Every lane's quaternion (4, row) onto the unit sphere."""
    for l in range(L):
        r0, r1, r2, r3 = quaternions[0, l], quaternions[1, l], quaternions[2, l], quaternions[3, l]
        m = 1.0 / np.sqrt(fma(r3, r3, fma(r2, r2, fma(r1, r1, r0 * r0))))
        quaternions[0, l], quaternions[1, l], quaternions[2, l], quaternions[3, l] = r0 * m, r1 * m, r2 * m, r3 * m


@njit(cache=True)
def block_project(fx, y, par, out, scr):
    """Every lane's p and q onto the unit sphere: R̃ exactly a rotation (a stays in so(4) by
    construction)."""
    d = y.shape[0]
    row = d // ROWS
    for i in range(d):
        out[i] = y[i]
    _, p, q = _views(out, row)
    _normalize(p, row - 8)
    _normalize(q, row - 8)


@njit(cache=True)
def block_radius2(fx, y, par, scr):
    """The largest ``max(|ω_α|², |ω_β|²)`` of the block's lanes, ``ω = M₆ a``."""
    row = y.shape[0] // ROWS
    a = y[: 6 * row].reshape((6, row))
    largest = 0.0
    for l in range(row - 8):
        for half in range(2):
            norm2 = 0.0
            for i in range(3 * half, 3 * half + 3):
                w = 0.0
                for j in range(6):
                    w += par[6 * i + j] * a[j, l]
                norm2 += w * w
            largest = max(largest, norm2)
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


# -- conversions between the principal frame's (Ã, R̃) and the blocks -------------------------------


@njit(cache=True)
def _rotations_of_pairs(p, q, out):
    """``out[s, i] = R̃`` with ``R̃ x = p x q̄`` for quaternions p, q (m, N, 4), out (m, N, 4, 4):
    column j is ``p ⊗ e_j ⊗ q̄``."""
    for s in range(p.shape[0]):
        for i in range(p.shape[1]):
            p0, p1, p2, p3 = p[s, i, 0], p[s, i, 1], p[s, i, 2], p[s, i, 3]
            q0, q1, q2, q3 = q[s, i, 0], -q[s, i, 1], -q[s, i, 2], -q[s, i, 3]
            for j in range(4):
                # p ⊗ e_j
                if j == 0:
                    x0, x1, x2, x3 = p0, p1, p2, p3
                elif j == 1:
                    x0, x1, x2, x3 = -p1, p0, p3, -p2
                elif j == 2:
                    x0, x1, x2, x3 = -p2, -p3, p0, p1
                else:
                    x0, x1, x2, x3 = -p3, p2, -p1, p0
                R = out[s, i]
                R[0, j] = x0 * q0 - x1 * q1 - x2 * q2 - x3 * q3
                R[1, j] = x0 * q1 + x1 * q0 + x2 * q3 - x3 * q2
                R[2, j] = x0 * q2 - x1 * q3 + x2 * q0 + x3 * q1
                R[3, j] = x0 * q3 + x1 * q2 - x2 * q1 + x3 * q0


def pairs_of_rotations(R: np.ndarray):
    """Unit quaternions ``(p, q)`` (N, 4) each with ``R x = p x q̄`` for rotations R (N, 4, 4):
    ``r = R e₀ = p q̄``; ``x ↦ (R x) r̄ = p x p̄`` is the 3D rotation of p (Shepperd's method,
    :func:`lieint.fast.quaternions.lanes_from_matrices`), and ``q = r̄ p``."""
    R = np.asarray(R, dtype=float)
    r = R[:, :, 0]
    conj = r * np.array([1.0, -1.0, -1.0, -1.0])
    C = np.stack([_quaternion_product(R[:, :, k], conj)[:, 1:] for k in (1, 2, 3)], axis=-1)
    p = lanes_from_matrices(C).T
    return p, _quaternion_product(conj, p)


def blocks_from_state(A: np.ndarray, R: np.ndarray, N: int) -> np.ndarray:
    """The blocks of an ensemble of N tops from the principal frame's ``Ã`` (N, 4, 4) and ``R̃``
    (N, 4, 4) (the identity where the state carries no attitude)."""
    a = np.asarray(A, dtype=float).reshape(N, 16) @ algebra_basis()
    p, q = pairs_of_rotations(R)
    return blocks_of(np.concatenate([a, p, q], axis=1), N, ROWS)


def blocks_to_principal(Y, N: int):
    """``(Ã, R̃)`` (m, N, 4, 4) of rows of blocks (m, nblocks, d)."""
    X = rows_of(Y, N, ROWS)
    A = (X[..., :6] @ algebra_basis().T).reshape(X.shape[:2] + (4, 4))
    R = np.empty(X.shape[:2] + (4, 4))
    _rotations_of_pairs(np.ascontiguousarray(X[..., 6:10]), np.ascontiguousarray(X[..., 10:14]), R)
    return A, R


def increments_to_principal(U, N: int) -> np.ndarray:
    """The increments of rows of blocks (m, nblocks, 6 row) as 4 × 4 skew matrices (m, N, 4, 4)
    of the principal frame."""
    u = increment_rows(U, N, INCREMENT_ROWS)
    return (u @ algebra_basis().T).reshape(u.shape[:2] + (4, 4))
