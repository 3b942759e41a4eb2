"""Every system on SO(n) or SE(n) times a vector space with compiled pieces, as a form of the one
compiled loop (:mod:`lieint.fast.loop`; numba, cached).

A system moved by the right action of ``G = SO(n) × Rᵐ`` or ``G = SE(n) × Rᵐ`` (the heavy
top, the free body, the rolling and the Chaplygin ball, docs/theory.md §3–§5) supplies four
compiled *pieces* working on its state flattened to one float vector y — its generator,
action, vector field and projection, each given a scratch vector ``work`` of the length it
declares (the contract: :mod:`lieint.fast.pieces`). The pieces travel as one compiled record,
so the loop is compiled once per installation for every such system and a system outside the
package opts in by declaring its own pieces (:class:`lieint.fast.forms.PiecesForm`).

One RKMK step in exponential coordinates with dexp⁻¹ truncated at the method's degree, as the
generic path (:mod:`lieint.methods.rkmk`)::

    u_i = h Σ_j a_ij k_j,   k_i = Σ_{d ≤ degree} (B_d/d!) ad_{−u_i}^d ξ(ρ(exp u_i, y)),
    y ← ρ(exp(h Σ_j b_j k_j), y),

with the bracket of ``se(n) ⊕ Rᵐ``, ``[(W₁, v₁, a₁), (W₂, v₂, a₂)] = ([W₁, W₂], W₁v₂ − W₂v₁, 0)``
(the vector factor is abelian: its dexp⁻¹ is the identity) and ``exp(W, v) = (exp W, φ₁(W) v)``
(:func:`lieint.fast.skew.expm_se`). A stage whose rotation part reaches the dexp⁻¹ radius
(``θ₁ + θ₂ ≥ 2π``, the generic path's test) stops the body there. In Cayley coordinates
``k_i = dcay⁻¹_{−u_i}(ξ(ρ(cay u_i, y)))`` with the exact ``dcay⁻¹_{−u}(k) = k + ½[u, k] − ¼ uku``
and ``cay(W, x) = (M⁻¹(I + W/2), M⁻¹x)``, ``M = I − W/2``: no range limit. The stage code is
:mod:`lieint.fast.generic_step`.

The run's context is ``(pieces record, (n, nv, m, work))``: ``nv = n`` on SE(n) (0 on SO(n)),
m the size of the vector factor, ``work`` the pieces' scratch length. A step's increment (what
dense output interpolates) is ``(W, v, a) = h Σ_j b_j k_j`` flattened.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._jit import compiled_copies
from .generic_step import (
    _classical_step,
    lie_step,
    lie_step_cayley,
    lie_step_uncounted,
    move,
    move_cayley,
    move_uncounted,
    products_step,
    step_work,
)

__all__ = ["NAMESPACES"]


@njit(cache=True)
def _norm2(W):
    """``‖W‖_F²``: ``‖W‖_F ≥ θ₁ + θ₂``, the ad spectral radius of W on so(n), and on se(n) × Rᵐ
    (whose translations and vector factor add no larger eigenvalue), the step check's bound."""
    total = 0.0
    for i in range(W.shape[0]):
        for j in range(W.shape[1]):
            total += W[i, j] * W[i, j]
    return total


@njit(cache=True)
def form_prepare(ctx):
    return ctx


@njit(cache=True)
def form_scratch(fx, meth, par, d):
    """The stage slopes ``(W, v, a)`` and K of classical RK, a stage state, and the work arrays
    of :func:`lieint.fast.generic_step.step_work`."""
    dims = fx[1]
    n, nv, m, work_size = dims[0], dims[1], dims[2], dims[3]
    s = meth.b.shape[0]
    S, Sv, ua, aug, work = step_work(n, nv, m, work_size)
    return (np.zeros((s, n, n)), np.zeros((s, nv)), np.zeros((s, m)), np.zeros((s, d)), np.empty(d), S, Sv, ua, aug,
            work)  # fmt: skip


# inlined into the loop's copies, as the stage code is into it (lieint.fast.generic_step): one
# function less to compile on its own, which optimized the whole step's code once more
@njit(cache=True, inline="always")
def form_lie_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One RKMK step through the system's generator and action; ``inc`` = ``(W, v, a)`` of the
    step, ``aux[0] = ‖W‖_F²`` of ``ξ(y)`` (the first stage)."""
    pieces, dims = fx
    KW, Kv, Ka, y_stage = scr[0], scr[1], scr[2], scr[4]
    S, Sv, ua, aug, work = scr[5], scr[6], scr[7], scr[8], scr[9]
    n, nv = dims[0], dims[1]
    gen = pieces.generator
    act = pieces.action
    ok = lie_step(
        gen, act, y, par, nv, meth.A, meth.b, h, meth.coeffs, KW, Kv, Ka, y_stage, y1, S, Sv, ua, aug, work
    )  # fmt: skip
    if not ok:
        return -1
    # the step's increment: what `move` left in the combination arrays (u of the last move)
    uW, uv = S[0], Sv[0]
    j = 0
    for a in range(n):
        for c in range(n):
            inc[j] = uW[a, c]
            j += 1
    for a in range(nv):
        inc[j] = uv[a]
        j += 1
    for a in range(ua.shape[0]):
        inc[j] = ua[a]
        j += 1
    aux[0] = _norm2(KW[0])
    return meth.b.shape[0]


@njit(cache=True)
def form_products_scratch(fx, meth, par, d):
    """The stage generators ``(W, v, a)``, two states (a stage's, the action's result) and the
    work arrays of :func:`lieint.fast.generic_step.step_work`."""
    dims = fx[1]
    n, nv, m, work_size = dims[0], dims[1], dims[2], dims[3]
    s = meth.c.shape[0]
    S, Sv, ua, aug, work = step_work(n, nv, m, work_size)
    return (np.zeros((s, n, n)), np.zeros((s, nv)), np.zeros((s, m)), np.empty(d), np.empty(d), S, Sv, ua, aug, work)


@njit(cache=True)
def form_products_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One step of a product of exponentials through the system's generator and action
    (:func:`lieint.fast.generic_step.products_step`); ``inc`` = the step's exponents,
    ``aux[0] = ‖W‖_F²`` of ``ξ(y)`` (the first stage)."""
    pieces, dims = fx
    gen = pieces.generator
    act = pieces.action
    products_step(
        gen, act, y, par, dims[1], meth.weights, meth.bounds, h, scr[0], scr[1], scr[2], scr[3], scr[4], y1, scr[5],
        scr[6], scr[7], scr[8], scr[9], inc,
    )  # fmt: skip
    aux[0] = _norm2(scr[0][0])
    return meth.c.shape[0]


@njit(cache=True)
def form_rk_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One classical RK step on the flattened state."""
    pieces = fx[0]
    field = pieces.vector_field
    _classical_step(field, y, par, meth.A, meth.b, h, scr[3], scr[4], y1, scr[9])
    return meth.b.shape[0]


@njit(cache=True)
def form_embedded(fx, y, par, meth, weights, h, yh, scr):
    pieces, dims = fx
    act = pieces.action
    move(act, y, par, dims[1], scr[0], scr[1], scr[2], weights, h, yh, scr[5], scr[6], scr[7], scr[8], scr[9])


@njit(cache=True)
def form_error_sum(fx, y0, y1, yh, par, rtol, atol, scr):
    """``Σ_i ((y₁ − ŷ)_i / (atol + rtol·max(|y₀,i|, |y₁,i|)))²`` (the flat state is the user's)."""
    total = 0.0
    for i in range(y0.shape[0]):
        x = (y1[i] - yh[i]) / (atol + rtol * max(abs(y0[i]), abs(y1[i])))
        total += x * x
    return total


@njit(cache=True)
def form_project(fx, y, par, out, scr):
    pieces = fx[0]
    proj = pieces.projection
    proj(y, par, out, scr[9])


@njit(cache=True)
def form_radius2(fx, y, par, scr):
    pieces = fx[0]
    gen = pieces.generator
    KW, Kv, Ka = scr[0], scr[1], scr[2]
    gen(y, par, KW[0], Kv[0], Ka[0], scr[9])
    return _norm2(KW[0])


@njit(cache=True)
def form_user_field(fx, yu, par, fu, scr):
    pieces = fx[0]
    field = pieces.vector_field
    field(yu, par, fu, scr[9])


#: the step and the embedded solution without reference counts, for exponential coordinates at
#: n = 3 and Cayley coordinates at every n, where the coordinate map allocates nothing (each view
#: of a stage and each call counted references: ~100 atomic operations a step, 18 % of a 3D heavy
#: top's RKMK6 run); a family per coordinates (their stage code differs at compile time:
#: :mod:`lieint.fast.generic_step`), so that a run compiles the one copy it uses
_UNCOUNTED = compiled_copies(
    [form_lie_step, form_embedded], {"lie_step": lie_step_uncounted, "move": move_uncounted}, "_uncounted"
)
_CAYLEY = compiled_copies([form_lie_step, form_embedded], {"lie_step": lie_step_cayley, "move": move_cayley}, "_cayley")

_COMMON = {
    "prepare": form_prepare,
    "scratch": form_scratch,
    "error_sum": form_error_sum,
    "project": form_project,
    "radius2": form_radius2,
    "user_field": form_user_field,
}
#: the names of :mod:`lieint.fast.loop` this form binds, per method family ("rkmk": RKMK in
#: exponential coordinates, "rkmk_uncounted": the same at n = 3, "rkmk_cayley": in Cayley
#: coordinates)
NAMESPACES = {
    "rkmk": {**_COMMON, "step": form_lie_step, "embedded": form_embedded},
    "rkmk_uncounted": {**_COMMON, "step": _UNCOUNTED["form_lie_step"], "embedded": _UNCOUNTED["form_embedded"]},
    "rkmk_cayley": {**_COMMON, "step": _CAYLEY["form_lie_step"], "embedded": _CAYLEY["form_embedded"]},
    "rk": {**_COMMON, "step": form_rk_step, "embedded": form_embedded},
    # products of exponentials (no pairs: the embedded solution and the error norm never compile)
    "cf": {**_COMMON, "scratch": form_products_scratch, "step": form_products_step, "embedded": form_embedded},
}
