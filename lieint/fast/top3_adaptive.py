"""Compiled adaptive RKMK for the 3D Euler top (numba, cached on disk).

The whole adaptive loop — trial step, error norm, accept or reject, next step size — runs in
machine code, for one body or a batch sharing one step size, with the generic path's
controller (:class:`lieint.control.StepSizeController`) constant for constant:

* a trial step from ``y₀`` computes the stages ``k_i`` of the order-p tableau with the stage
  code of :mod:`lieint.fast.top3` (``_lie_step``: Rodrigues, dexp⁻¹ truncated at the method's
  degree, in the principal frame ``(Π, R P)``), the propagated solution
  ``y₁ = ρ(exp(h Σ b_j k_j), y₀)`` and the embedded one(s) ``ŷ = ρ(exp(h Σ b̂_j k_j), y₀)``;
* the error is measured on the **user's** fields, as the generic path measures it: with P the
  proper principal frame, ``A = P(−Π̂)Pᵀ = −(PΠ)^`` (conjugation by a rotation moves the hat
  map's vector by P), so the nine entries of A are ``0`` (diagonal) and ``±(PΠ)_k`` (twice
  each), and ``R_user = R Pᵀ``. Componentwise
  ``r_i = (y₁ − ŷ)_i / (atol + rtol·max(|y₀,i|, |y₁,i|))`` over the 9 entries of A and the 9 of
  R (when the system carries R) of every body; ``err = √(Σ r_i²/N)``, or DOP853's
  ``err = s₅/√((s₅ + 0.01 s₃)·N)`` with ``s = Σ r_i²`` of the two estimates;
* ``err ≥ 1`` (or non-finite, or a stage beyond the dexp⁻¹ radius ``|u| ≥ 2π``) rejects the
  step and retries with ``h·max(f_min, safety·err^{−1/(q+1)})``; an accepted step moves the
  state (projected by one Newton–Schulz step when asked), saves every ``save_every``-th step
  and the last one, and proposes ``h·min(f_max, safety·err^{−1/(q+1)})``, capped at ``h`` right
  after a rejection (the controller's arithmetic, shared with the generic kernel's loop:
  :mod:`lieint.fast.controller`).

The loop stops at ``t1``, after ``max_accept`` accepted steps or when the row buffer is full,
and hands back ``(t, h)``: the controller's whole state between accepted steps (the
after-rejection flag is always clear there), so a run split into calls takes the same steps as
one call. ``tests/test_fast_adaptive.py`` checks it against the generic path.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .controller import advanced_time, error_norm, step_factor
from .top3 import _lie_step, _newton_schulz, _rodrigues

__all__ = ["adaptive_top3"]


@njit(cache=True)
def _embedded(pi0, R0, K, w, h, u, Q, out_pi, out_R):
    """``ρ(exp(h Σ_j w_j k_j), (Π₀, R₀))`` into out_pi (3,), out_R (3, 3)."""
    u[0] = 0.0
    u[1] = 0.0
    u[2] = 0.0
    for j in range(w.shape[0]):
        c = h * w[j]
        if c != 0.0:
            u[0] += c * K[j, 0]
            u[1] += c * K[j, 1]
            u[2] += c * K[j, 2]
    _rodrigues(u, Q)
    for r in range(3):
        out_pi[r] = Q[0, r] * pi0[0] + Q[1, r] * pi0[1] + Q[2, r] * pi0[2]
        for c2 in range(3):
            out_R[r, c2] = R0[r, 0] * Q[0, c2] + R0[r, 1] * Q[1, c2] + R0[r, 2] * Q[2, c2]


@njit(cache=True)
def _scaled(pi0, R0, pi1, R1, pih, Rh, P, orientation, rtol, atol, U0, U1, Uh):
    """``Σ_i r_i²`` over the user-frame entries of A (and R) of one body (see the module text)."""
    total = 0.0
    for r in range(3):
        a0 = P[r, 0] * pi0[0] + P[r, 1] * pi0[1] + P[r, 2] * pi0[2]
        a1 = P[r, 0] * pi1[0] + P[r, 1] * pi1[1] + P[r, 2] * pi1[2]
        ah = P[r, 0] * pih[0] + P[r, 1] * pih[1] + P[r, 2] * pih[2]
        x = (a1 - ah) / (atol + rtol * max(abs(a0), abs(a1)))
        total += 2.0 * x * x  # A = −(PΠ)^ holds each component twice, with both signs
    if orientation:
        for r in range(3):
            for c2 in range(3):  # R_user = R Pᵀ
                U0[r, c2] = R0[r, 0] * P[c2, 0] + R0[r, 1] * P[c2, 1] + R0[r, 2] * P[c2, 2]
                U1[r, c2] = R1[r, 0] * P[c2, 0] + R1[r, 1] * P[c2, 1] + R1[r, 2] * P[c2, 2]
                Uh[r, c2] = Rh[r, 0] * P[c2, 0] + Rh[r, 1] * P[c2, 1] + Rh[r, 2] * P[c2, 2]
        for r in range(3):
            for c2 in range(3):
                x = (U1[r, c2] - Uh[r, c2]) / (atol + rtol * max(abs(U0[r, c2]), abs(U1[r, c2])))
                total += x * x
    return total


@njit(cache=True)
def adaptive_top3(
    pi,
    R,
    Iinv,
    A,
    b,
    b_hat,
    b_low,
    has_low,
    coeffs,
    P,
    orientation,
    rtol,
    atol,
    q,
    safety,
    fmin,
    fmax,
    h_min,
    t,
    t1,
    h,
    k,
    max_accept,
    save_every,
    project,
    out_t,
    out_pi,
    out_R,
):
    """Adaptive RKMK steps from ``t`` in place on ``pi`` (N, 3) and ``R`` (N, 3, 3).

    Parameters
    ----------
    pi, R : ndarray
        The state ``(Π, R P)`` of the N bodies in the principal frame (moved in place).
    Iinv : ndarray, shape (3,)
        Inverse principal moments (``w = I⁻¹Π``).
    A, b, b_hat, b_low : ndarray
        The order-p tableau and the embedded weights; ``b_low`` (with ``has_low``) is DOP853's
        third-order estimate, combined as ``s₅/√((s₅ + 0.01 s₃)·N)``.
    coeffs : ndarray
        Bernoulli coefficients of dexp⁻¹ up to the method's degree.
    P : ndarray, shape (3, 3)
        The proper principal frame: the user's ``A = P(−Π̂)Pᵀ``, ``R_user = R Pᵀ``.
    orientation : bool
        Whether R is one of the user's fields (it then enters the error norm).
    rtol, atol, q, safety, fmin, fmax : float
        The controller (:class:`lieint.control.StepSizeController`); q the error order.
    h_min : float
        A rejected step smaller than this ends the run (status 1).
    t, t1, h, k : float, float, float, int
        Current time, end, next trial step and accepted steps so far.
    max_accept, save_every : int
        Stop after this many accepted steps; save every ``save_every``-th step and the last.
    project : bool
        One Newton–Schulz step toward the polar factor of R after every accepted step.
    out_t, out_pi, out_R : ndarray
        Row buffers (capacity ``out_t.size``; the loop stops when they are full).

    Returns
    -------
    status, t, h, k, accepted, rejected, nfev, rows
        ``status`` 0, or 1 when the step size fell below ``h_min`` (the state stays at ``t``);
        the controller's state ``(t, h)`` and the step count k after the call; the accepted and
        rejected trial steps and the generator evaluations of this call (a trial stopped at the
        dexp⁻¹ radius counts as a rejection without evaluations, as on the generic path); the
        saved rows are ``out_*[:rows]``.
    """
    N = pi.shape[0]
    s = b.shape[0]
    cap = out_t.shape[0]
    K = np.zeros((s, 3))
    u = np.zeros(3)
    Q = np.zeros((3, 3))
    tpi = np.zeros(3)
    tR = np.zeros((3, 3))
    U0 = np.zeros((3, 3))
    U1 = np.zeros((3, 3))
    Uh = np.zeros((3, 3))
    pih = np.zeros(3)
    Rh = np.zeros((3, 3))
    pi1 = np.empty((N, 3))
    R1 = np.empty((N, 3, 3))
    count = float(N * (18 if orientation else 9))
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
        for n in range(N):
            for r in range(3):
                pi1[n, r] = pi[n, r]
                for c2 in range(3):
                    R1[n, r, c2] = R[n, r, c2]
            if not _lie_step(pi1[n], R1[n], Iinv, A, b, h, coeffs, K, u, Q, tpi, tR):
                ok = False
                break
            _embedded(pi[n], R[n], K, b_hat, h, u, Q, pih, Rh)
            s5 += _scaled(pi[n], R[n], pi1[n], R1[n], pih, Rh, P, orientation, rtol, atol, U0, U1, Uh)
            if has_low:
                _embedded(pi[n], R[n], K, b_low, h, u, Q, pih, Rh)
                s3 += _scaled(pi[n], R[n], pi1[n], R1[n], pih, Rh, P, orientation, rtol, atol, U0, U1, Uh)
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
        for n in range(N):
            for r in range(3):
                pi[n, r] = pi1[n, r]
                for c2 in range(3):
                    R[n, r, c2] = R1[n, r, c2]
            if project:
                _newton_schulz(R[n], Q)
        k += 1
        accepted += 1
        if k % save_every == 0 or t == t1:
            out_t[rows] = t
            for n in range(N):
                for r in range(3):
                    out_pi[rows, n, r] = pi[n, r]
                    for c2 in range(3):
                        out_R[rows, n, r, c2] = R[n, r, c2]
            rows += 1
        h *= step_factor(err, q, safety, fmin, fmax, after_rejection)
        after_rejection = False
    return status, t, h, k, accepted, rejected, nfev, rows
