"""Compiled pieces of the built-in systems on SO(n)/SE(n) × Rᵐ, for :mod:`lieint.fast.generic`.

Each system's ``compiled()`` names its pieces (``"pieces": "heavy_top"``) and packs its
parameters into one float vector whose first entries are ``n`` and the offsets of its fields
in the flattened state; these functions read that layout. The equations are the generic
path's (docs/theory.md §3–§5):

* Euler top, ``Q·(A, R) = (QᵀAQ, RQ)``, ``ξ = Ω(A)`` (its adaptive pairs for n ≥ 4);
* heavy top, ``(Q, v)·(A, Γ, R) = (Qᵀ(A + v∧Γ)Q, QᵀΓ, RQ)``, ``ξ = (Ω(A), M X_G)``;
* free body, ``(Q, p, w)·(A, R, q, v) = (QᵀAQ, RQ, q + p, v + w)``, ``ξ = (Ω(A), v, g)``;
* the energies of the heavy top and the free body, ``T − M⟨Γ, X_G⟩`` and ``T + ½M|v|² − M⟨g, q⟩``
  with ``T = −¼⟨Ω, A⟩`` (the energy-keeping pairs);
* the Chaplygin ball and the rolling ball: :mod:`lieint.fast.balls`.

The pieces are compiled lazily, for the signatures of :mod:`lieint.fast.pieces`, when a run of
their system first needs them (:class:`lieint.fast.pieces.CompiledPieces`), so a run of one
system never compiles another's. Every Ω is made exactly skew. The flattened state's readers and
writers and the shared small linear algebra are in :mod:`lieint.fast.flat`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._jit import NO_REFCOUNT
from .flat import (
    conj_flat_into,
    mat,
    normalized,
    project_pose,
    put,
    rotate_back_into,
    skew_part,
    times_into,
    vec,
    wedge,
)
from .pieces import CompiledPieces
from .products import copy_vector_into, mv
from .products import mm_loops as mm

__all__ = ["EULER_TOP", "FREE_BODY", "HEAVY_TOP"]

# -- the rigid body with constant B: heavy top and free body ------------------------------------
# params: n, oR, ident, P (n²), M = −1/(b_i + b_j) (n², 0 on the diagonal), then the system's own


@njit(cache=True, **NO_REFCOUNT)
def _omega_into(y, par, W, work):
    """``W = Ω(A)`` for the momentum A stored first in y: ``Ω_ij = −Ã_ij/(b_i + b_j)`` in the
    eigenbasis P of B (``Ã = PᵀAP``, ``Ω = P Ω̃ Pᵀ``), made exactly skew; 2n² of ``work``."""
    n = W.shape[0]
    nn = n * n
    m = 3 + nn  # M = −1/(b_i + b_j) in par
    if par[2] != 0.0:  # diagonal B: Ω_ij = −A_ij/(b_i + b_j), made exactly skew
        for i in range(n):
            for j in range(n):
                W[i, j] = 0.5 * (y[i * n + j] * par[m + i * n + j] - y[j * n + i] * par[m + j * n + i])
        return
    # on the flat state and parameters where they lie: reshaped views and the strided products
    # (products.mm_unrolled_into on P.T) made the 3D heavy top's RKMK6 step 18 % slower
    T, U = work[:nn], work[nn : 2 * nn]
    for i in range(n):  # T = A P
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += y[i * n + k] * par[3 + k * n + j]
            T[i * n + j] = acc
    for i in range(n):  # U = (PᵀAP) ∘ M
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += par[3 + k * n + i] * T[k * n + j]
            U[i * n + j] = acc * par[m + i * n + j]
    for i in range(n):  # T = U Pᵀ
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += U[i * n + k] * par[3 + j * n + k]
            T[i * n + j] = acc
    for i in range(n):  # U = P T
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += par[3 + i * n + k] * T[k * n + j]
            U[i * n + j] = acc
    for i in range(n):
        for j in range(n):
            W[i, j] = 0.5 * (U[i * n + j] - U[j * n + i])


@njit(cache=True)
def _omega(y, par, n, work):
    """:func:`_omega_into` into a new matrix (the vector fields)."""
    W = np.empty((n, n))
    _omega_into(y, par, W, work)
    return W


@njit(cache=True, **NO_REFCOUNT)
def _conj_skew_into(Q, y, out, work):
    """``out[: n²] = skew(QᵀAQ)`` for the momentum A stored first in y (the Euler top's action,
    made exactly skew as the generic one); n² of ``work``."""
    n = Q.shape[0]
    conj_flat_into(Q, y, 0, out, 0, work)
    for i in range(n):
        for j in range(i, n):
            d = 0.5 * (out[i * n + j] - out[j * n + i])
            out[i * n + j] = d
            out[j * n + i] = -d


def _body_work(n: int) -> int:
    """Two n × n temporaries, and Ω for the energy."""
    return 3 * n * n


@njit(cache=True)
def _rotational_energy(y, par, work):
    """``T = ¼ tr(ΩA) = −¼ ⟨Ω, A⟩`` of the momentum A stored first in y (the generic path's
    :meth:`lieint.systems.rigid.InertiaOperator.energy`); Ω in the third n² of ``work``."""
    n = int(par[0])
    nn = n * n
    W = work[2 * nn : 3 * nn].reshape((n, n))
    _omega_into(y, par, W, work)
    total = 0.0
    for i in range(n):
        for j in range(n):
            total += W[i, j] * y[i * n + j]
    return -0.25 * total


# Euler top (its adaptive pairs for n ≥ 4): fields A, [R]; no own params
@njit(cache=True, **NO_REFCOUNT)
def _top_generator(y, par, W, v, a, work):
    _omega_into(y, par, W, work)


@njit(cache=True, **NO_REFCOUNT)
def _top_action(Q, t, a, y, par, out, work):
    _conj_skew_into(Q, y, out, work)
    oR = int(par[1])
    if oR >= 0:
        times_into(y, oR, Q, out)


@njit(cache=True)
def _top_field(y, par, out, work):
    n = int(par[0])
    A = mat(y, 0, n)
    Om = _omega(y, par, n, work)
    put(out, 0, mm(A, Om) - mm(Om, A))
    oR = int(par[1])
    if oR >= 0:
        put(out, oR, mm(mat(y, oR, n), Om))


@njit(cache=True)
def _top_projection(y, par, out, work):
    n = int(par[0])
    copy_vector_into(y, out)
    put(out, 0, skew_part(mat(y, 0, n)))
    project_pose(y, out, int(par[1]), -1, n, np.empty(0), 0.0)


# heavy top: fields A, Gamma, [R]; own params M X_G (n), |g|
@njit(cache=True, **NO_REFCOUNT)
def _heavy_generator(y, par, W, v, a, work):
    n = W.shape[0]
    _omega_into(y, par, W, work)
    for i in range(n):
        v[i] = par[3 + 2 * n * n + i]


@njit(cache=True, **NO_REFCOUNT)
def _heavy_action(Q, t, a, y, par, out, work):
    n = Q.shape[0]
    nn = n * n
    C = work[:nn]  # A + t ∧ Γ
    for i in range(n):
        for j in range(n):
            C[i * n + j] = y[i * n + j] + t[i] * y[nn + j] - y[nn + i] * t[j]
    conj_flat_into(Q, C, 0, out, 0, work[nn : 2 * nn])
    rotate_back_into(Q, y, nn, out, nn)
    oR = int(par[1])
    if oR >= 0:
        times_into(y, oR, Q, out)


@njit(cache=True)
def _heavy_field(y, par, out, work):
    n = int(par[0])
    A, G = mat(y, 0, n), vec(y, n * n, n)
    Om = _omega(y, par, n, work)
    MXG = vec(par, 3 + 2 * n * n, n)
    put(out, 0, mm(A, Om) - mm(Om, A) + wedge(MXG, G))
    put(out, n * n, -mv(Om, G))
    oR = int(par[1])
    if oR >= 0:
        put(out, oR, mm(mat(y, oR, n), Om))


@njit(cache=True)
def _heavy_energy(y, par, work):
    """``H = T − M⟨Γ, X_G⟩``."""
    n = int(par[0])
    potential = 0.0
    for i in range(n):
        potential += y[n * n + i] * par[3 + 2 * n * n + i]
    return _rotational_energy(y, par, work) - potential


@njit(cache=True)
def _heavy_projection(y, par, out, work):
    n = int(par[0])
    put(out, 0, skew_part(mat(y, 0, n)))
    put(out, n * n, normalized(vec(y, n * n, n), par[3 + 2 * n * n + n]))
    project_pose(y, out, int(par[1]), -1, n, np.empty(0), 0.0)


# free body: fields A, [R], center, velocity; own params oC, g (n), M
@njit(cache=True, **NO_REFCOUNT)
def _free_generator(y, par, W, v, a, work):
    n = W.shape[0]
    _omega_into(y, par, W, work)
    oC = int(par[3 + 2 * n * n])
    for i in range(n):
        a[i] = y[oC + n + i]
        a[n + i] = par[4 + 2 * n * n + i]


@njit(cache=True, **NO_REFCOUNT)
def _free_action(Q, t, a, y, par, out, work):
    n = Q.shape[0]
    _conj_skew_into(Q, y, out, work)
    oR, oC = int(par[1]), int(par[3 + 2 * n * n])
    if oR >= 0:
        times_into(y, oR, Q, out)
    for i in range(2 * n):
        out[oC + i] = y[oC + i] + a[i]


@njit(cache=True)
def _free_field(y, par, out, work):
    n = int(par[0])
    A = mat(y, 0, n)
    Om = _omega(y, par, n, work)
    put(out, 0, mm(A, Om) - mm(Om, A))
    oR, oC = int(par[1]), int(par[3 + 2 * n * n])
    if oR >= 0:
        put(out, oR, mm(mat(y, oR, n), Om))
    for i in range(n):
        out[oC + i] = y[oC + n + i]
        out[oC + n + i] = par[4 + 2 * n * n + i]


@njit(cache=True)
def _free_energy(y, par, work):
    """``T_rot + ½M|v|² − M⟨g, q⟩``."""
    n = int(par[0])
    oC, mass = int(par[3 + 2 * n * n]), par[4 + 2 * n * n + n]
    kinetic, potential = 0.0, 0.0
    for i in range(n):
        v = y[oC + n + i]
        kinetic += v * v
        potential += y[oC + i] * par[4 + 2 * n * n + i]
    return _rotational_energy(y, par, work) + 0.5 * mass * kinetic - mass * potential


@njit(cache=True)
def _free_projection(y, par, out, work):
    n = int(par[0])
    copy_vector_into(y, out)
    put(out, 0, skew_part(mat(y, 0, n)))
    project_pose(y, out, int(par[1]), -1, n, np.empty(0), 0.0)


#: the Euler top's pieces (its Cayley coordinates in 3D; :data:`lieint.fast.forms.BUILTIN_PIECES`)
EULER_TOP = CompiledPieces(_top_generator, _top_action, _top_field, _top_projection, _body_work)
#: the heavy top's pieces
HEAVY_TOP = CompiledPieces(
    _heavy_generator, _heavy_action, _heavy_field, _heavy_projection, _body_work, energy=_heavy_energy
)
#: the free body's pieces
FREE_BODY = CompiledPieces(
    _free_generator, _free_action, _free_field, _free_projection, _body_work, energy=_free_energy
)
