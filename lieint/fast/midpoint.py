"""The implicit (Lie–Poisson) midpoint rule through a system's compiled pieces, as a form of the
one compiled loop.

``lie_midpoint`` (:mod:`lieint.methods.midpoint`) solves ``y_m = y₀ + (h/2) f(y_m)`` for the
midpoint by fixed-point iteration from the explicit Euler half step and takes
``y₁ = 2 y_m − y₀``, with f the system's vector field on its flattened fields in the user's frame
— the pieces' ``vector_field`` (:mod:`lieint.fast.pieces`), the same equations as the numpy
path's ``system.vector_field``. The iteration and its stopping rule are the numpy path's: the
relative update of each field (its largest change over its largest entry) below 4ε, or no longer
shrinking once below 1000ε; a step that diverges, or has not converged in 200 iterations, returns
−1 and the run raises the numpy path's error. The n-D tops (n ≥ 4) run here through their compiled
pieces (``TopNForm.generic``), the heavy top through its own; the 3D top has its own stage code
(:mod:`lieint.fast.top3_midpoint`). The rule has
no increment in the algebra (it is not a Lie-group method): dense output interpolates the states,
as for classical Runge–Kutta.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .generic import form_embedded, form_error_sum, form_prepare
from .pieces_maps import form_project, form_radius2, form_user_field, scratch_head

__all__ = ["NAMESPACES", "MidpointNumbers", "numbers", "verdict"]

#: the offsets of the state's fields in the flat state (``bounds[f] … bounds[f + 1]``), and
#: ``cayley`` (False; read by the loop's observer as a tableau's)
MidpointNumbers = namedtuple("MidpointNumbers", "bounds cayley")

#: the rule is no Lie-group method: its steps have no increment in the algebra
INCREMENT = False
_EPS = np.finfo(np.float64).eps
#: the numpy path's limit on the fixed-point iterations of one step
_MAX_ITER = 200


def numbers(form, layout) -> MidpointNumbers:
    """The fields' offsets of a pieces layout, for the iteration's per-field relative update."""
    return MidpointNumbers(np.concatenate([[0], np.cumsum(layout.sizes)]).astype(np.int64), False)


@njit(cache=True, inline="always")
def verdict(size, last, it):
    """The numpy path's stopping rule after iteration ``it`` (:func:`lieint.methods.midpoint.implicit_midpoint`),
    from the largest relative update ``size`` and the one before, ``last``: 1 converged (below
    4ε, or no longer shrinking below 1000ε), −1 diverged (no longer shrinking after 3 iterations),
    0 go on. Shared by both stage codes of the rule (:mod:`lieint.fast.top3_midpoint`)."""
    if size <= 4.0 * _EPS or (size >= last and size <= 1e3 * _EPS):
        return 1
    if size >= last and it > 3:
        return -1
    return 0


@njit(cache=True)
def form_scratch(fx, meth, par, d):
    """:func:`lieint.fast.pieces_maps.scratch_head`'s arrays, the slope k, the midpoint's iterate
    and the fields' scales (their largest entries at the step's start)."""
    work, W, v, a = scratch_head(fx)
    return work, W, v, a, np.empty(d), np.empty(d), np.empty(meth.bounds.shape[0] - 1)


@njit(cache=True)
def form_midpoint_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One midpoint step of one body; returns the vector field's evaluations, or −1 when the
    fixed-point iteration did not converge (the numpy path's test,
    :func:`lieint.methods.midpoint.implicit_midpoint`)."""
    field = fx[0].vector_field
    work, k, ym, scales = scr[0], scr[4], scr[5], scr[6]
    bounds = meth.bounds
    d = y.shape[0]
    half = 0.5 * h
    for f in range(scales.shape[0]):
        scale = 1.0e-300
        for i in range(bounds[f], bounds[f + 1]):
            scale = max(scale, abs(y[i]))
        scales[f] = scale
    field(y, par, k, work)
    for i in range(d):
        ym[i] = y[i] + half * k[i]
    last = np.inf
    for it in range(1, _MAX_ITER + 1):
        field(ym, par, k, work)
        size = 0.0
        for f in range(scales.shape[0]):
            change = 0.0
            for i in range(bounds[f], bounds[f + 1]):
                new = y[i] + half * k[i]
                change = max(change, abs(new - ym[i]))
                ym[i] = new
            size = max(size, change / scales[f])
        outcome = verdict(size, last, it)
        if outcome == 1:
            for i in range(d):
                y1[i] = 2.0 * ym[i] - y[i]
            return it + 1
        if outcome == -1:
            return -1
        last = size
    return -1


#: the names of :mod:`lieint.fast.loop` this form binds (fixed steps only)
NAMESPACES = {
    "midpoint": {
        "prepare": form_prepare,
        "scratch": form_scratch,
        "step": form_midpoint_step,
        "embedded": form_embedded,
        "error_sum": form_error_sum,
        "project": form_project,
        "radius2": form_radius2,
        "user_field": form_user_field,
    }
}
