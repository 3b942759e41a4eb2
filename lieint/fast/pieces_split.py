"""The splittings of the free and the heavy top into exact flows, through the systems' compiled
pieces, as a form of the one compiled loop (every n; the free 3D top has its own,
:mod:`lieint.fast.top3_split`).

``splitting2/4/6`` (:mod:`lieint.methods.splitting`, ``free="rotations"``) in the numpy path's
order: each basic step is Strang's (the heavy top: the gravity kick over τ/2, the free part over
τ, the kick over τ/2), the free part the plane rotations
``T₁(τ/2) … T_{m−1}(τ/2) T_m(τ) T_{m−1}(τ/2) … T₁(τ/2)``. The piece of the plane ``(i, j)`` of
the principal frame (``B = P diag(b) Pᵀ``, ``Ã = PᵀAP``) is the group action of
``Q = P exp(θ e_i∧e_j) Pᵀ``, ``θ = −τ Ã_ij/(b_i + b_j)``; the kick ``A ↦ A + τ M X_G ∧ Γ`` is the
SE(n) action of ``(I, τ M X_G)``. Both go through the pieces' ``action``, so each piece moves the
state exactly as the numpy path's ``system.act`` does. Dense output gets each step's element from
the states, as on the numpy path (``system.relative_element``).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .generic import form_embedded, form_error_sum, form_prepare
from .pieces_maps import form_project, form_radius2, form_user_field, scratch_head

__all__ = ["NAMESPACES", "PiecesSplittingNumbers", "numbers"]

#: the Strang steps' fractions of h, the planes ``(i, j)`` of one free part in its order with
#: their fractions of τ (½ but the middle one's 1), the principal frame P and moments b,
#: ``M X_G`` (zeros and ``heavy`` False for the free top), and ``cayley`` (False; read by the
#: loop's observer as a tableau's)
PiecesSplittingNumbers = namedtuple("PiecesSplittingNumbers", "substeps planes halves P b MXG heavy cayley")
#: a step reports no increment: dense output takes each step's element from its two states
INCREMENT = False


def numbers(form, layout) -> PiecesSplittingNumbers:
    """The numbers of a splitting :class:`~lieint.fast.forms.MapForm` for a top's compiled pieces:
    its planes (the method's split for n = 3, lexicographic otherwise: a split names three axes)
    unrolled into one free part, the top's principal frame and moments, ``M X_G``."""
    system = layout.system
    inertia = system.inertia
    n = int(inertia.n)
    planes = [tuple(int(v) for v in p) for p in form.planes] if n == 3 else [
        (i, j) for i in range(n) for j in range(i + 1, n)
    ]  # fmt: skip
    order = planes[:-1] + [planes[-1]] + planes[-2::-1]
    halves = [0.5] * (len(planes) - 1) + [1.0] + [0.5] * (len(planes) - 1)
    heavy = "heavy_top" in system.structure
    MXG = system.mass * np.asarray(system.center_of_mass, dtype=float) if heavy else np.zeros(n)
    return PiecesSplittingNumbers(
        np.array(form.substeps, dtype=float), np.array(order, dtype=np.int64), np.array(halves),
        np.ascontiguousarray(inertia.P, dtype=float), np.ascontiguousarray(inertia.b, dtype=float),
        np.ascontiguousarray(MXG), bool(heavy), False,
    )  # fmt: skip


@njit(cache=True)
def form_scratch(fx, meth, par, d):
    """:func:`lieint.fast.pieces_maps.scratch_head`'s arrays, a group element ``(Q, t, a)`` and the
    action's result."""
    work, W, v, a = scratch_head(fx)
    n = W.shape[0]
    return work, W, v, a, np.empty((n, n)), np.zeros(v.shape[0]), np.zeros(a.shape[0]), np.empty(d)


@njit(cache=True, inline="always")
def _act(act, Q, t, a, y, par, out, work):
    """``y ← ρ((Q, t, a), y)`` through ``out``."""
    act(Q, t, a, y, par, out, work)
    for i in range(y.shape[0]):
        y[i] = out[i]


@njit(cache=True, inline="always")
def _kick(act, meth, tau, Q, t, a, y, par, out, work):
    """The gravity kick over τ: the SE(n) action of ``(I, τ M X_G)``."""
    n = Q.shape[0]
    for r in range(n):
        for c in range(n):
            Q[r, c] = 1.0 if r == c else 0.0
        t[r] = tau * meth.MXG[r]
    _act(act, Q, t, a, y, par, out, work)
    for r in range(n):
        t[r] = 0.0


@njit(cache=True, inline="always")
def _rotate(act, meth, i, j, tau, Q, t, a, y, par, out, work):
    """The exact flow of ``T_ij`` over τ: the action of ``Q = P exp(θ e_i∧e_j) Pᵀ``,
    ``θ = −τ Ã_ij/(b_i + b_j)``, ``Ã_ij = (PᵀAP)_ij`` (A the state's first n² entries)."""
    P = meth.P
    n = Q.shape[0]
    a_ij = 0.0
    for k in range(n):
        row = 0.0
        for m in range(n):
            row += y[k * n + m] * P[m, j]
        a_ij += P[k, i] * row
    theta = -tau * a_ij / (meth.b[i] + meth.b[j])
    c, s = np.cos(theta), np.sin(theta)
    # P exp(θ e_i∧e_j) Pᵀ = I + (c − 1)(p_i p_iᵀ + p_j p_jᵀ) + s (p_i p_jᵀ − p_j p_iᵀ), p_k column k of P
    for r in range(n):
        for q in range(n):
            pi_r, pj_r, pi_q, pj_q = P[r, i], P[r, j], P[q, i], P[q, j]
            identity = 1.0 if r == q else 0.0
            Q[r, q] = identity + (c - 1.0) * (pi_r * pi_q + pj_r * pj_q) + s * (pi_r * pj_q - pj_r * pi_q)
    _act(act, Q, t, a, y, par, out, work)


@njit(cache=True)
def form_split_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One step of one body (``y1``); returns the Strang steps spent (the numpy path's count)."""
    act = fx[0].action
    work, Q, t, a, out = scr[0], scr[4], scr[5], scr[6], scr[7]
    for i in range(y.shape[0]):
        y1[i] = y[i]
    planes, halves = meth.planes, meth.halves
    for sub in range(meth.substeps.shape[0]):
        tau = h * meth.substeps[sub]
        if meth.heavy:
            _kick(act, meth, 0.5 * tau, Q, t, a, y1, par, out, work)
        for row in range(planes.shape[0]):
            _rotate(act, meth, planes[row, 0], planes[row, 1], halves[row] * tau, Q, t, a, y1, par, out, work)
        if meth.heavy:
            _kick(act, meth, 0.5 * tau, Q, t, a, y1, par, out, work)
    return meth.substeps.shape[0]


#: the names of :mod:`lieint.fast.loop` this form binds (fixed steps only)
NAMESPACES = {
    "splitting": {
        "prepare": form_prepare,
        "scratch": form_scratch,
        "step": form_split_step,
        "embedded": form_embedded,
        "error_sum": form_error_sum,
        "project": form_project,
        "radius2": form_radius2,
        "user_field": form_user_field,
    }
}
