"""The algebra ``se(n) ⊕ Rᵐ`` (or ``so(n) ⊕ Rᵐ``) the generic compiled kernel steps in
(:mod:`lieint.fast.generic`), on the flat views of its work arrays (numba, cached on disk).

An element is ``(W, v, a)``: W ∈ so(n), v ∈ Rⁿ the translation (length 0 on SO(n)), a ∈ Rᵐ
(abelian: its exponential is the identity map and its dexp⁻¹ and dcay⁻¹ the identity), so the
functions here take the rotation and translation parts ``(uW, uv)``:

* :func:`exponential` into preallocated ``(Q, t)``, and the coordinate maps φ the step takes
  (:func:`exp_map`, :func:`exp_map_n`, :func:`exp_map_3`, :func:`cayley_map`: one per set of
  coordinates and range of n, so that a step compiled for one never compiles another's code);
* :func:`out_of_range`, the generic path's dexp⁻¹ range test on the rotation part;
* :func:`dexpinv`, the truncated series ``Σ_d (B_d/d!) ad_{−u}^d k`` with
  ``ad_{−u}(W, v) = ([−uW, W], −uW v + W uv)``, and :func:`dcayinv`, the exact
  ``dcay⁻¹_{−u}(k) = k + ½[u, k] − ¼ uku`` in homogeneous matrices.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._jit import NO_REFCOUNT
from .products import mm_unrolled_into
from .skew import _cayley_se3_into, _finite, cayley_se_elim_into, exp_se3_into, expm_so_se_into, so_ad_radius_exceeds

__all__ = [
    "cayley_map",
    "dcayinv",
    "dexpinv",
    "exp_map",
    "exp_map_3",
    "exp_map_n",
    "exponential",
    "out_of_range",
    "out_of_range_3",
]


@njit(cache=True)
def exponential(uW, uv, nv, Q, t):
    """``(Q, t) = exp(uW, uv)`` on SE(n) (``nv = n``) or ``Q = exp uW`` on SO(n), written into
    Q and t; NaN when u is not finite (the driver reports the non-finite state)."""
    if not (_finite(uW) and _finite(uv)):
        _nan_into(Q, t)
    elif uW.shape[0] == 3:
        exp_se3_into(uW, uv, Q, t)  # closed forms (uv of length 0 on SO(3))
    else:
        # expm_skew's or expm_se's bits (uv of length nv) through one compiled Taylor kernel:
        # the group is known only at run time, and compiling both wrappers cost seconds
        expm_so_se_into(uW, uv, Q, t)


@njit(cache=True, **NO_REFCOUNT)
def _nan_into(Q, t):
    """NaN into Q and t (a non-finite u: the driver reports the non-finite state), by loops:
    numba's slice assignment compiles its broadcasting for a copy a loop does."""
    for i in range(Q.shape[0]):
        for j in range(Q.shape[1]):
            Q[i, j] = np.nan
    for i in range(t.shape[0]):
        t[i] = np.nan


@njit(cache=True)
def out_of_range(uW, nv):
    """The generic path's dexp⁻¹ range test on the rotation part (``θ₁ + θ₂ ≥ 2π``; on se(2)
    the spectral radius of ad is ``|θ|``)."""
    if uW.shape[0] == 2:
        return nv > 0 and abs(uW[1, 0]) >= 2.0 * np.pi
    return so_ad_radius_exceeds(uW) == 1


@njit(cache=True, **NO_REFCOUNT)
def dexpinv(uW, uv, kW, kv, coeffs, tW, tv, P, nw):
    """``k ← Σ_{d ≤ degree} (B_d/d!) ad_{−u}^d k`` in place, with
    ``ad_{−u}(W, v) = ([−uW, W], −uW v + W uv)`` and ``[−uW, W] = Pᵀ − P``, ``P = uW W`` (both
    skew); tW, tv, P, nw are work arrays."""
    n = uW.shape[0]
    m = uv.shape[0]
    for a in range(n):  # copies by loops: numba's array assignment may allocate
        for c in range(n):
            tW[a, c] = kW[a, c]
    for a in range(m):
        tv[a] = kv[a]
    for d in range(1, coeffs.shape[0]):
        mm_unrolled_into(uW, tW, P)
        for a in range(m):  # −uW tv + tW uv, from the old tW
            acc = 0.0
            for e in range(n):
                acc += tW[a, e] * uv[e] - uW[a, e] * tv[e]
            nw[a] = acc
        for a in range(n):
            for c in range(n):
                tW[a, c] = P[c, a] - P[a, c]
        for a in range(m):
            tv[a] = nw[a]
        coeff = coeffs[d]
        if coeff != 0.0:
            for a in range(n):
                for c in range(n):
                    kW[a, c] += coeff * tW[a, c]
            for a in range(m):
                kv[a] += coeff * tv[a]


@njit(cache=True, **NO_REFCOUNT)
def dcayinv(uW, uv, kW, kv, tW, tv, new):
    """``k ← dcay⁻¹_{−u}(k) = k + ½[u, k] − ¼ u k u`` in place (exact, no series), in the
    homogeneous matrices of se(n): for ``u = (W, x)``, ``k = (U, v)``,
    ``U ← U + ½(WU − UW) − ¼ WUW``, ``v ← v + ½(Wv − Ux) − ¼ WUx`` (the vector factor's
    dcay⁻¹ is the identity); tW, tv, new are work arrays."""
    n = uW.shape[0]
    m = uv.shape[0]
    mm_unrolled_into(uW, kW, tW)  # tW = W U
    for a in range(m):  # tv = ½(Wv − Ux) − ¼ W(Ux), from the old U, v
        ux = 0.0
        wv = 0.0
        for e in range(n):
            ux += kW[a, e] * uv[e]
            wv += uW[a, e] * kv[e]
        tv[a] = 0.5 * (wv - ux)
    for a in range(m):
        acc = 0.0
        for e in range(n):
            ux_e = 0.0
            for f in range(n):
                ux_e += kW[e, f] * uv[f]
            acc += uW[a, e] * ux_e
        tv[a] -= 0.25 * acc
    for a in range(n):  # U + ½(WU − UW) − ¼ (WU)W, UW from the old U
        for c in range(n):
            uw = 0.0
            wuw = 0.0
            for e in range(n):
                uw += kW[a, e] * uW[e, c]
                wuw += tW[a, e] * uW[e, c]
            new[a, c] = kW[a, c] + 0.5 * (tW[a, c] - uw) - 0.25 * wuw
    for a in range(n):  # a copy by loops: numba's array assignment may allocate
        for c in range(n):
            kW[a, c] = new[a, c]
    for a in range(m):
        kv[a] += tv[a]


# The coordinate maps φ(u) into Q and t, one per set of coordinates and inlined into the step
# (not called: where the step runs without reference counts, a call of its own would count one on
# each of its six arrays). ``aug`` is an ``(n, 2n + 1)`` work array for the Cayley map's
# elimination (n ≠ 3). A step takes one of them as a compile-time constant
# (lieint.fast.generic_step), so it compiles only its own coordinates' code.


@njit(cache=True, inline="always")
def exp_map(uW, uv, nv, Q, t, aug):
    """The exponential φ(u) = exp u into Q and t, at every n; NaN when u is not finite."""
    if uW.shape[0] == 3 and _finite(uW) and _finite(uv):
        exp_se3_into(uW, uv, Q, t)
    else:
        exponential(uW, uv, nv, Q, t)


@njit(cache=True, inline="always")
def exp_map_n(uW, uv, nv, Q, t, aug):
    """:func:`exp_map` at n ≠ 3, the Taylor kernel only (the step at n = 3 is a copy of its own,
    with :func:`exp_map_3`): neither the closed forms nor :func:`exponential`'s call to compile
    and link; NaN when u is not finite."""
    if _finite(uW) and _finite(uv):
        expm_so_se_into(uW, uv, Q, t)
    else:
        _nan_into(Q, t)


@njit(cache=True, inline="always")
def exp_map_3(uW, uv, nv, Q, t, aug):
    """:func:`exp_map` at n = 3 (the closed forms), allocating nothing (not called at other n)."""
    if _finite(uW) and _finite(uv):
        exp_se3_into(uW, uv, Q, t)
    else:
        _nan_into(Q, t)


@njit(cache=True, inline="always")
def cayley_map(uW, uv, nv, Q, t, aug):
    """The Cayley map φ(u) = cay u into Q and t, at every n, allocating nothing; NaN when u is
    not finite."""
    if not (_finite(uW) and _finite(uv)):
        _nan_into(Q, t)
    elif uW.shape[0] == 3:
        _cayley_se3_into(uW, uv, Q, t)
    else:
        cayley_se_elim_into(uW, uv, Q, t, aug)


# The step's copy for exponential coordinates at n = 3 (lieint.fast.generic_step.lie_step_uncounted)
# takes this in place of out_of_range, with exp_map_3: it runs without reference counts.


@njit(cache=True, **NO_REFCOUNT)
def out_of_range_3(uW, nv):
    """:func:`out_of_range` on so(3) and se(3), where ``θ₁ + θ₂ = θ = |w|`` (one plane turns):
    ``‖u‖_F² = 2θ² ≥ 8π²`` (not called at other n)."""
    ss = 0.0
    for i in range(3):
        for j in range(3):
            ss += uW[i, j] * uW[i, j]
    return np.sqrt(0.5 * ss) >= 2.0 * np.pi
