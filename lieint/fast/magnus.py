"""The Magnus methods on prescribed rotations, as a form of the one compiled loop.

``magnus4`` and ``magnus6`` (:mod:`lieint.methods.magnus`) step ``Ṙ = R Ω(t)``: the generator
depends on t only, so its values at a step's Gauss nodes ``t_k + c_i h_k`` are known before the
step. The Python side (:class:`lieint.fast.layouts.PrescribedLayout`) samples the prescribed rates
there for the steps of a call — the sampled rates' spline at all nodes in one evaluation, a rates
function once per node — and hands them to the loop in the call's parameters; the loop gives each
step its index on the global grid (``aux[1]``), and the step reads its nodes' values by it. The
step is the numpy path's, in the same order: the right equation ``ġ = g ξ`` is the left one for
``g⁻¹`` with ``A = −ξ``, so ``u = −Ω_left(A₁, …)`` with

* ``magnus4``: ``Ω = h/2 (A₁ + A₂) − (√3/12) h² [A₁, A₂]``;
* ``magnus6``: ``α₁ = h A₂``, ``α₂ = (√15 h/3)(A₃ − A₁)``, ``α₃ = (10 h/3)(A₃ − 2A₂ + A₁)``,
  ``C₁ = [α₁, α₂]``, ``C₂ = −(1/60)[α₁, 2α₃ + C₁]``,
  ``Ω = α₁ + α₃/12 + (1/240)[−20α₁ − α₃ + C₁, α₂ + C₂]``

(Blanes, Casas, Oteo, Ros, Phys. Rep. 470 (2009), §5.2), then ``R₁ = R exp(u)`` with
:func:`lieint.fast.skew.expm_skew_into` (Taylor with scaling and squaring). A state is R,
row-major (n² numbers); a step's increment is u (n², what dense output interpolates on the group).
A projecting run takes the nearest rotation by the SVD, as :func:`lieint.groups.so.project_to_so`.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .skew import expm_skew_into

__all__ = ["NAMESPACES", "MagnusNumbers", "numbers"]

#: a rule's Gauss nodes (fractions of the step) and whether it is the order-6 rule; ``cayley``
#: (False) as the loop's observer reads a tableau's
MagnusNumbers = namedtuple("MagnusNumbers", "nodes sixth cayley")

#: where a call's node values start in its parameters (after n, the nodes per step, the first step)
HEAD = 3


def numbers(form, layout) -> MagnusNumbers:
    """The rule's numbers: its nodes (``form.substeps``), and whether it has three (order 6)."""
    nodes = np.array(form.substeps, dtype=float)
    return MagnusNumbers(nodes, nodes.size == 3, False)


@njit(cache=True)
def _bracket_into(X, Y, out):
    """``out = XY − YX``."""
    n = X.shape[0]
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += X[i, k] * Y[k, j] - Y[i, k] * X[k, j]
            out[i, j] = acc


@njit(cache=True)
def form_prepare(ctx):
    return 0


@njit(cache=True)
def form_scratch(fx, meth, par, d):
    """Three node values A_i, the rule's α₁, α₂, α₃, C, two brackets' arguments, u, exp(u), R and
    expm's five work matrices: 17 matrices (n, n)."""
    n = int(par[0])
    return np.zeros((17, n, n))


@njit(cache=True)
def form_magnus_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One Magnus step of R (``y``, row-major) into ``y1``; ``inc`` = u; ``aux[1]`` = the step's index
    on the global grid (set by the loop), ``aux[0]`` left at −1 (ξ is not a function of the state).
    Returns the generator evaluations (the nodes)."""
    n = int(par[0])
    m = int(par[1])
    k = int(aux[1]) - int(par[2])
    A1, A2, A3 = scr[0], scr[1], scr[2]
    a1, a2, a3, C, X, Y = scr[3], scr[4], scr[5], scr[6], scr[7], scr[8]
    u, E, R = scr[9], scr[10], scr[11]
    base = HEAD + k * m * n * n
    for i in range(n):
        for j in range(n):
            # A = −ξ at each node
            A1[i, j] = -par[base + i * n + j]
            A2[i, j] = -par[base + n * n + i * n + j]
            if m == 3:
                A3[i, j] = -par[base + 2 * n * n + i * n + j]
    if not meth.sixth:
        c = np.sqrt(3.0) / 12 * h * h
        _bracket_into(A1, A2, C)
        for i in range(n):
            for j in range(n):
                u[i, j] = -((h / 2) * (A1[i, j] + A2[i, j]) - c * C[i, j])
    else:
        s15 = np.sqrt(15.0) * h / 3
        for i in range(n):
            for j in range(n):
                a1[i, j] = h * A2[i, j]
                a2[i, j] = s15 * (A3[i, j] - A1[i, j])
                a3[i, j] = (10 * h / 3) * (A3[i, j] - 2 * A2[i, j] + A1[i, j])
        _bracket_into(a1, a2, C)  # C₁
        for i in range(n):
            for j in range(n):
                X[i, j] = 2 * a3[i, j] + C[i, j]
        _bracket_into(a1, X, Y)
        for i in range(n):
            for j in range(n):
                Y[i, j] = -(1 / 60) * Y[i, j]  # C₂
                X[i, j] = -20 * a1[i, j] - a3[i, j] + C[i, j]
                C[i, j] = a2[i, j] + Y[i, j]
        _bracket_into(X, C, Y)
        for i in range(n):
            for j in range(n):
                u[i, j] = -(a1[i, j] + a3[i, j] / 12 + (1 / 240) * Y[i, j])
    expm_skew_into(u, E, scr[12:17])
    for i in range(n):
        for j in range(n):
            R[i, j] = y[i * n + j]
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for q in range(n):
                acc += R[i, q] * E[q, j]
            y1[i * n + j] = acc
            inc[i * n + j] = u[i, j]
    aux[0] = -1.0
    return m


@njit(cache=True)
def form_project(fx, y, par, out, scr):
    """The nearest rotation to R (``y``): ``U diag(1, …, det(U Vᵀ)) Vᵀ`` from the SVD."""
    n = int(par[0])
    R = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            R[i, j] = y[i * n + j]
    U, _, Vt = np.linalg.svd(R)
    if np.linalg.det(U @ Vt) < 0.0:
        for i in range(n):
            U[i, n - 1] = -U[i, n - 1]
    P = U @ Vt
    for i in range(n):
        for j in range(n):
            out[i * n + j] = P[i, j]


@njit(cache=True)
def form_radius2(fx, y, par, scr):
    """No bound from the state (ξ depends on t only): infinite, so the step check evaluates ξ at the
    saved times itself."""
    return np.inf


# fixed steps only: the adaptive loop and the first trial step never run this form
@njit(cache=True)
def form_embedded(fx, y, par, meth, weights, h, yh, scr):  # pragma: no cover
    raise NotImplementedError


@njit(cache=True)
def form_error_sum(fx, y0, y1, yh, par, rtol, atol, scr):  # pragma: no cover
    raise NotImplementedError


@njit(cache=True)
def form_user_field(fx, yu, par, fu, scr):  # pragma: no cover
    raise NotImplementedError


#: the names of :mod:`lieint.fast.loop` this form binds (fixed steps only)
NAMESPACES = {
    "magnus": {
        "prepare": form_prepare,
        "scratch": form_scratch,
        "step": form_magnus_step,
        "embedded": form_embedded,
        "error_sum": form_error_sum,
        "project": form_project,
        "radius2": form_radius2,
        "user_field": form_user_field,
    }
}
