"""Compiled adaptive RKMK for every system with compiled pieces (numba, cached on disk).

The controller loop of :mod:`lieint.fast.top3_adaptive` — trial step, error norm, accept or
reject, next step size, the generic path's controller constant for constant — around the stage
code of the generic compiled kernel (:func:`lieint.fast.generic_step.lie_step`), for one body or a
batch sharing one step size:

* a trial step computes the stages ``k_i``, ``y₁ = ρ(exp(h Σ b_j k_j), y₀)`` and the embedded
  ``ŷ = ρ(exp(h Σ b̂_j k_j), y₀)`` (and DOP853's second, weights ``b̂₃``);
* the error is measured on the flattened state — every field of the user's state, in the
  user's frame, as the generic path measures it:
  ``r_i = (y₁ − ŷ)_i / (atol + rtol·max(|y₀,i|, |y₁,i|))``, ``err = √(Σ r_i²/N)`` over all
  entries of all bodies, or ``s₅/√((s₅ + 0.01 s₃)·N)`` for DOP853;
* ``err ≥ 1`` (or non-finite, or a stage beyond the dexp⁻¹ radius) rejects the step, an
  accepted one moves (and, asked, projects) the state, saves every ``save_every``-th step and
  the last, and proposes the next step as :class:`lieint.control.StepSizeController` does.

The loop hands back ``(t, h)`` between accepted steps, so a run split into calls takes the
same steps as one call.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from .controller import advanced_time, error_norm, first_guess, initial_step_from, step_factor
from .generic import LieKernel
from .generic_step import move_either, step_either, step_work
from .pairs import CompiledPair, row_capacity
from .pieces import BUNDLE

__all__ = ["LieAdaptiveKernel", "adaptive_lie", "initial_step_lie"]

_vec = types.float64[::1]
_mat = types.float64[:, ::1]


@njit(cache=True)
def _scaled(y0, y1, yh, rtol, atol):
    """``Σ_i ((y₁ − ŷ)_i / (atol + rtol·max(|y₀,i|, |y₁,i|)))²``."""
    total = 0.0
    for i in range(y0.shape[0]):
        x = (y1[i] - yh[i]) / (atol + rtol * max(abs(y0[i]), abs(y1[i])))
        total += x * x
    return total


_SIGNATURE = types.Tuple((types.int64, types.float64, types.float64) + (types.int64,) * 5)(
    BUNDLE,
    _mat,  # Y (N, d), moved in place
    _vec,  # params
    types.int64,  # nv
    types.int64,  # m
    _mat,  # tableau A
    _vec,  # b
    _vec,  # b_hat
    _vec,  # b_low
    types.boolean,  # has_low
    _vec,  # dexp⁻¹ coefficients
    types.float64,  # rtol
    types.float64,  # atol
    types.int64,  # q
    types.float64,  # safety
    types.float64,  # fmin
    types.float64,  # fmax
    types.float64,  # h_min
    types.float64,  # t
    types.float64,  # t1
    types.float64,  # h
    types.int64,  # k
    types.int64,  # max_accept
    types.int64,  # save_every
    types.boolean,  # project
    types.boolean,  # cayley
    _vec,  # out_t
    types.float64[:, :, ::1],  # out_Y (cap, N, d)
    types.int64,  # work_size: the pieces' scratch length
)


@njit(_SIGNATURE, cache=True)
def adaptive_lie(
    pieces, Y, par, nv, m, A, b, b_hat, b_low, has_low, coeffs, rtol, atol, q, safety, fmin, fmax, h_min,
    t, t1, h, k, max_accept, save_every, project, cayley, out_t, out_Y, work_size,
):  # fmt: skip
    """Adaptive RKMK steps from ``t`` in place on the flattened states ``Y`` (N, d).

    Arguments and results as :func:`lieint.fast.top3_adaptive.adaptive_top3`, with the
    system's compiled pieces (:data:`lieint.fast.pieces.BUNDLE`: its generator, action and
    projection), its parameters ``par``, ``nv = n`` on SE(n) (0 on SO(n)) and m the size of its
    vector factor. Returns ``(status, t, h, k, accepted, rejected, nfev, rows)``.
    """
    # one by one: a tuple of function values makes numba unify their types (and warn)
    gen = pieces.generator
    act = pieces.action
    proj = pieces.projection
    N, d = Y.shape
    n = int(par[0])
    s = b.shape[0]
    cap = out_t.shape[0]
    KW = np.zeros((s, n, n))
    Kv = np.zeros((s, nv))
    Ka = np.zeros((s, m))
    y_stage = np.empty(d)
    yh = np.empty(d)
    S, Sv, ua, aug, work = step_work(n, nv, m, work_size)
    uncounted = cayley or n == 3  # the step's copy without reference counts applies
    Y1 = np.empty((N, d))
    count = float(N * d)
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
        for body in range(N):
            y0, y1 = Y[body], Y1[body]
            stepped = step_either(
                uncounted, gen, act, y0, par, nv, A, b, h, coeffs, KW, Kv, Ka, y_stage, y1, cayley,
                S, Sv, ua, aug, work,
            )  # fmt: skip
            if not stepped:
                ok = False
                break
            move_either(uncounted, act, y0, par, nv, KW, Kv, Ka, b_hat, h, yh, cayley, S, Sv, ua, aug, work)
            s5 += _scaled(Y[body], Y1[body], yh, rtol, atol)
            if has_low:
                move_either(uncounted, act, y0, par, nv, KW, Kv, Ka, b_low, h, yh, cayley, S, Sv, ua, aug, work)
                s3 += _scaled(Y[body], Y1[body], yh, rtol, atol)
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
        for body in range(N):
            if project:
                proj(Y1[body], par, Y[body], work)
            else:
                Y[body] = Y1[body]
        k += 1
        accepted += 1
        if k % save_every == 0 or t == t1:
            out_t[rows] = t
            out_Y[rows] = Y
            rows += 1
        h *= step_factor(err, q, safety, fmin, fmax, after_rejection)
        after_rejection = False
    return status, t, h, k, accepted, rejected, nfev, rows


@njit(cache=True)
def initial_step_lie(bundle, Y, params, rtol, atol, span, error_order, work_size):
    """scipy's (Hairer's) first trial step on the flattened states ``Y`` (N, d) of every body,
    with the system's compiled vector field: :meth:`lieint.control.StepSizeController.initial_step`
    (the same norms over every component of every body) without its two evaluations in Python."""
    N, d = Y.shape
    work = np.empty(work_size)
    F0, F1, Y1 = np.empty((N, d)), np.empty((N, d)), np.empty((N, d))
    for m in range(N):
        bundle.vector_field(Y[m], params, F0[m], work)
    h0, d1 = first_guess(Y, F0, rtol, atol, span)
    for m in range(N):
        for i in range(d):
            Y1[m, i] = Y[m, i] + h0 * F0[m, i]
        bundle.vector_field(Y1[m], params, F1[m], work)
    return initial_step_from(h0, d1, Y, F0, F1, rtol, atol, span, error_order)


class LieAdaptiveKernel(LieKernel):
    """Adaptive RKMK through the generic compiled kernel: the whole controller loop in machine
    code, serial (a batch shares one step size), state flattened as :class:`LieKernel`'s."""

    def __init__(self, sys_decl: dict, meth_decl: dict, batch: tuple[int, ...]):
        super().__init__(sys_decl, meth_decl, None, batch)
        self.parallel, self.threads = False, 1
        self.pair = CompiledPair.from_declaration(meth_decl)
        self.tab_A = np.array(meth_decl["A"], dtype=float)
        self.tab_b = np.array(meth_decl["b"], dtype=float)

    def describe(self) -> str:
        kind = "adaptive RKMK (Cayley)" if self.cayley else "adaptive RKMK"
        return f"compiled Lie-group kernel on {self.group}, {kind} (whole controller loop), per body, serial"

    def generator_radius(self, states: dict, limit: float = 0.0) -> None:
        """None: this loop keeps no bound of ξ (the fixed-step check does not apply to it)."""
        return None

    def initial_step(self, internal: dict, t0: float, t1: float, controller, error_order: int) -> float:
        """The first trial step, :meth:`lieint.control.StepSizeController.initial_step` with the
        compiled vector field (:func:`initial_step_lie`)."""
        return float(
            initial_step_lie(
                self.pieces.bundle, internal["Y"], self.params, float(controller.rtol), float(controller.atol),
                float(t1 - t0), int(error_order), self.pieces.work_size(self.n),
            )
        )  # fmt: skip

    def advance_adaptive(self, internal: dict, t, t1, h, k, max_accept, save_every, project, controller, h_min):
        """Accepted steps from ``(t, h)`` at step ``k`` until ``t1``, ``max_accept`` accepted
        steps or :data:`lieint.fast.pairs.ROWS_PER_CALL` saved rows (see
        :meth:`lieint.fast.adaptive.Top3AdaptiveKernel.advance_adaptive`)."""
        Y = internal["Y"].copy()
        N, d = Y.shape
        cap = row_capacity(8 * d * N, max_accept, save_every)
        out_t, out_Y = np.empty(cap), np.empty((cap, N, d))
        status, t, h, k, accepted, rejected, nfev, rows = adaptive_lie(
            self.pieces.bundle,
            Y,
            self.params,
            self.n if self.translation else 0,
            self.m,
            self.tab_A,
            self.tab_b,
            self.pair.b_hat,
            self.pair.b_low,
            self.pair.has_low,
            self.coeffs,
            float(controller.rtol),
            float(controller.atol),
            self.pair.error_order,
            float(controller.safety),
            float(controller.factor_min),
            float(controller.factor_max),
            float(h_min),
            float(t),
            float(t1),
            float(h),
            int(k),
            int(min(max_accept, np.iinfo(np.int64).max)),
            int(save_every),
            bool(project),
            self.cayley,
            out_t,
            out_Y,
            self.pieces.work_size(self.n),
        )
        saved = self._user(out_Y[:rows])
        return {"Y": Y}, (t, h, k), (accepted, rejected, nfev), out_t[:rows].copy(), saved, status == 1
