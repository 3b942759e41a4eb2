"""One step of the generic compiled loop (:mod:`lieint.fast.generic`): RKMK on
``SO(n)/SE(n) × Rᵐ`` through a system's compiled pieces, and classical RK on its flattened
state (numba, cached on disk).

:func:`lie_step` and :func:`move` take their work arrays from :func:`step_work` (allocated once
per run and thread). Their coordinates are a compile-time constant, not an argument: the module's
globals :data:`CAYLEY` and ``coordinate_map`` (numba freezes a global when it compiles a
function, and drops the branches a constant decides before typing them), bound per copy —
:func:`lie_step` and :func:`move` in exponential coordinates, :data:`lie_step_uncounted` and
:data:`move_uncounted` in exponential coordinates at n = 3 and :data:`lie_step_cayley` and
:data:`move_cayley` in Cayley coordinates at every n, both without reference counts (the form's
``rkmk``, ``rkmk_uncounted`` and ``rkmk_cayley`` families, :mod:`lieint.fast.generic`). With
the coordinates a run-time flag, a run in exponential coordinates compiled the Cayley map and
dcay⁻¹ too, in the step and again in each function that links it (3.6 of a cold 4D heavy top's
22.4 s of CPU time). The algebra is :mod:`lieint.fast.se_algebra`'s.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._jit import NO_REFCOUNT, compiled_copies
from .se_algebra import cayley_map, dcayinv, dexpinv, exp_map, exp_map_3, exp_map_n, out_of_range, out_of_range_3

__all__ = [
    "lie_step",
    "lie_step_cayley",
    "lie_step_uncounted",
    "move",
    "move_cayley",
    "move_uncounted",
    "products_step",
    "step_work",
]

#: whether :func:`lie_step` and :func:`move` step in Cayley coordinates: a compile-time constant,
#: rebound in their copies (never read at run time)
CAYLEY = False
#: φ of :func:`lie_step` and :func:`move` (:mod:`lieint.fast.se_algebra`'s maps), rebound with
#: :data:`CAYLEY` in their copies; the exponential at n ≠ 3 here (n = 3 runs the copy with the
#: closed forms, :data:`lie_step_uncounted`)
coordinate_map = exp_map_n


@njit(cache=True, **NO_REFCOUNT)
def _combine(out, K, weights, upto, h):
    """``out = Σ_{j < upto} (h w_j) K[j]`` over the nonzero weights (zero if none), on flat
    views (out of shape (size,), K of shape (stages, size)); returns whether any weight was
    nonzero."""
    size = out.shape[0]
    for i in range(size):
        out[i] = 0.0
    any_weight = False
    for j in range(upto):
        if weights[j] != 0.0:
            any_weight = True
            w = h * weights[j]
            for i in range(size):
                out[i] += w * K[j, i]
    return any_weight


@njit(cache=True)
def step_work(n, nv, m, work_size):
    """The work arrays of :func:`lie_step` and :func:`move`, allocated once per run and thread:
    ``S`` (5, n, n) for ``uW, Q, tW, P`` and dcay⁻¹'s result, ``Sv`` (4, nv) for
    ``uv, t, tv, nw``, ``ua`` (m,), ``aug`` (n, 2n + 1) for the Cayley map's elimination, and
    the pieces' ``work`` (``work_size``,)."""
    return np.empty((5, n, n)), np.empty((4, nv)), np.empty(m), np.empty((n, 2 * n + 1)), np.empty(work_size)


# lie_step and move are inlined into their callers (numba's inlining, before typing), form_lie_step
# and the embedded solution: a function compiled on its own optimizes once more all the code it
# links (its callees'), so each level of calls cost a cold run that again (with form_lie_step,
# 2 s of a cold 4D heavy top's CPU time). Their copies without reference counts are called, not
# inlined: an inlined body counts references as its caller does.
@njit(cache=True, inline="always")
def lie_step(gen, act, y, par, nv, tab, b, h, coeffs, KW, Kv, Ka, y_stage, y1, S, Sv, ua, aug, work):
    """One RKMK step from y into ``y1`` in exponential (dexp⁻¹ truncated at ``coeffs``) or, in
    the copies with :data:`CAYLEY`, Cayley coordinates (exact dcay⁻¹); False when a stage leaves
    the dexp⁻¹ radius.
    ``S, Sv, ua, aug, work``: :func:`step_work`'s arrays (nothing is allocated here)."""
    s = b.shape[0]
    n = KW.shape[1]
    uW, Q, tW, P, new = S[0], S[1], S[2], S[3], S[4]
    uv, t, tv, nw = Sv[0], Sv[1], Sv[2], Sv[3]
    uW_flat, KW_flat = uW.reshape(n * n), KW.reshape(KW.shape[0], n * n)
    for i in range(s):
        row = tab[i]
        _combine(uW_flat, KW_flat, row, i, h)
        _combine(uv, Kv, row, i, h)
        kW, kv, ka = KW[i], Kv[i], Ka[i]
        if not _combine(ua, Ka, row, i, h):
            gen(y, par, kW, kv, ka, work)  # u = 0: k_i = ξ(y)
            continue
        if not CAYLEY and out_of_range(uW, nv):
            return False
        coordinate_map(uW, uv, nv, Q, t, aug)
        act(Q, t, ua, y, par, y_stage, work)
        gen(y_stage, par, kW, kv, ka, work)
        if CAYLEY:
            dcayinv(uW, uv, kW, kv, tW, tv, new)
        else:
            dexpinv(uW, uv, kW, kv, coeffs, tW, tv, P, nw)
    move(act, y, par, nv, KW, Kv, Ka, b, h, y1, S, Sv, ua, aug, work)
    return True


@njit(cache=True)
def products_step(gen, act, y, par, nv, weights, bounds, h, KW, Kv, Ka, y_stage, y_next, y1, S, Sv, ua, aug, work,
                  inc):  # fmt: skip
    """One step of a product of exponentials (:class:`lieint.fast.forms.ExpProductForm`) from y
    into ``y1``: stage i moves a copy of y by its exponentials one after the other and evaluates
    ξ there, the step moves y by its own; ``inc`` receives the step's exponents ``(W, v, a)``
    flattened, one after another. ``y_stage`` and ``y_next`` hold states (the action writes
    into a state of its own); ``S, Sv, ua, aug, work``: :func:`step_work`'s arrays (nothing is
    allocated here). No dexp⁻¹: never out of range."""
    s = bounds.shape[0] - 2
    n = KW.shape[1]
    d = y.shape[0]
    uW, Q = S[0], S[1]
    uv, t = Sv[0], Sv[1]
    m = ua.shape[0]
    uW_flat, KW_flat = uW.reshape(n * n), KW.reshape(KW.shape[0], n * n)
    for i in range(s):
        for j in range(d):
            y_stage[j] = y[j]
        for e in range(bounds[i], bounds[i + 1]):
            row = weights[e]
            _combine(uW_flat, KW_flat, row, i, h)
            _combine(uv, Kv, row, i, h)
            if not _combine(ua, Ka, row, i, h):
                continue
            exp_map(uW, uv, nv, Q, t, aug)
            act(Q, t, ua, y_stage, par, y_next, work)
            for j in range(d):
                y_stage[j] = y_next[j]
        gen(y_stage, par, KW[i], Kv[i], Ka[i], work)
    for j in range(d):
        y1[j] = y[j]
    first = bounds[s]
    size = n * n + nv + m
    for e in range(first, bounds[s + 1]):
        row = weights[e]
        _combine(uW_flat, KW_flat, row, s, h)
        _combine(uv, Kv, row, s, h)
        nonzero = _combine(ua, Ka, row, s, h)
        o = size * (e - first)
        for j in range(n * n):
            inc[o + j] = uW_flat[j]
        for j in range(nv):
            inc[o + n * n + j] = uv[j]
        for j in range(m):
            inc[o + n * n + nv + j] = ua[j]
        if not nonzero:
            continue
        exp_map(uW, uv, nv, Q, t, aug)
        act(Q, t, ua, y1, par, y_next, work)
        for j in range(d):
            y1[j] = y_next[j]


@njit(cache=True, inline="always")  # inlined, as lie_step (see there)
def move(act, y, par, nv, KW, Kv, Ka, w, h, out, S, Sv, ua, aug, work):
    """``out = ρ(φ(h Σ_j w_j k_j), y)``: the step's new state (weights b) or an embedded
    solution (weights b̂), in :func:`step_work`'s arrays (φ: ``coordinate_map``)."""
    n = KW.shape[1]
    uW, Q = S[0], S[1]
    uv, t = Sv[0], Sv[1]
    s = w.shape[0]
    _combine(uW.reshape(n * n), KW.reshape(KW.shape[0], n * n), w, s, h)
    _combine(uv, Kv, w, s, h)
    _combine(ua, Ka, w, s, h)
    coordinate_map(uW, uv, nv, Q, t, aug)
    act(Q, t, ua, y, par, out, work)


# The copies without reference counts, for exponential coordinates at n = 3 and Cayley
# coordinates at every n, where the coordinate map and the range test allocate nothing: each view
# of a stage and each call counted references (two atomic operations an array), ~100 a step, 18 %
# of a 3D heavy top's RKMK6 run. One copy per coordinates, so that each compiles its own only.
_UNCOUNTED = compiled_copies(
    [lie_step, move],
    {"coordinate_map": exp_map_3, "out_of_range": out_of_range_3},
    "_uncounted",
    **NO_REFCOUNT,
)
#: :func:`lie_step` and :func:`move` in exponential coordinates at n = 3, without reference counts
lie_step_uncounted, move_uncounted = _UNCOUNTED["lie_step"], _UNCOUNTED["move"]
_CAYLEY = compiled_copies([lie_step, move], {"coordinate_map": cayley_map, "CAYLEY": True}, "_cayley", **NO_REFCOUNT)
#: :func:`lie_step` and :func:`move` in Cayley coordinates (any n), without reference counts
lie_step_cayley, move_cayley = _CAYLEY["lie_step"], _CAYLEY["move"]


@njit(cache=True)
def _classical_step(field, y, par, tab, b, h, K, y_stage, y1, work):
    """One classical RK step on the flattened state: ``y1 = y + h Σ_j b_j K_j``."""
    s = b.shape[0]
    for i in range(s):
        _combine(y_stage, K, tab[i], i, h)
        y_stage += y
        field(y_stage, par, K[i], work)
    _combine(y1, K, b, s, h)
    y1 += y
