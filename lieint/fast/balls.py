"""Compiled pieces of the rolling balls for :mod:`lieint.fast.generic` (numba, cached on disk).

The equations are the generic path's (docs/theory.md §4–§5):

* Chaplygin ball, ``(Q, v)·(A_K, Γ, R, q) = (QᵀA_KQ, QᵀΓ, RQ, q + Rv)``,
  ``ξ = (Ω, rΩΓ)`` with ``A_K = −(B_K Ω + Ω B_K)``, ``B_K = B_C + M r² ΓΓᵀ``;
* rolling ball, ``((Q, v), δ)·(Ω, Γ, G, R, q) = (Ω + δ, QᵀΓ, QᵀG, RQ, q + Rv)``,
  ``ξ = ((Ω, rΩΓ), Ω̇)`` with Ω̇ from the rolling equation (a Lyapunov equation in
  ``B_K(Γ)``).

Parameters and state layouts are described above each system's pieces; the registry of every
built-in system's pieces is :data:`lieint.fast.bodies.PIECES`. The generators and actions
allocate nothing (their temporaries are in ``work``; compiled without reference counts); the
vector fields and projections (classical RK, ``project=True``) allocate. Both solve the
Lyapunov equation ``B X + X B = C`` on the n(n − 1)/2 unknowns of the skew X by elimination
(:func:`lieint.fast.flat.lyapunov_pairs`; NaN, reported as a non-finite state, when B is not
positive definite). Every Ω is exactly skew.
"""

from __future__ import annotations

from numba import njit

from ._jit import NO_REFCOUNT
from .flat import (
    conj_flat_into,
    lyapunov,
    lyapunov_pairs,
    mat,
    move_pose,
    normalized,
    pose_rate,
    project_pose,
    put,
    rotate_back_into,
    skew_from_pairs,
    skew_matrix_from_pairs,
    skew_part,
    vec,
    wedge,
)
from .pieces import CompiledPieces
from .products import copy_vector_into, mv
from .products import mm_loops as mm

__all__ = ["CHAPLYGIN", "ROLLING_BALL"]


# -- the balls ---------------------------------------------------------------------------------
# Chaplygin: fields A, Gamma, [R], [center]; params n, oR, oC, M r², r, B_C (n²), ν (n)


@njit(cache=True)
def _chaplygin_omega(y, par, n):
    """Ω from ``A_K = −(B_K Ω + Ω B_K)``, ``B_K = B_C + M r² ΓΓᵀ``."""
    G = vec(y, n * n, n)
    BK = mat(par, 5, n)
    for i in range(n):
        for j in range(n):
            BK[i, j] += par[3] * G[i] * G[j]
    return lyapunov(BK, -mat(y, 0, n)), G


def _chaplygin_work(n: int) -> int:
    """B_K, −A_K and the Lyapunov system, and Ω for the energy."""
    k = n * (n - 1) // 2
    return 3 * n * n + k * (k + 1)


@njit(cache=True, **NO_REFCOUNT)
def _chaplygin_energy(y, par, work):
    """``T = −¼⟨Ω, A_K⟩`` with Ω from ``B_K Ω + Ω B_K = −A_K`` (the generator's solve)."""
    n = int(par[0])
    nn = n * n
    k = n * (n - 1) // 2
    BK, C, L = work[:nn], work[nn : 2 * nn], work[2 * nn : 2 * nn + k * (k + 1)]
    for i in range(n):
        for j in range(n):
            BK[i * n + j] = par[5 + i * n + j] + par[3] * y[nn + i] * y[nn + j]
            C[i * n + j] = -y[i * n + j]
    lyapunov_pairs(BK, C, n, L)
    off = 2 * nn + k * (k + 1)
    skew_from_pairs(L, n, work, off)
    total = 0.0
    for e in range(nn):
        total += work[off + e] * y[e]
    return -0.25 * total


@njit(cache=True, **NO_REFCOUNT)
def _chaplygin_generator(y, par, W, v, a, work):
    """``Ω`` from ``B_K Ω + Ω B_K = −A_K`` with ``B_K = B_C + M r² ΓΓᵀ``, and ``v = r ΩΓ``."""
    n = W.shape[0]
    nn = n * n
    BK, C, L = work[:nn], work[nn : 2 * nn], work[2 * nn :]
    for i in range(n):
        for j in range(n):
            BK[i * n + j] = par[5 + i * n + j] + par[3] * y[nn + i] * y[nn + j]
            C[i * n + j] = -y[i * n + j]
    lyapunov_pairs(BK, C, n, L)
    skew_matrix_from_pairs(L, n, W)
    if v.shape[0] > 0:
        for i in range(n):
            acc = 0.0
            for k in range(n):
                acc += W[i, k] * y[nn + k]
            v[i] = par[4] * acc


@njit(cache=True, **NO_REFCOUNT)
def _chaplygin_action(Q, t, a, y, par, out, work):
    n = Q.shape[0]
    conj_flat_into(Q, y, 0, out, 0, work)
    rotate_back_into(Q, y, n * n, out, n * n)
    move_pose(Q, t, y, out, int(par[1]), int(par[2]), n)


@njit(cache=True)
def _chaplygin_field(y, par, out, work):
    n = int(par[0])
    Om, G = _chaplygin_omega(y, par, n)
    A = mat(y, 0, n)
    put(out, 0, mm(A, Om) - mm(Om, A))
    put(out, n * n, -mv(Om, G))
    pose_rate(Om, par[4] * mv(Om, G), y, out, int(par[1]), int(par[2]), n)


@njit(cache=True)
def _chaplygin_projection(y, par, out, work):
    n = int(par[0])
    copy_vector_into(y, out)
    put(out, 0, skew_part(mat(y, 0, n)))
    put(out, n * n, normalized(vec(y, n * n, n), 1.0))
    project_pose(y, out, int(par[1]), int(par[2]), n, vec(par, 5 + n * n, n), par[4])


# rolling ball: fields Omega, Gamma, [G], [R], [center]; params n, oR, oC, oG, M, r, gravity mode
# (0: none, 1: along ν, c = ⟨g, ν⟩; 2: tilted, G a field), c, |g|, B_C (n²), X_G (n), ν (n), g (n)


@njit(cache=True)
def _ball_acceleration(y, par, n):
    """Ω̇ of the rolling equation: ``B_K Ω̇ + Ω̇ B_K = [B_K, Ω²] − M (κ + X_G) ∧ (Ω²κ + G)``,
    ``κ = rΓ``, ``B_K = B_C + M(X_G κᵀ + κ X_Gᵀ) + M κκᵀ``."""
    Om = mat(y, 0, n)
    M, r = par[4], par[5]
    k = r * vec(y, n * n, n)
    XG = vec(par, 9 + n * n, n)
    BK = mat(par, 9, n)
    for i in range(n):
        for j in range(n):
            BK[i, j] += M * (k[i] * k[j] + XG[i] * k[j] + k[i] * XG[j])
    Om2 = mm(Om, Om)
    force = mv(Om2, k)
    mode = par[6]
    if mode == 1.0:
        force = force + par[7] * vec(y, n * n, n)
    elif mode == 2.0:
        force = force + vec(y, int(par[3]), n)
    C = mm(BK, Om2) - mm(Om2, BK) - M * wedge(k + XG, force)
    return lyapunov(BK, C)


def _ball_work(n: int) -> int:
    """B_K, Ω², the right-hand side, κ, the force and the Lyapunov system."""
    k = n * (n - 1) // 2
    return 3 * n * n + 2 * n + k * (k + 1)


@njit(cache=True, **NO_REFCOUNT)
def _ball_acceleration_into(y, par, n, out, work):
    """:func:`_ball_acceleration` into ``out`` (flat, n²), its temporaries in ``work``."""
    nn = n * n
    M, r = par[4], par[5]
    BK, Om2, C = work[:nn], work[nn : 2 * nn], work[2 * nn : 3 * nn]
    k, force, L = work[3 * nn : 3 * nn + n], work[3 * nn + n : 3 * nn + 2 * n], work[3 * nn + 2 * n :]
    xg = 9 + nn  # X_G in par
    for i in range(n):
        k[i] = r * y[nn + i]
    for i in range(n):
        for j in range(n):
            BK[i * n + j] = par[9 + i * n + j] + M * (k[i] * k[j] + par[xg + i] * k[j] + k[i] * par[xg + j])
            acc = 0.0
            for m in range(n):
                acc += y[i * n + m] * y[m * n + j]
            Om2[i * n + j] = acc
    mode = par[6]
    oG = int(par[3])
    for i in range(n):
        acc = 0.0
        for m in range(n):
            acc += Om2[i * n + m] * k[m]
        if mode == 1.0:
            acc += par[7] * y[nn + i]
        elif mode == 2.0:
            acc += y[oG + i]
        force[i] = acc
    for i in range(n):  # [B_K, Ω²] − M (κ + X_G) ∧ force
        for j in range(n):
            acc = 0.0
            for m in range(n):
                acc += BK[i * n + m] * Om2[m * n + j] - Om2[i * n + m] * BK[m * n + j]
            ui, uj = k[i] + par[xg + i], k[j] + par[xg + j]
            C[i * n + j] = acc - M * (ui * force[j] - force[i] * uj)
    lyapunov_pairs(BK, C, n, L)
    skew_from_pairs(L, n, out, 0)


@njit(cache=True, **NO_REFCOUNT)
def _ball_generator(y, par, W, v, a, work):
    n = W.shape[0]
    nn = n * n
    for i in range(n):
        for j in range(n):
            W[i, j] = y[i * n + j]
    if v.shape[0] > 0:
        for i in range(n):
            acc = 0.0
            for k in range(n):
                acc += y[i * n + k] * y[nn + k]
            v[i] = par[5] * acc
    _ball_acceleration_into(y, par, n, a, work)


@njit(cache=True, **NO_REFCOUNT)
def _ball_action(Q, t, a, y, par, out, work):
    n = Q.shape[0]
    for i in range(n * n):
        out[i] = y[i] + a[i]
    rotate_back_into(Q, y, n * n, out, n * n)
    oG = int(par[3])
    if oG >= 0:
        rotate_back_into(Q, y, oG, out, oG)
    move_pose(Q, t, y, out, int(par[1]), int(par[2]), n)


@njit(cache=True)
def _ball_field(y, par, out, work):
    n = int(par[0])
    Om = mat(y, 0, n)
    put(out, 0, _ball_acceleration(y, par, n))
    G = vec(y, n * n, n)
    put(out, n * n, -mv(Om, G))
    oG = int(par[3])
    if oG >= 0:
        put(out, oG, -mv(Om, vec(y, oG, n)))
    pose_rate(Om, par[5] * mv(Om, G), y, out, int(par[1]), int(par[2]), n)


@njit(cache=True, **NO_REFCOUNT)
def _ball_energy(y, par, work):
    """``H = ½⟨Ω, B_K Ω⟩ − U``, ``U = M⟨G, X_G⟩`` plus ``M⟨g, q⟩`` on an incline (G a field,
    q tracked) or ``M c r`` with gravity along ν (``G = cΓ``): the generic path's
    :meth:`lieint.RollingBall.energy`."""
    n = int(par[0])
    nn = n * n
    M, r, mode = par[4], par[5], par[6]
    xg = 9 + nn
    kinetic = 0.0
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for m in range(n):  # (B_K Ω)_ij, B_K = B_C + M κκᵀ + M (X_G κᵀ + κ X_Gᵀ), κ = rΓ
                ki, km = r * y[nn + i], r * y[nn + m]
                bk = par[9 + i * n + m] + M * (ki * km + par[xg + i] * km + ki * par[xg + m])
                acc += bk * y[m * n + j]
            kinetic += y[i * n + j] * acc
    energy = 0.5 * kinetic
    if mode == 1.0:
        c = par[7]
        for i in range(n):
            energy -= M * (c * y[nn + i]) * par[xg + i]
        energy -= M * c * r
    elif mode == 2.0:
        oG, oC = int(par[3]), int(par[2])
        for i in range(n):
            energy -= M * y[oG + i] * par[xg + i]
        if oC >= 0:
            for i in range(n):
                energy -= M * y[oC + i] * par[xg + 2 * n + i]
    return energy


@njit(cache=True)
def _ball_projection(y, par, out, work):
    n = int(par[0])
    copy_vector_into(y, out)
    put(out, 0, skew_part(mat(y, 0, n)))
    put(out, n * n, normalized(vec(y, n * n, n), 1.0))
    oG = int(par[3])
    if oG >= 0:
        put(out, oG, normalized(vec(y, oG, n), par[8]))
    project_pose(y, out, int(par[1]), int(par[2]), n, vec(par, 9 + n * n + n, n), par[5])


#: the balls' pieces, by the name their systems' ``compiled()`` declares
#: the Chaplygin ball's pieces (:data:`lieint.fast.forms.BUILTIN_PIECES`)
CHAPLYGIN = CompiledPieces(
    _chaplygin_generator, _chaplygin_action, _chaplygin_field, _chaplygin_projection, _chaplygin_work,
    energy=_chaplygin_energy,
)  # fmt: skip
#: the rolling ball's pieces (:data:`lieint.fast.forms.BUILTIN_PIECES`)
ROLLING_BALL = CompiledPieces(
    _ball_generator, _ball_action, _ball_field, _ball_projection, _ball_work, energy=_ball_energy
)
