"""MEGNO's sums and Benettin's re-orthonormalisation inside a compiled tangent step (numba, inlined).

A row of a compiled tangent form (:mod:`lieint.fast.top3_tangent`, :mod:`lieint.fast.heavy3_tangent`)
is a body's state block and k tangent vectors of the same layout, ``block`` numbers each, then the
sums. A block starts with ``flat`` numbers perturbed additively (Π; Π and Γ) followed by the
attitude R̃ (9 numbers, row-major) when the body carries one. The norm of a tangent vector is that
of its chart coordinates (:mod:`lieint.tangent.coordinates`): the flat part as it is and, with an
attitude, ``vee`` of the skew part of ``R̃ᵀδR̃``. The principal frame is a rotation of the user's,
so these norms and inner products are the chart's.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = [
    "MEGNO_SLOTS",
    "chart_coordinates",
    "keep_row",
    "lyapunov_update",
    "megno_advance",
    "megno_update",
    "prepare_nothing",
]

#: the MEGNO sums after a body's state and its tangent vector: the time since the start,
#: ``log|δ|`` (renormalisations added back), ``∫ s d log|δ|``, ``∫ Y dt``, ``Y``
MEGNO_SLOTS = 5


@njit(cache=True, inline="always")
def chart_coordinates(y1, o, block, flat, orient, u):
    """``u`` = the tangent vector at ``y1[o : o + block]`` in coordinates of the chart's norm: its
    first ``flat`` numbers, then (with an attitude, at ``flat`` in the block) ``vee`` of the skew
    part of ``R̃ᵀδR̃``, the state's R̃ at ``y1[flat : flat + 9]``; ``u`` has ``flat + 3`` entries."""
    for a in range(flat):
        u[a] = y1[o + a]
    u[flat], u[flat + 1], u[flat + 2] = 0.0, 0.0, 0.0
    if orient:
        m01, m10, m02, m20, m12, m21 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        for r in range(3):
            a0, a1, a2 = y1[flat + 3 * r], y1[flat + 1 + 3 * r], y1[flat + 2 + 3 * r]
            b0, b1, b2 = y1[o + flat + 3 * r], y1[o + flat + 1 + 3 * r], y1[o + flat + 2 + 3 * r]
            m01 += a0 * b1
            m10 += a1 * b0
            m02 += a0 * b2
            m20 += a2 * b0
            m12 += a1 * b2
            m21 += a2 * b1
        u[flat], u[flat + 1], u[flat + 2] = 0.5 * (m21 - m12), 0.5 * (m02 - m20), 0.5 * (m10 - m01)


@njit(cache=True, inline="always")
def megno_update(y1, h, block, flat, orient):
    """After a step of size h: ``|δ|`` of the tangent vector at ``y1[block : 2 block]`` in the
    chart's norm (:func:`chart_coordinates`), MEGNO's sums at ``y1[2 block :]``
    (:func:`lieint.megno`: ``Y(t) = (2/t) ∫ s d log|δ|``, ⟨Y⟩ by the trapezoidal rule), and δ
    renormalised to 1. Where |δ| is not finite and positive the sums become NaN (and stay so: the
    caller refuses the run, naming it)."""
    n2 = 0.0
    for a in range(flat):
        n2 += y1[block + a] * y1[block + a]
    if orient:  # the attitude's part: M = R̃ᵀ δR̃, δ = vee((M − Mᵀ)/2)
        m01, m10, m02, m20, m12, m21 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        for r in range(3):
            a0, a1, a2 = y1[flat + 3 * r], y1[flat + 1 + 3 * r], y1[flat + 2 + 3 * r]
            o = block + flat + 3 * r
            b0, b1, b2 = y1[o], y1[o + 1], y1[o + 2]
            m01 += a0 * b1
            m10 += a1 * b0
            m02 += a0 * b2
            m20 += a2 * b0
            m12 += a1 * b2
            m21 += a2 * b1
        d0, d1, d2 = 0.5 * (m21 - m12), 0.5 * (m02 - m20), 0.5 * (m10 - m01)
        n2 += d0 * d0 + d1 * d1 + d2 * d2
    megno_advance(y1, 2 * block, h, np.sqrt(n2), block, 2 * block)


@njit(cache=True, inline="always")
def megno_advance(y1, s, h, norm, lo, hi):
    """MEGNO's sums at ``y1[s : s + 5]`` after a step of size h that left the tangent vector at
    ``y1[lo : hi]`` with the chart norm ``norm`` (:func:`lieint.megno`: ``Y(t) = (2/t) ∫ s d log|δ|``,
    ⟨Y⟩ by the trapezoidal rule), then the vector renormalised to 1. Where the norm is not finite
    and positive the sums become NaN (and stay so: the caller refuses the run, naming it)."""
    if not (norm > 0.0 and np.isfinite(norm)):
        for i in range(s + 1, s + MEGNO_SLOTS):
            y1[i] = np.nan
        y1[s] += h
        return
    tk = y1[s]
    t = tk + h
    dlog = np.log(norm)
    y1[s] = t
    y1[s + 1] += dlog
    y1[s + 2] += (tk + 0.5 * h) * dlog
    Y = 2.0 * y1[s + 2] / t
    y1[s + 3] += 0.5 * (y1[s + 4] + Y) * h
    y1[s + 4] = Y
    for i in range(lo, hi):
        y1[i] /= norm


@njit(cache=True, inline="always")
def lyapunov_update(y1, k, block, flat, orient, every, total):
    """Every ``every`` steps and after the last (the ``total``-th): the k tangent vectors
    orthonormalised by modified Gram–Schmidt in the chart's norm (:func:`chart_coordinates`; the
    combinations applied to the vectors themselves, the coordinates being linear in them), and
    ``log`` of each vector's norm before its normalisation (the diagonal of QR's R) added to its
    sum. The row's step counter is at ``block (1 + k)``, the k sums after it."""
    c = block * (1 + k)
    y1[c] += 1.0
    done = y1[c]
    if done % every != 0.0 and done != total:
        return
    u = np.empty(flat + 3)
    w = np.empty(flat + 3)
    for j in range(1, k + 1):
        oj = block * j
        for i in range(1, j):  # v_j ← v_j − ⟨q_i, v_j⟩ q_i, q_i already normalised
            oi = block * i
            chart_coordinates(y1, oi, block, flat, orient, u)
            chart_coordinates(y1, oj, block, flat, orient, w)
            dot = 0.0
            for a in range(flat + 3):
                dot += u[a] * w[a]
            for a in range(block):
                y1[oj + a] -= dot * y1[oi + a]
        chart_coordinates(y1, oj, block, flat, orient, w)
        n2 = 0.0
        for a in range(flat + 3):
            n2 += w[a] * w[a]
        norm = np.sqrt(n2)
        y1[c + j] += np.log(norm)  # −inf or NaN when the vectors degenerate: the caller refuses
        for a in range(block):
            y1[oj + a] /= norm


@njit(cache=True)
def prepare_nothing(ctx):
    """A tangent form's ``prepare``: nothing to prepare, the stage code is its module's."""
    return ctx


@njit(cache=True)
def keep_row(fx, y, par, out, scr):
    """A tangent form's ``project``: the row as it is. A run of tangent vectors does not project
    (the projection's derivative is not carried: :class:`lieint.tangent.compiled.CompiledTangent`
    runs with ``project=False``)."""
    for i in range(y.shape[0]):
        out[i] = y[i]
