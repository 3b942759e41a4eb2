"""The implicit (Lie–Poisson) midpoint rule on the free 3D top, as a form of the one compiled loop.

``lie_midpoint`` (:mod:`lieint.methods.midpoint`) in the 3D top's principal frame
(:mod:`lieint.fast.top3`: ``(Π, R P)``, ``A = −Π̂``): the midpoint ``y_m = y₀ + (h/2) f(y_m)`` of
Euler's equations ``Π̇ = Π × ω``, ``(RP)˙ = (RP) ω̂``, ``ω = I⁻¹Π``, by the numpy path's
fixed-point iteration and stopping rule (each field's largest change over its largest entry
below 4ε, or no longer shrinking once below 1000ε; the attitude counted only when the state
carries it), then ``y₁ = 2 y_m − y₀``. The arithmetic is the 3D top's own (a cross product and a
3 × 3 product a pass), so it compiles and runs as that form's maps do; the other tops and the
heavy top run the rule through their compiled pieces (:mod:`lieint.fast.midpoint`). The rule is
no Lie-group method: its steps report no increment, and dense output works from the states.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .midpoint import verdict
from .top3 import form_embedded, form_error_sum, form_prepare, form_radius2, form_user_field
from .top3_mv import form_project, form_scratch

__all__ = ["INCREMENT", "NAMESPACES", "MidpointNumbers", "numbers"]

#: the rule is no Lie-group method: its steps have no increment in the algebra
INCREMENT = False
#: ``cayley`` (False; read by the loop's observer as a tableau's)
MidpointNumbers = namedtuple("MidpointNumbers", "cayley")

#: the numpy path's limit on the fixed-point iterations of one step
_MAX_ITER = 200


def numbers(form, layout) -> MidpointNumbers:
    """The midpoint's numbers (none besides the tableau's flag)."""
    return MidpointNumbers(False)


@njit(cache=True, inline="always")
def _field_into(Iinv, y, out):
    """``(Π × ω, R̃ ω̂)`` at y, ``ω = I⁻¹Π``."""
    p0, p1, p2 = y[0], y[1], y[2]
    w0, w1, w2 = Iinv[0] * p0, Iinv[1] * p1, Iinv[2] * p2
    out[0] = p1 * w2 - p2 * w1
    out[1] = p2 * w0 - p0 * w2
    out[2] = p0 * w1 - p1 * w0
    for r in range(3):
        a, b, c = y[3 + 3 * r], y[4 + 3 * r], y[5 + 3 * r]
        out[3 + 3 * r] = b * w2 - c * w1  # (R̃ ω̂)_r0 = R̃_r1 ω₂ − R̃_r2 ω₁
        out[4 + 3 * r] = c * w0 - a * w2
        out[5 + 3 * r] = a * w1 - b * w0


@njit(cache=True)
def form_midpoint_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One midpoint step of one body; returns the vector field's evaluations, or −1 when the
    fixed-point iteration did not converge (the numpy path's test)."""
    Iinv = par[0:3]
    orient = par[12] != 0.0
    k = np.empty(12)
    ym = np.empty(12)
    half = 0.5 * h
    _field_into(Iinv, y, k)
    for i in range(12):
        ym[i] = y[i] + half * k[i]
    scale_pi = max(max(abs(y[0]), abs(y[1]), abs(y[2])), 1.0e-300)
    scale_r = 1.0e-300
    for i in range(3, 12):
        scale_r = max(scale_r, abs(y[i]))
    last = np.inf
    for it in range(1, _MAX_ITER + 1):
        _field_into(Iinv, ym, k)
        change_pi, change_r = 0.0, 0.0
        for i in range(12):
            new = y[i] + half * k[i]
            if i < 3:
                change_pi = max(change_pi, abs(new - ym[i]))
            else:
                change_r = max(change_r, abs(new - ym[i]))
            ym[i] = new
        size = change_pi / scale_pi
        if orient:
            size = max(size, change_r / scale_r)
        outcome = verdict(size, last, it)
        if outcome == 1:
            for i in range(12):
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
