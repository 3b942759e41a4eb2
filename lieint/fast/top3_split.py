"""The splittings of the free 3D top into exact rotations, as a form of the one compiled loop.

``splitting2/4/6`` on the free 3D top (:mod:`lieint.methods.splitting`, ``free="rotations"``):
the kinetic energy is split over the principal axes, and the piece of axis k is the rotation of
the coordinate plane ``(i, j)`` (the other two axes) by the angle ``θ = τ Ω_ij``,
``Ω_ij = −Ã_ij/I_k`` (``Ã = −Π̂``; ``I_k = b_i + b_j``), which leaves ``Π_k`` unchanged: the group
action ``(Π, R) ↦ (QᵀΠ, RQ)`` with ``Q = exp(θ e_i∧e_j)`` touches two components of Π and two
columns of R. A step is the symmetric composition of Strang steps of the method
(``substeps``), each ``T₁(τ/2) … T_{m−1}(τ/2) T_m(τ) T_{m−1}(τ/2) … T₁(τ/2)`` over the planes in
the order of the split — the numpy path's map, in the principal frame.

A step's increment is the Cayley coordinates ``2q/q₀`` of the product of the rotations'
quaternions (each ``(1, tan(φ/2) e_k)``, φ its angle about axis k), converted when dense output
asks. Everything else is the 3D top's (:mod:`lieint.fast.top3`).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .top3 import form_embedded, form_error_sum, form_prepare, form_radius2, form_user_field
from .top3_mv import form_project, form_scratch

__all__ = ["NAMESPACES", "SplittingNumbers", "numbers"]

#: the Strang steps' fractions of h, the planes ``(i, j, k)`` of the rotations in the order of one
#: Strang step (k the axis of plane (i, j), the rotation by τ/2 except the middle one's τ), and
#: ``cayley`` (the increments are Cayley coordinates: dense output converts them)
SplittingNumbers = namedtuple("SplittingNumbers", "substeps planes halves cayley")


def numbers(form, layout) -> SplittingNumbers:
    """The numbers of a splitting :class:`~lieint.fast.forms.MapForm` for the 3D top: the planes
    of one Strang step ``T₁(τ/2) … T_m(τ) … T₁(τ/2)`` unrolled, with their fractions of τ."""
    planes = [tuple(int(v) for v in p) for p in form.planes]
    order = planes[:-1] + [planes[-1]] + planes[-2::-1]
    fractions = [0.5] * (len(planes) - 1) + [1.0] + [0.5] * (len(planes) - 1)
    rows = np.array([(i, j, 3 - i - j) for i, j in order], dtype=np.int64)
    return SplittingNumbers(np.array(form.substeps, dtype=float), rows, np.array(fractions), True)


@njit(cache=True)
def form_split_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One step of one body; ``inc`` = the Cayley coordinates of the step's rotation,
    ``aux[0] = |I⁻¹Π|²``. Returns the Strang steps spent."""
    Iinv = par[0:3]
    for i in range(12):
        y1[i] = y[i]
    w0, w1, w2 = Iinv[0] * y1[0], Iinv[1] * y1[1], Iinv[2] * y1[2]
    aux[0] = w0 * w0 + w1 * w1 + w2 * w2
    q0, q1, q2, q3 = 1.0, 0.0, 0.0, 0.0
    planes, halves = meth.planes, meth.halves
    for sub in range(meth.substeps.shape[0]):
        tau = h * meth.substeps[sub]
        for row in range(planes.shape[0]):
            i, j, k = planes[row, 0], planes[row, 1], planes[row, 2]
            # Ã_ij of Ã = −Π̂: +Π_k for the planes (0, 1), (1, 2), −Π_k for (0, 2)
            a = -y1[k] if (i == 0 and j == 2) else y1[k]
            theta = -halves[row] * tau * a * Iinv[k]  # τ Ω_ij
            c, s = np.cos(theta), np.sin(theta)
            pi, pj = y1[i], y1[j]
            y1[i] = c * pi - s * pj  # QᵀΠ
            y1[j] = s * pi + c * pj
            for r in range(3):  # RQ: columns i and j
                ri, rj = y1[3 + 3 * r + i], y1[3 + 3 * r + j]
                y1[3 + 3 * r + i] = c * ri - s * rj
                y1[3 + 3 * r + j] = s * ri + c * rj
            # the rotation's angle about axis k is φ = −θ (planes (0, 1), (1, 2)) or θ ((0, 2));
            # its quaternion (1, tan(φ/2) e_k), multiplied on the right
            t = np.tan(0.5 * theta) * (1.0 if (i == 0 and j == 2) else -1.0)
            e0 = t if k == 0 else 0.0
            e1 = t if k == 1 else 0.0
            e2 = t if k == 2 else 0.0
            q0, q1, q2, q3 = (
                q0 - (q1 * e0 + q2 * e1 + q3 * e2),
                q1 + q0 * e0 + (q2 * e2 - q3 * e1),
                q2 + q0 * e1 + (q3 * e0 - q1 * e2),
                q3 + q0 * e2 + (q1 * e1 - q2 * e0),
            )
    inc[0], inc[1], inc[2] = 2.0 * q1 / q0, 2.0 * q2 / q0, 2.0 * q3 / q0
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
