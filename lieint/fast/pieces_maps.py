"""What every map on a system's compiled pieces binds besides its step (the implicit midpoint,
:mod:`lieint.fast.midpoint`; the splittings, :mod:`lieint.fast.pieces_split`): the loop's
projection, step-check bound and user field through the pieces.

A map's scratch starts with the pieces' work array and a generator's ``(W, v, a)``
(:func:`scratch_head`); the rest is its own.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .generic import _norm2

__all__ = ["form_project", "form_radius2", "form_user_field", "scratch_head"]


@njit(cache=True)
def scratch_head(fx):
    """The pieces' work array and a generator's ``(W, v, a)``: ``scr[0:4]`` of a map's scratch."""
    dims = fx[1]
    n, nv, m = dims[0], dims[1], dims[2]
    return np.empty(max(dims[3], 1)), np.empty((n, n)), np.empty(nv), np.empty(m)


@njit(cache=True)
def form_project(fx, y, par, out, scr):
    proj = fx[0].projection
    proj(y, par, out, scr[0])


@njit(cache=True)
def form_radius2(fx, y, par, scr):
    """``‖W‖_F²`` of ξ(y): the step check's bound (a map's step does not report it)."""
    gen = fx[0].generator
    gen(y, par, scr[1], scr[2], scr[3], scr[0])
    return _norm2(scr[1])


@njit(cache=True)
def form_user_field(fx, yu, par, fu, scr):
    field = fx[0].vector_field
    field(yu, par, fu, scr[0])
