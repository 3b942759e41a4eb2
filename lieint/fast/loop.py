"""The one compiled loop: fixed steps on the global grid, and the step-size controller.

Written once, compiled once per *form* — a system family's stage functions with one method
family's step (:mod:`lieint.fast.engine` binds them): the functions below call the global
names of the form's namespace, and :func:`lieint.fast._jit.compiled_copies` makes a copy of
this module's functions per form with those names bound to the form's numba functions, which
numba then compiles statically (the step inlined where LLVM chooses) and caches on disk under
the copy's own name. A form supplies:

* ``prepare(ctx)`` — what its stage functions need, from the per-run context (the compiled
  pieces of a generic system, nothing for the tops), read once per call;
* ``scratch(fx, meth, par, d)`` — its work arrays, allocated once per call and thread;
* ``step(fx, y, par, meth, h, y1, inc, aux, scr) -> int`` — one step from ``y`` into ``y1``;
  ``inc`` receives the step's increment in the algebra (what dense output interpolates),
  ``aux[0]`` the squared bound ``‖ξ(y)‖_F²`` of the step's first stage (or −1 when the step
  does not evaluate ξ); on fixed steps ``aux[1]`` holds the step's index k on the global grid
  (a generator of t alone, the Magnus methods', reads its samples by it); returns the
  evaluations it spent, or :data:`OUT_OF_RANGE` (−1) when a stage left the dexp⁻¹ radius;
* ``embedded(fx, y, par, meth, weights, h, yh, scr)`` — an embedded solution from the stages
  the last ``step`` left in ``scr`` (adaptive pairs);
* ``error_sum(fx, y0, y1, yh, par, rtol, atol, scr) -> float`` — ``Σ r_i²`` of the scaled
  differences over the components of the user's state (:mod:`lieint.fast.controller`);
* ``project(fx, y, par, out, scr)``, ``radius2(fx, y, par, scr) -> float`` (a squared upper
  bound of the ad spectral radius of ξ(y), ``‖ξ(y)‖_F²`` in general: the step check's), and
  ``user_field(fx, yu, par, fu, scr)``: the vector field at a state given in the user's flat
  layout (the fields one after another, in the user's frame), in that layout — what the first
  trial step's norms are taken on, as on the generic path.

The state of one body is a flat float vector in the form's layout (the principal frame of the
tops, the fields one after another for generic systems); the Python side
(:class:`lieint.fast.engine.Engine`) turns it into the user's fields. Everything else a run
needs — the grid, saving, projection, the rows a dense output or an event needs, the
controller — is here, once.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .controller import advanced_time, error_norm, first_guess, initial_step_from, step_factor

__all__ = ["OUT_OF_RANGE", "adaptive", "first_trial_step", "fixed"]

#: what a step returns when a stage increment left the radius of the dexp⁻¹ series
OUT_OF_RANGE = -1

# The names a form binds (placeholders: calling one unbound is a programming error).


def prepare(ctx):  # pragma: no cover - bound per form
    raise NotImplementedError


def scratch(fx, meth, par, d):  # pragma: no cover - bound per form
    raise NotImplementedError


def step(fx, y, par, meth, h, y1, inc, aux, scr):  # pragma: no cover - bound per form
    raise NotImplementedError


def embedded(fx, y, par, meth, weights, h, yh, scr):  # pragma: no cover - bound per form
    raise NotImplementedError


def error_sum(fx, y0, y1, yh, par, rtol, atol, scr):  # pragma: no cover - bound per form
    raise NotImplementedError


def project(fx, y, par, out, scr):  # pragma: no cover - bound per form
    raise NotImplementedError


def radius2(fx, y, par, scr):  # pragma: no cover - bound per form
    raise NotImplementedError


def user_field(fx, yu, par, fu, scr):  # pragma: no cover - bound per form
    raise NotImplementedError


@njit(cache=True, inline="always")
def _copy(src, dst):
    """``dst[:] = src`` by a loop (numba's slice assignment may allocate)."""
    for i in range(src.shape[0]):
        dst[i] = src[i]


def fixed(ctx, bodies, Y0, par, meth, grid, save_steps, outs):
    """Steps ``k_from < k ≤ k_to`` of the bodies ``lo ≤ m < hi`` (``bodies``) on the global grid.

    ``grid`` is ``(h, h_last, k_from, k_to, nsteps, project, sizes)``: the grid's steps have size
    h, its last ``h_last`` — or, when ``sizes`` has entries, step k has size ``sizes[k]`` (a
    schedule of steps, such as an adaptive run's accepted steps held fixed). ``outs`` is
    ``(out, fin, status, norm2, evals, kept_Y, kept_U)``. The state after each step of
    ``save_steps`` goes to ``out[slot, m]``, the state after ``k_to`` to ``fin[m]``;
    ``status[m]`` is −1, or the step at which a stage of body m left the dexp⁻¹ radius (the body
    stops there); ``norm2[m]`` the largest ``‖ξ‖_F²`` over body m's starting state and saved rows
    (the step check's bound); ``evals[m]`` the evaluations spent. When ``kept_Y`` has rows, every
    step's state and increment go to ``kept_Y[k − k_from, m]`` and ``kept_U[k − k_from, m]``
    (dense output and events). Releases the GIL (compiled with ``nogil``): threads run disjoint
    ranges of bodies.
    """
    lo, hi = bodies
    out, fin, status, norm2, evals, kept_Y, kept_U = outs
    h, h_last, k_from, k_to, nsteps, projecting, sizes = grid
    scheduled = sizes.shape[0] > 0
    fx = prepare(ctx)
    d = Y0.shape[1]
    scr = scratch(fx, meth, par, d)
    y = np.empty(d)
    y1 = np.empty(d)
    # the step always writes its increment (kept_U has the form's increment length, 0 rows
    # when the run keeps no steps)
    inc = np.empty(max(kept_U.shape[2], 1))
    aux = np.empty(2)  # the step's bound of ξ, and its index k
    keep = kept_Y.shape[0] > 0
    for body in range(lo, hi):
        _copy(Y0[body], y)
        slot = 0
        status[body] = -1
        # the bound of a saved row is read from the next step's first stage (ξ of that state)
        # when the step evaluates it there, else evaluated: `pending` marks a row not yet read
        norm2[body] = 0.0
        evals[body] = 0
        pending = True
        for k in range(k_from, k_to):
            if scheduled:
                hk = sizes[k]
            else:
                hk = h if k < nsteps - 1 else h_last
            aux[0] = -1.0
            aux[1] = k
            spent = step(fx, y, par, meth, hk, y1, inc, aux, scr)
            if spent < 0:
                status[body] = k
                pending = False
                break
            evals[body] += spent
            if pending:
                bound = aux[0] if aux[0] >= 0.0 else radius2(fx, y, par, scr)
                norm2[body] = max(norm2[body], bound)
                pending = False
            if projecting:
                project(fx, y1, par, y, scr)
            else:
                _copy(y1, y)
            if keep:
                _copy(y, kept_Y[k - k_from, body])
                _copy(inc, kept_U[k - k_from, body])
            if slot < save_steps.shape[0] and save_steps[slot] == k + 1:
                _copy(y, out[slot, body])
                slot += 1
                pending = True
        if pending:
            norm2[body] = max(norm2[body], radius2(fx, y, par, scr))
        _copy(y, fin[body])


def adaptive(ctx, Y, par, meth, pair, control, clock, out_t, out_Y, out_U):
    """Accepted steps under the step-size controller, in place on the states ``Y`` (N, d) of a
    batch that shares one step size.

    ``pair`` is ``(b_hat, b_low, has_low, q)``: the embedded weights (DOP853's third-order
    ones in ``b_low`` when ``has_low``) and the error order q; ``control`` is ``(rtol, atol,
    safety, f_min, f_max, h_min, count)`` with ``count`` the components of the user's state
    over the batch, then ``h_max`` (scipy's ``max_step``: no trial step is longer; ``inf`` for no
    bound); ``clock`` is ``(t, t1, h, k, max_accept, save_every, project)``, with ``h`` negative
    for a run backward in time (``t1 < t``). A trial
    step computes ``y₁`` and ``ŷ`` (and DOP853's second estimate) of every body from the same
    stages; ``err`` is scipy's RMS norm of the scaled differences over every component
    (:mod:`lieint.fast.controller`); ``err ≥ 1`` (or not finite, or a stage beyond the dexp⁻¹
    radius) rejects the step, an accepted one moves (and, asked, projects) the states, saves
    every ``save_every``-th step and the last into ``out_t``, ``out_Y`` (and its increments into
    ``out_U`` when that has rows: dense output and events), and proposes the next step size. Stops at
    ``t1``, after ``max_accept`` accepted steps or when the row buffers are full.

    Returns ``(status, t, h, k, accepted, rejected, nfev, rows)``: status 1 when the step size
    fell below ``h_min`` (the state stays at ``t``), 0 otherwise; the controller's state
    ``(t, h)`` between accepted steps, so a run split into calls takes the steps of one call.
    """
    b_hat, b_low, has_low, q = pair
    rtol, atol, safety, fmin, fmax, h_min, count, h_max = control
    t, t1, h, k, max_accept, save_every, projecting = clock
    direction = 1.0 if h >= 0.0 else -1.0  # every step has the sign of the first
    fx = prepare(ctx)
    N, d = Y.shape
    scr = scratch(fx, meth, par, d)
    Y1 = np.empty((N, d))
    yh = np.empty(d)
    # the steps write their increments always (out_U has the form's increment length; rows only
    # when the run keeps them: dense output, events)
    du = out_U.shape[2]
    U = np.empty((N, max(du, 1)))
    keep = out_U.shape[0] > 0
    aux = np.empty(1)
    cap = out_t.shape[0]
    accepted = 0
    rejected = 0
    nfev = 0
    rows = 0
    status = 0
    stages = 0
    after_rejection = False
    while direction * (t1 - t) > 0.0 and accepted < max_accept and rows < cap:
        if abs(h) > h_max:
            h = direction * h_max
        if direction * h > direction * (t1 - t):  # the last step lands on t1
            h = t1 - t
        ok = True
        s5 = 0.0
        s3 = 0.0
        for body in range(N):
            y0, y1 = Y[body], Y1[body]
            aux[0] = -1.0
            stages = step(fx, y0, par, meth, h, y1, U[body], aux, scr)
            if stages < 0:
                ok = False
                break
            embedded(fx, y0, par, meth, b_hat, h, yh, scr)
            s5 += error_sum(fx, y0, y1, yh, par, rtol, atol, scr)
            if has_low:
                embedded(fx, y0, par, meth, b_low, h, yh, scr)
                s3 += error_sum(fx, y0, y1, yh, par, rtol, atol, scr)
        if ok:
            nfev += stages
        err = error_norm(ok, s5, s3, has_low, count)
        if not math.isfinite(err) or err >= 1.0:
            rejected += 1
            after_rejection = True
            h *= step_factor(err, q, safety, fmin, fmax, False)
            if abs(h) < h_min:
                status = 1
                break
            continue
        t = advanced_time(t, h, t1, h_min)
        for body in range(N):
            if projecting:
                project(fx, Y1[body], par, Y[body], scr)
            else:
                _copy(Y1[body], Y[body])
        k += 1
        accepted += 1
        if k % save_every == 0 or t == t1:
            out_t[rows] = t
            for body in range(N):
                _copy(Y[body], out_Y[rows, body])
                if keep:
                    _copy(U[body], out_U[rows, body])
            rows += 1
        h *= step_factor(err, q, safety, fmin, fmax, after_rejection)
        after_rejection = False
    return status, t, h, k, accepted, rejected, nfev, rows


def first_trial_step(ctx, Yu, par, meth, tolerances, span, error_order):
    """scipy's (Hairer's) first trial step over the states ``Yu`` (N, du) of a batch in the
    user's flat layout, with the form's compiled vector field:
    :meth:`lieint.control.StepSizeController.initial_step` (the same norms over every component
    of every body, in the user's frame) without its two evaluations in Python. ``tolerances``
    is ``(rtol, atol)``; ``span`` is ``t1 − t0``, negative backward in time (the Euler step goes
    towards t1; the size returned is positive); ``d`` of the form's own layout is not needed here."""
    rtol, atol = tolerances
    direction = 1.0 if span >= 0.0 else -1.0
    span = abs(span)
    fx = prepare(ctx)
    N, du = Yu.shape
    scr = scratch(fx, meth, par, du)
    F0, F1, Y1 = np.empty((N, du)), np.empty((N, du)), np.empty((N, du))
    for m in range(N):
        user_field(fx, Yu[m], par, F0[m], scr)
    h0, d1 = first_guess(Yu, F0, rtol, atol, span)
    for m in range(N):
        for i in range(du):
            Y1[m, i] = Yu[m, i] + direction * h0 * F0[m, i]
        user_field(fx, Y1[m], par, F1[m], scr)
    return initial_step_from(h0, d1, Yu, F0, F1, rtol, atol, span, error_order)
