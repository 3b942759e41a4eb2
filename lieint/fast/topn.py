"""The compiled kernel for the Euler top of any dimension n ≥ 4 (numba, cached on disk).

The generic path moves dicts of batched matrices through Python for every stage, and for the
n-dimensional top (docs/theory.md §2) each stage is a handful of n×n products: for small n the step
is Python overhead, not arithmetic. This module runs the whole fixed-step loop in machine code
(the 3D top keeps its own kernel, :mod:`lieint.fast.top3`); one step, shared with the adaptive
kernel, is :mod:`lieint.fast.topn_step`:

* the state is ``(Ã, R̃) = (PᵀAP, RP)`` in the principal frame of ``B = P diag(b) Pᵀ`` (P a
  proper eigenbasis), where the inertia operator is the entrywise product
  ``Ω̃_ij = −Ã_ij / (b_i + b_j)`` and the equations keep their form, ``Ã' = [Ã, Ω̃]``,
  ``R̃' = R̃ Ω̃`` (conjugation by P is an automorphism of so(n));
* RKMK from any explicit tableau of the right action ``Q · (Ã, R̃) = (QᵀÃQ, R̃Q)``, with
  exponential coordinates and dexp⁻¹ truncated at the method's degree::

      u_i = h Σ_j a_ij k_j,   k_i = Σ_{d ≤ degree} (B_d / d!) ad_{−u_i}^d Ω̃(exp(u_i)ᵀ Ã exp(u_i)),
      (Ã, R̃) ← (QᵀÃQ, R̃Q),  Q = exp(h Σ_j b_j k_j),

  or with Cayley coordinates, ``k_i = dcay⁻¹_{−u_i}(ξ_i) = ξ_i + ½[u_i, ξ_i] − ¼ u_i ξ_i u_i``
  (exact: two products, no range limit) and ``cay(u) = (I − u/2)⁻¹(I + u/2)`` by elimination,
  or classical RK on the embedded equations ``Ã' = [Ã, Ω̃]``, ``R̃' = R̃Ω̃``;
* ``exp`` of a skew matrix (:mod:`lieint.fast.skew`) by scaling and squaring with a Taylor
  polynomial of degree 4, 6, 9, 12 or 16 chosen so that the truncation error is below the unit
  round-off (:data:`lieint.fast.skew.expm_skew_small_into`): only matrix products, no linear solve —
  numba's ``np.linalg.solve`` alone would add about 5 s to the one-time compilation; at n = 4 in
  closed form instead, by so(4) = su(2) ⊕ su(2) (:func:`lieint.fast.skew.expm_so4_into`: 40 ns
  against 450–600 ns, an RKMK4 step 1.25 µs against 2.8 µs);
* the stage slopes and the scratch of the exponential, the action and the brackets are held
  per body for the whole run, and the products are written into them, unrolled up to n = 8
  (:func:`lieint.fast.products.mm_small_into`; BLAS above, where the arithmetic outweighs a call);
* brackets of skew matrices cost one product, ``[X, Y] = XY − (XY)ᵀ``; for 4 ≤ n ≤ 6 the
  stage's skew operations are unrolled and compute only upper triangles
  (:mod:`lieint.fast.small_skew`);
* the dexp⁻¹ series converges only while the spectral radius of ``ad_u`` on so(n),
  ``θ₁ + θ₂`` (the two largest rotation angles of u), is below 2π; the Frobenius norm settles
  the usual case (``‖u‖_F² = 2 Σ θ_k² ≥ (θ₁ + θ₂)²``), then ``(2‖u²‖_F)^{1/2}``, and only when
  both fail are the angles computed, from the eigenvalues ``θ_k²`` (each twice) of the
  symmetric ``−u² = uᵀu`` (:func:`so_ad_radius_exceeds`). Those give θ₂ to about
  ``√ε·θ₁`` when θ₂ is near 0 (the generic path's singular values give it to ``ε·θ₁``), so
  the two paths may decide differently on a step within about 1e-8 (relative) of the limit;
  every other step is accepted or refused alike;
* the projection (``project=True``) is Newton–Schulz ``R̃ ← R̃(3I − R̃ᵀR̃)/2`` toward the polar
  factor, repeated while ``‖R̃ᵀR̃ − I‖_max`` exceeds 1e-8; from farther than the region where
  it converges (a coarse classical step) R̃ is first scaled by ``‖R̃ᵀR̃‖₁^{-1/2}`` (same polar
  factor, at most 128 steps); Ã stays exactly skew;
* bodies of an ensemble run in parallel Python threads, each over a contiguous range of
  bodies (the compiled loop releases the GIL: no ``prange`` region to compile a second time);
  a single body, or fewer bodies than threads, runs serially in the calling thread
  (:func:`lieint.fast.use_threads`).

The compiled entry point :func:`_run_bodies` has one type signature (float64 arrays, int64,
bool) whatever the method, n, orientation and options, so numba compiles it once per
installation (cached on disk).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit

from ._jit import NO_REFCOUNT
from .cayley import cayley_into
from .products import copy_matrix_into, mm_small_into
from .skew import _project, expm_skew, so_ad_radius_exceeds
from .topn_step import _act_into, _classical_step, _combine, _exp_into, _lie_step, _products_step

__all__ = ["NAMESPACES", "expm_skew", "inertia_factors", "inertia_factors_of", "so_ad_radius_exceeds"]


@njit(cache=True, **NO_REFCOUNT)
def _generator_norm2(A, M):
    """``‖Ω̃‖_F²`` of ``Ω̃ = M ∘ Ã`` (an upper bound of ``(θ₁ + θ₂)²``, the squared ad spectral
    radius of Ω̃, which the step check compares with π/h)."""
    total = 0.0
    for a in range(A.shape[0]):
        for c in range(A.shape[1]):
            x = A[a, c] * M[a, c]
            total += x * x
    return total


def inertia_factors(b_principal) -> np.ndarray:
    """``M_ij = −1/(b_i + b_j)``: the inertia operator in the principal frame is the entrywise
    product ``Ω̃ = M ∘ Ã`` (the diagonal, zero in a bivector, is set to −1)."""
    b = np.asarray(b_principal, dtype=float)
    pair = b[:, None] + b[None, :]
    np.fill_diagonal(pair, 1.0)  # the diagonal of a bivector is zero anyway
    return -1.0 / pair


@lru_cache(maxsize=32)
def inertia_factors_of(data: bytes) -> np.ndarray:
    """:func:`inertia_factors` of the eigenvalues in ``data``, worked out once per top (a
    single call's set-up is tens of microseconds); writable, as the compiled loops take it,
    and never written."""
    return inertia_factors(np.frombuffer(data))


# inlined into its callers, not called: a product here may fall back on BLAS (which copies),
# so it cannot drop reference counts, and a call would pay them (lieint.fast._jit)
@njit(cache=True, inline="always")
def _embedded(A0, R0, orient, M, K, w, h, cayley, W, E, out_A, out_R):
    """``ρ(φ(h Σ_j w_j k_j), (Ã₀, R̃₀))`` into out_A, out_R, φ = exp or cay (``cayley``);
    ``W``, ``E``: scratch."""
    u, Q, C, tmp, acc = W[0], W[1], W[2], W[3], W[4]
    if not _combine(u, K, w.reshape((1, w.shape[0])), 0, w.shape[0], h):
        u[:, :] = 0.0
    if cayley:
        cayley_into(u, Q, E[0], E[1])
    else:
        _exp_into(u, Q, E)
    _act_into(Q, Q.T, A0, M, out_A, acc, C, tmp)
    if orient:
        mm_small_into(R0, Q, out_R)


# inlined into its callers, not called: a product here may fall back on BLAS (which copies),
# so it cannot drop reference counts, and a call would pay them (lieint.fast._jit)
@njit(cache=True, inline="always")
def _user(X, P, right_only, identity, out, tmp):
    """The user's frame of a principal-frame field: ``P X Pᵀ`` (A), or ``X Pᵀ`` (R, with
    ``right_only``); a copy when P is the identity."""
    if identity:
        copy_matrix_into(X, out)
    elif right_only:
        mm_small_into(X, P.T, out)
    else:
        mm_small_into(P, X, tmp)
        mm_small_into(tmp, P.T, out)


@njit(cache=True, **NO_REFCOUNT)
def _scaled_sum(Y0, Y1, Yh, rtol, atol):
    """``Σ_i r_i²``, ``r_i = (Y₁ − Ŷ)_i / (atol + rtol·max(|Y₀,i|, |Y₁,i|))``."""
    total = 0.0
    for a in range(Y0.shape[0]):
        for c in range(Y0.shape[1]):
            x = (Y1[a, c] - Yh[a, c]) / (atol + rtol * max(abs(Y0[a, c]), abs(Y1[a, c])))
            total += x * x
    return total


# inlined into its callers, not called: a product here may fall back on BLAS (which copies),
# so it cannot drop reference counts, and a call would pay them (lieint.fast._jit)
@njit(cache=True, inline="always")
def _user_pair(A, R, orient, P, identity, UA, UR, tmp):
    """The user's ``A = P Ã Pᵀ`` into UA and ``R = R̃ Pᵀ`` into UR (when ``orient``)."""
    _user(A, P, False, identity, UA, tmp)
    if orient:
        _user(R, P, True, identity, UR, tmp)


# inlined into its callers, not called: a product here may fall back on BLAS (which copies),
# so it cannot drop reference counts, and a call would pay them (lieint.fast._jit)
@njit(cache=True, inline="always")
def _error_sum(Ah, Rh, orient, P, identity, rtol, atol, U):
    """The scaled squares of one body over the user's A (and R), against the embedded
    ``(Ãh, R̃h)``; ``U`` holds the user's y₀ (U[0], U[1]) and y₁ (U[2], U[3]) and scratch."""
    _user_pair(Ah, Rh, orient, P, identity, U[4], U[5], U[6])
    total = _scaled_sum(U[0], U[2], U[4], rtol, atol)
    if orient:
        total += _scaled_sum(U[1], U[3], U[5], rtol, atol)
    return total


# -- the n-dimensional top as a form of the one compiled loop (lieint.fast.loop) ------------------
# State of one body: y = (Ã, R̃) flattened (n² + r² floats, r = n with orientation, else 0);
# parameters par = (n, r, identity frame, M (n²), P (n²)).


@njit(cache=True, inline="always")
def _dims(par):
    return int(par[0]), int(par[1])


@njit(cache=True, inline="always")
def _M(par, n):
    return par[3 : 3 + n * n].reshape((n, n))


@njit(cache=True, inline="always")
def _P(par, n):
    return par[3 + n * n : 3 + 2 * n * n].reshape((n, n))


@njit(cache=True, inline="always")
def _parts(y, n, r):
    """The views ``(Ã, R̃)`` of a flat state (R̃ of shape (0, 0) without orientation)."""
    return y[: n * n].reshape((n, n)), y[n * n : n * n + r * r].reshape((r, r))


@njit(cache=True)
def form_prepare(ctx):
    return ctx


@njit(cache=True)
def form_scratch(fx, meth, par, d):
    """The stage slopes K (s, n, n) and KR (s, r, r) of classical RK, the step's scratch W (8, n, n)
    and E (5, n, n), the error norm's U (7, n, n) and the embedded state's ``(Ãh, R̃h)``."""
    n, r = _dims(par)
    s = meth.b.shape[0]
    return (np.zeros((s, n, n)), np.zeros((s, r, r)), np.zeros((8, n, n)), np.zeros((5, n, n)), np.zeros((7, n, n)))


@njit(cache=True)
def form_lie_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One RKMK step (:func:`lieint.fast.topn_step._lie_step`); ``inc`` = the step's u,
    ``aux[0] = ‖M ∘ Ã‖_F²`` (ξ of the first stage)."""
    n, r = _dims(par)
    K, W, E = scr[0], scr[2], scr[3]
    M = _M(par, n)
    for i in range(y.shape[0]):
        y1[i] = y[i]
    A, R = _parts(y1, n, r)
    aux[0] = _generator_norm2(A, M)  # ξ(y) = M ∘ Ã, the first stage
    # reduce=False passed, not left to its default: an omitted argument is a type of its own,
    # and the energy pairs' call (reduce=True) would compile the whole step a second time
    if not _lie_step(A, R, r > 0, M, meth.A, meth.b, h, meth.coeffs, meth.cayley, K, W, E, False):
        return -1
    u = W[0]
    j = 0
    for a in range(n):
        for c in range(n):
            inc[j] = u[a, c]
            j += 1
    return meth.b.shape[0]


@njit(cache=True)
def form_products_scratch(fx, meth, par, d):
    """The stage generators K (s, n, n) and the step's scratch W (8, n, n), E (5, n, n)."""
    n = _dims(par)[0]
    s = meth.c.shape[0]
    return (np.zeros((s, n, n)), np.zeros((8, n, n)), np.zeros((5, n, n)))


@njit(cache=True)
def form_products_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One step of a product of exponentials (:func:`lieint.fast.topn_step._products_step`);
    ``inc`` = the step's exponents, ``aux[0] = ‖M ∘ Ã‖_F²`` (ξ of the first stage)."""
    n, r = _dims(par)
    M = _M(par, n)
    for i in range(y.shape[0]):
        y1[i] = y[i]
    A, R = _parts(y1, n, r)
    aux[0] = _generator_norm2(A, M)
    _products_step(A, R, r > 0, M, meth.weights, meth.bounds, h, scr[0], scr[1], scr[2], inc)
    return meth.c.shape[0]


@njit(cache=True)
def form_rk_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One classical RK step on ``Ã' = [Ã, Ω̃]``, ``R̃' = R̃Ω̃``."""
    n, r = _dims(par)
    A, R = _parts(y, n, r)
    A1, R1 = _classical_step(A, R, r > 0, _M(par, n), meth.A, meth.b, h, scr[0], scr[1])
    B1, S1 = _parts(y1, n, r)
    copy_matrix_into(A1, B1)
    copy_matrix_into(R1, S1)
    return meth.b.shape[0]


@njit(cache=True)
def form_embedded(fx, y, par, meth, weights, h, yh, scr):
    n, r = _dims(par)
    A0, R0 = _parts(y, n, r)
    Ah, Rh = _parts(yh, n, r)
    _embedded(A0, R0, r > 0, _M(par, n), scr[0], weights, h, meth.cayley, scr[2], scr[3], Ah, Rh)


@njit(cache=True)
def form_error_sum(fx, y0, y1, yh, par, rtol, atol, scr):
    """``Σ r_i²`` over the user's A (and R) of one body, against the embedded state."""
    n, r = _dims(par)
    P, identity, U = _P(par, n), par[2] != 0.0, scr[4]
    A0, R0 = _parts(y0, n, r)
    A1, R1 = _parts(y1, n, r)
    Ah, Rh = _parts(yh, n, r)
    _user_pair(A0, R0, r > 0, P, identity, U[0], U[1], U[6])
    _user_pair(A1, R1, r > 0, P, identity, U[2], U[3], U[6])
    return _error_sum(Ah, Rh, r > 0, P, identity, rtol, atol, U)


@njit(cache=True)
def form_project(fx, y, par, out, scr):
    """R̃ onto SO(n) (:func:`lieint.fast.skew._project`); Ã as it is."""
    n, r = _dims(par)
    for i in range(y.shape[0]):
        out[i] = y[i]
    if r > 0:
        R = _parts(out, n, r)[1]
        copy_matrix_into(_project(R), R)


@njit(cache=True)
def form_radius2(fx, y, par, scr):
    n, r = _dims(par)
    return _generator_norm2(_parts(y, n, r)[0], _M(par, n))


@njit(cache=True)
def form_user_field(fx, yu, par, fu, scr):
    """The vector field at a state in the user's layout ``(A, R)``, in that layout:
    ``Ω = P (M ∘ PᵀAP) Pᵀ``, ``Ȧ = [A, Ω]``, ``Ṙ = RΩ``."""
    n, r = _dims(par)
    A, R = _parts(yu, n, r)
    dA, dR = _parts(fu, n, r)
    P, M = _P(par, n), _M(par, n)
    Om = P @ ((P.T @ A @ P) * M) @ P.T
    Om = 0.5 * (Om - Om.T)
    copy_matrix_into(A @ Om - Om @ A, dA)
    if r > 0:
        copy_matrix_into(R @ Om, dR)


#: the names of :mod:`lieint.fast.loop` this form binds, per method family
NAMESPACES = {
    family: {
        "prepare": form_prepare,
        "scratch": form_scratch,
        "step": stepper,
        "embedded": form_embedded,
        "error_sum": form_error_sum,
        "project": form_project,
        "radius2": form_radius2,
        "user_field": form_user_field,
    }
    for family, stepper in (("rkmk", form_lie_step), ("rk", form_rk_step))
}
#: products of exponentials (no pairs: the controller loop, the embedded solution and the error
#: norm are never compiled for them)
NAMESPACES["cf"] = {**NAMESPACES["rkmk"], "scratch": form_products_scratch, "step": form_products_step}
