"""Compiled adaptive RKMK for the Euler top in n ≥ 4 dimensions (numba, cached on disk).

The n-dimensional counterpart of :mod:`lieint.fast.top3_adaptive`: the whole controller loop —
trial step, error norm, accept or reject, next step size — in machine code, for one body or a
batch sharing one step size, with the generic path's controller
(:class:`lieint.control.StepSizeController`) constant for constant:

* a trial step from ``y₀ = (Ã, R̃)`` in the principal frame of ``B = P diag(b) Pᵀ`` computes
  the stages ``k_i`` of the order-p tableau with the stage code of the fixed-step kernel
  (:func:`lieint.fast.topn_step._lie_step`: the Taylor exponential, the action
  ``(QᵀÃQ, R̃Q)``, dexp⁻¹ truncated at the method's degree, brackets of one product — or in
  Cayley coordinates, ``cay`` by elimination and the exact dcay⁻¹), the
  propagated solution ``y₁ = ρ(φ(h Σ b_j k_j), y₀)`` and the embedded one(s)
  ``ŷ = ρ(φ(h Σ b̂_j k_j), y₀)`` from the same stages (φ = exp or cay);
* the error is measured on the **user's** fields, as the generic path measures it:
  ``A = P Ã Pᵀ``, ``R = R̃ Pᵀ`` (skipped when B is diagonal, P = I), componentwise
  ``r_i = (y₁ − ŷ)_i / (atol + rtol·max(|y₀,i|, |y₁,i|))`` over the n² entries of A and the n²
  of R (when the top carries R) of every body; ``err = √(Σ r_i²/N)``, or DOP853's
  ``err = s₅/√((s₅ + 0.01 s₃)·N)`` (:mod:`lieint.fast.controller`);
* ``err ≥ 1`` (or not finite, or a stage beyond the dexp⁻¹ radius) rejects the step; an
  accepted step moves the state (R̃ projected by Newton–Schulz when asked, as the fixed-step
  kernel projects), saves every ``save_every``-th step and the last one, and proposes the next
  step size.

Why a kernel of its own: through the generic kernel (:mod:`lieint.fast.generic_adaptive`) the
top is stepped in the user's frame, where the inertia operator ``Ω = −(B⁻¹-solve of A)`` costs
four n × n products per stage instead of an entrywise product, and the stage code is the
generic one; in the principal frame a stage of rkmk853 on a 6D top is about half as expensive
(``benchmarks/systems_speed.py``). The entry point has one type signature (float64 arrays,
int64, bool) for every pair, n and option: one compilation per installation.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._jit import NO_REFCOUNT
from .cayley import cayley_into
from .controller import advanced_time, error_norm, first_guess, initial_step_from, step_factor
from .principal import _convert
from .products import mm_small_into
from .skew import _project
from .topn_step import _act_into, _combine, _exp_into, _field, _lie_step

__all__ = ["adaptive_topn", "initial_step_topn"]


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
        out[:, :] = X
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


@njit(cache=True)
def adaptive_topn(
    A, R, orient, M, P, identity, tab, b, b_hat, b_low, has_low, coeffs, cayley, rtol, atol, q, safety, fmin, fmax,
    h_min, t, t1, h, k, max_accept, save_every, project, out_t, out_A, out_R,
):  # fmt: skip
    """Adaptive RKMK steps from ``t`` in place on ``A`` (N, n, n) and ``R`` (N, n, n) or
    (N, 0, 0) without orientation.

    Parameters
    ----------
    A, R : ndarray
        The state ``(Ã, R̃) = (PᵀAP, RP)`` of the N bodies in the principal frame (moved in place).
    orient : bool
        Whether R is one of the user's fields (stepped, and measured in the error norm).
    M : ndarray, shape (n, n)
        The inertia operator ``Ω̃_ij = M_ij Ã_ij``, ``M_ij = −1/(b_i + b_j)``.
    P : ndarray, shape (n, n)
        The proper principal frame; ``identity`` when it is I (no conversion for the norm).
    tab, b, b_hat, b_low : ndarray
        The order-p tableau and the embedded weights; ``b_low`` (with ``has_low``) is DOP853's
        third-order estimate.
    coeffs : ndarray
        Bernoulli coefficients of dexp⁻¹ up to the method's degree.
    cayley : bool
        Cayley coordinates (exact dcay⁻¹; ``coeffs`` unused) instead of exponential ones.
    rtol, atol, q, safety, fmin, fmax, h_min, t, t1, h, k, max_accept, save_every, project
        As :func:`lieint.fast.top3_adaptive.adaptive_top3`.
    out_t, out_A, out_R : ndarray
        Row buffers (capacity ``out_t.size``; the loop stops when they are full).

    Returns
    -------
    status, t, h, k, accepted, rejected, nfev, rows
        As :func:`lieint.fast.top3_adaptive.adaptive_top3`.
    """
    N, n = A.shape[0], A.shape[1]
    r = R.shape[1]
    s = b.shape[0]
    cap = out_t.shape[0]
    K = np.zeros((s, n, n))
    W = np.zeros((8, n, n))
    E = np.zeros((5, n, n))
    U = np.zeros((7, n, n))
    Ah = np.zeros((n, n))
    Rh = np.zeros((r, r))
    A1 = np.empty((N, n, n))
    R1 = np.empty((N, r, r))
    count = float(N * (2 * n * n if orient else n * n))
    accepted = 0
    rejected = 0
    nfev = 0
    rows = 0
    status = 0
    after_rejection = False
    while t < t1 and accepted < max_accept and rows < cap:
        h = min(h, t1 - t)
        ok = True
        s5 = 0.0
        s3 = 0.0
        for m in range(N):
            A1[m, :, :] = A[m]
            R1[m, :, :] = R[m]
            if not _lie_step(A1[m], R1[m], orient, M, tab, b, h, coeffs, cayley, K, W, E):
                ok = False
                break
            _user_pair(A[m], R[m], orient, P, identity, U[0], U[1], U[6])
            _user_pair(A1[m], R1[m], orient, P, identity, U[2], U[3], U[6])
            _embedded(A[m], R[m], orient, M, K, b_hat, h, cayley, W, E, Ah, Rh)
            s5 += _error_sum(Ah, Rh, orient, P, identity, rtol, atol, U)
            if has_low:
                _embedded(A[m], R[m], orient, M, K, b_low, h, cayley, W, E, Ah, Rh)
                s3 += _error_sum(Ah, Rh, orient, P, identity, rtol, atol, U)
        if ok:
            nfev += s
        err = error_norm(ok, s5, s3, has_low, count)
        if not math.isfinite(err) or err >= 1.0:
            rejected += 1
            after_rejection = True
            h *= step_factor(err, q, safety, fmin, fmax, False)
            if h < h_min:
                status = 1
                break
            continue
        t = advanced_time(t, h, t1, h_min)
        for m in range(N):
            A[m, :, :] = A1[m]
            if orient:
                R[m, :, :] = _project(R1[m]) if project else R1[m]
        k += 1
        accepted += 1
        if k % save_every == 0 or t == t1:
            out_t[rows] = t
            out_A[rows] = A
            out_R[rows] = R
            rows += 1
        h *= step_factor(err, q, safety, fmin, fmax, after_rejection)
        after_rejection = False
    return status, t, h, k, accepted, rejected, nfev, rows


@njit(cache=True)
def _principal_field(A, R, M, orient, dA, dR):
    """:func:`lieint.fast.topn_step._field` of every body into ``dA``, ``dR``."""
    for m in range(A.shape[0]):
        fA, fR = _field(A[m], R[m], M, orient)
        dA[m] = fA
        if orient:
            dR[m] = fR


@njit(cache=True)
def _user_flat(A, R, P, identity):
    """``(P Ã Pᵀ, R̃ Pᵀ)`` of every body (the state or its derivative), flattened into one vector
    (A's entries, then R's): the fields the generic controller measures."""
    if identity:
        return np.concatenate((A.ravel(), R.ravel()))
    out_A, out_R = np.empty_like(A), np.empty_like(R)
    _convert(A, R, P, False, out_A, out_R)
    return np.concatenate((out_A.ravel(), out_R.ravel()))


@njit(cache=True)
def initial_step_topn(A, R, orient, M, P, identity, rtol, atol, span, error_order):
    """scipy's (Hairer's) first trial step on the user's fields of the bodies ``(Ã, R̃)`` (N, n, n)
    in the principal frame: :meth:`lieint.control.StepSizeController.initial_step` (the same
    norms over every entry of A and R of every body, in the user's frame) with the vector field
    in machine code. The explicit Euler step ``y₀ + h₀f₀`` is taken in the principal frame,
    where it is the same linear map."""
    dA, dR = np.empty_like(A), np.empty_like(R)
    _principal_field(A, R, M, orient, dA, dR)
    Y, F0 = _user_flat(A, R, P, identity), _user_flat(dA, dR, P, identity)
    h0, d1 = first_guess(Y, F0, rtol, atol, span)
    A1, R1 = A + h0 * dA, R + h0 * dR
    _principal_field(A1, R1, M, orient, dA, dR)
    F1 = _user_flat(dA, dR, P, identity)
    return initial_step_from(h0, d1, Y, F0, F1, rtol, atol, span, error_order)
