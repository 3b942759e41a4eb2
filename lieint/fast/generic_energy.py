"""The energy-keeping pairs (:mod:`lieint.methods.energy_projection`) on systems with compiled
pieces (:mod:`lieint.fast.generic`; numba, cached on disk): the heavy top, the free body, the
balls, and any system whose pieces declare an ``energy`` (:mod:`lieint.fast.pieces`).

State of one body: the system's fields flattened (the plain form's layout), then the level H₀
every accepted step ends on — it travels with the state, so a run split into calls keeps the
level of its start. A step is the pair's RKMK step (exponential or Cayley coordinates, the plain
form's stage code), then the move along the group orbit onto H₀, the generic path's rule
(:meth:`lieint.methods.energy_projection.EnergyProjected.onto_level`) for one body::

    y₁ ← ρ(exp(s η), y₁),   η = Σ_i ∂_i H e_i,   ∂_i H = (H(ρ(g_i⁺, y₁)) − H(ρ(g_i⁻, y₁)))/(2ε),

with ``g_i^± = exp(±ε e_i)`` over the basis ``e_i`` of the group's algebra (the generic path's
:func:`lieint.methods.energy_projection.algebra_basis`, ε = 1e-6: the same central differences,
the group elements worked out once per run in Python), one Newton step and secant steps for s,
the same band, move limit and acceptance. The error estimate is the pair's own difference: the
embedded solution is moved by the same amount (``y₁ − ŷ`` is the pair's, as on the generic path).

These pieces' systems declare no commuting part of their generator (only the free Euler top
does, whose energy pairs run on :mod:`lieint.fast.top3` and :mod:`lieint.fast.topn`).

The run's context is the plain form's ``(pieces, dims)`` (dims with dim 𝔤 appended) and the
orbit's numbers in one flat array (:func:`_orbit`: typing one array a call is cheaper than six):
the basis elements ``(W, v, a)`` (dim 𝔤 of each) and the group elements ``g_i^±`` as
``(Q, t, a)`` (2, dim 𝔤, …).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._jit import compiled_copies
from .generic import NAMESPACES as PLAIN
from .generic import form_embedded, form_lie_step, form_scratch
from .generic_step import lie_step_cayley, lie_step_uncounted, move_cayley, move_uncounted
from .se_algebra import exp_map

__all__ = ["EPSILON", "NAMESPACES"]

#: the central differences' step (:data:`lieint.methods.energy_projection._EPSILON`)
EPSILON = 1e-6
#: :data:`lieint.methods.energy_projection.LEVEL_ULPS` · ε (the generic path's level band)
_LEVEL = 64 * 2.220446049250313e-16
#: the largest orbit move accepted and the secant iterations (the generic path's)
_MAX_MOVE = 1e-3
_ITERATIONS = 4


@njit(cache=True, inline="always")
def _orbit(fx):
    """The views ``(basis_W, basis_v, basis_a, Q, t, a)`` of the context's flat orbit numbers."""
    dims, flat = fx[1], fx[2]
    n, nv, m, dim = dims[0], dims[1], dims[2], dims[4]
    sizes = (dim * n * n, dim * nv, dim * m, 2 * dim * n * n, 2 * dim * nv, 2 * dim * m)
    o0 = 0
    o1 = o0 + sizes[0]
    o2 = o1 + sizes[1]
    o3 = o2 + sizes[2]
    o4 = o3 + sizes[3]
    o5 = o4 + sizes[4]
    return (
        flat[o0:o1].reshape((dim, n, n)), flat[o1:o2].reshape((dim, nv)), flat[o2:o3].reshape((dim, m)),
        flat[o3:o4].reshape((2, dim, n, n)), flat[o4:o5].reshape((2, dim, nv)),
        flat[o5 : o5 + sizes[5]].reshape((2, dim, m)),
    )  # fmt: skip


@njit(cache=True)
def form_energy_scratch(fx, meth, par, d):
    """The plain form's arrays for the fields (``d − 1``: the level is not a field), then the
    move onto the level (d − 1: added to the embedded solutions), a trial state (d − 1), the
    orbit gradient (dim 𝔤), η and the move's ``(W, v, a)``, its group element ``(Q, t)`` and
    the Cayley elimination's array the exponential does not use."""
    pieces, dims = fx[0], fx[1]
    n, nv, m, dim = dims[0], dims[1], dims[2], dims[4]
    f = d - 1
    return form_scratch((pieces, dims), meth, par, f) + (
        np.zeros(f), np.zeros(f), np.zeros(dim), np.zeros((n, n)), np.zeros(nv), np.zeros(m), np.zeros((n, n)),
        np.zeros(nv), np.zeros(m), np.zeros((n, n)), np.zeros(nv), np.zeros((n, 2 * n + 1)),
    )  # fmt: skip


@njit(cache=True)
def _gap(fx, y, par, s, level0, scr):
    """``H(ρ(exp(s η), y)) − H₀``; the state ρ(exp(sη), y) is left in the trial array."""
    pieces, dims = fx[0], fx[1]
    nv = dims[1]
    work, trial = scr[9], scr[11]
    etaW, etav, etaa, uW, uv, ua, Q, t, aug = scr[13], scr[14], scr[15], scr[16], scr[17], scr[18], scr[19], scr[20], \
        scr[21]  # fmt: skip
    n = uW.shape[0]
    for a in range(n):
        for c in range(n):
            uW[a, c] = s * etaW[a, c]
    for a in range(nv):
        uv[a] = s * etav[a]
    for a in range(ua.shape[0]):
        ua[a] = s * etaa[a]
    exp_map(uW, uv, nv, Q, t, aug)
    act, energy = pieces.action, pieces.energy
    act(Q, t, ua, y, par, trial, work)
    return energy(trial, par, work) - level0


@njit(cache=True)
def onto_level(fx, y, par, level0, scr):
    """Move the fields ``y`` along the group orbit onto ``H = level0`` in place (the generic
    path's rule for one body: see the module docstring)."""
    pieces = fx[0]
    basisW, basisv, basisa, gQ, gt, ga = _orbit(fx)
    work, trial, grad = scr[9], scr[11], scr[12]
    etaW, etav, etaa = scr[13], scr[14], scr[15]
    act, energy = pieces.action, pieces.energy
    f0 = energy(y, par, work) - level0
    band = _LEVEL * abs(level0)
    if not (np.isfinite(f0) and abs(f0) > band):
        return
    dim = basisW.shape[0]
    slope0 = 0.0
    for i in range(dim):
        act(gQ[0, i], gt[0, i], ga[0, i], y, par, trial, work)
        up = energy(trial, par, work)
        act(gQ[1, i], gt[1, i], ga[1, i], y, par, trial, work)
        down = energy(trial, par, work)
        grad[i] = (up - down) / (2.0 * EPSILON)
        slope0 += grad[i] * grad[i]
    if not slope0 > 0.0:
        return
    etaW[:, :] = 0.0
    etav[:] = 0.0
    etaa[:] = 0.0
    for i in range(dim):
        g = grad[i]
        for a in range(etaW.shape[0]):
            for c in range(etaW.shape[1]):
                etaW[a, c] += g * basisW[i, a, c]
        for a in range(etav.shape[0]):
            etav[a] += g * basisv[i, a]
        for a in range(etaa.shape[0]):
            etaa[a] += g * basisa[i, a]
    s_prev, f_prev = 0.0, f0
    s = -f0 / slope0
    f = _gap(fx, y, par, s, level0, scr)
    for _ in range(_ITERATIONS - 1):
        if not (abs(f) > band and f != f_prev):
            break
        step = f * (s - s_prev) / (f - f_prev)
        s_prev, f_prev, s = s, f, s - step
        f = _gap(fx, y, par, s, level0, scr)
    size = abs(s) * np.sqrt(slope0)
    if not (np.isfinite(s) and np.isfinite(f) and size <= _MAX_MOVE):
        return
    if not (abs(f) <= band or abs(f) <= 1e-2 * abs(f0)):
        return
    _gap(fx, y, par, s, level0, scr)
    for i in range(y.shape[0]):
        y[i] = trial[i]


@njit(cache=True)
def form_energy_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """The pair's step of the fields (the plain form's, whose ``inc`` and ``aux`` it sets),
    then the move onto the level ``y[-1]``; the move is kept for the embedded solutions."""
    f = y.shape[0] - 1
    x, x1 = y[:f], y1[:f]
    spent = form_lie_step((fx[0], fx[1]), x, par, meth, h, x1, inc, aux, scr)
    if spent < 0:
        return spent
    y1[f] = y[f]
    moved = scr[10]
    for i in range(f):
        moved[i] = x1[i]
    onto_level(fx, x1, par, y[f], scr)
    for i in range(f):
        moved[i] = x1[i] - moved[i]
    return spent


@njit(cache=True)
def form_energy_embedded(fx, y, par, meth, weights, h, yh, scr):
    """The pair's embedded solution of the fields plus the step's move onto the level."""
    f = y.shape[0] - 1
    form_embedded((fx[0], fx[1]), y[:f], par, meth, weights, h, yh[:f], scr)
    moved = scr[10]
    for i in range(f):
        yh[i] += moved[i]
    yh[f] = y[f]


@njit(cache=True)
def form_energy_project(fx, y, par, out, scr):
    """The system's projection of the fields; the level as it is."""
    f = y.shape[0] - 1
    pieces = fx[0]
    proj = pieces.projection
    proj(y[:f], par, out[:f], scr[9])
    out[f] = y[f]


@njit(cache=True)
def form_energy_radius2(fx, y, par, scr):
    """``‖W‖_F²`` of ξ of the fields (the plain form's bound)."""
    pieces = fx[0]
    gen = pieces.generator
    KW, Kv, Ka = scr[0], scr[1], scr[2]
    gen(y[: y.shape[0] - 1], par, KW[0], Kv[0], Ka[0], scr[9])
    total = 0.0
    for i in range(KW.shape[1]):
        for j in range(KW.shape[2]):
            total += KW[0, i, j] * KW[0, i, j]
    return total


@njit(cache=True)
def form_energy_user_field(fx, yu, par, fu, scr):
    """The plain form's vector field (the user's layout holds no level)."""
    pieces = fx[0]
    field = pieces.vector_field
    field(yu, par, fu, scr[9])


#: the step and the embedded solution on the plain form's copies without reference counts
#: (exponential coordinates at n = 3, Cayley coordinates at every n: :mod:`lieint.fast.generic`),
#: one per coordinates
_COPIES = {
    family: compiled_copies(
        [form_energy_step, form_energy_embedded],
        {
            "form_lie_step": PLAIN[f"rkmk_{family}"]["step"],
            "form_embedded": PLAIN[f"rkmk_{family}"]["embedded"],
            "lie_step": lie_step,
            "move": move,
        },
        f"_{family}",
    )
    for family, lie_step, move in (
        ("uncounted", lie_step_uncounted, move_uncounted),
        ("cayley", lie_step_cayley, move_cayley),
    )
}

_COMMON = {
    "prepare": PLAIN["rkmk"]["prepare"],
    "scratch": form_energy_scratch,
    "error_sum": PLAIN["rkmk"]["error_sum"],
    "project": form_energy_project,
    "radius2": form_energy_radius2,
    "user_field": form_energy_user_field,
}
#: the names of :mod:`lieint.fast.loop` this form binds, per method family (the plain form's
#: stage code, ``_uncounted``: at n = 3, ``_cayley``: in Cayley coordinates)
NAMESPACES = {
    "rkmk_energy": {**_COMMON, "step": form_energy_step, "embedded": form_energy_embedded},
    **{
        f"rkmk_energy_{family}": {
            **_COMMON,
            "step": copies["form_energy_step"],
            "embedded": copies["form_energy_embedded"],
        }
        for family, copies in _COPIES.items()
    },
}
