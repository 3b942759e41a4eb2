"""The loops a :class:`~lieint.driver.Driver` runs, one per way of choosing steps and back end.

* :class:`_FixedLoop` — fixed steps on the global grid, the generic numpy path (any system,
  any method);
* :class:`_KernelLoop` — a compiled kernel (:mod:`lieint.fast`) stepping whole segments of the
  grid;
* :class:`_AdaptiveLoop`, :class:`_AdaptiveKernelLoop` — accepted and rejected steps under the
  step-size controller, generic or compiled;
* :class:`ScipyLoop` — scipy's solvers, which choose their own steps.

Each has ``start(y0) -> Carry``, ``first_row(carry)``, ``user_state(carry)`` and
``advance(carry, max_steps) -> Segment``; :class:`_KernelLoop` also has
``advance_from_start(carry)``, a whole run with its first row in one segment (the kernel writes
that row beside the others: no concatenation of an ensemble's rows). :func:`fixed_loop` and
:func:`adaptive_loop` pick the compiled loop where a kernel covers the run. A :class:`Carry` is
the exact state of a run between steps, so a run split into segments gives the bits of one that
is not.
"""

from __future__ import annotations

import functools
import math
import types
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from .groups.base import DexpinvRangeError
from .limits import RowBudget

__all__ = ["Carry", "ScipyLoop", "Segment", "adaptive_loop", "fixed_loop"]

# How often (in steps) a long stretch between saves is checked for non-finite values.
_FINITE_CHECK_EVERY = 256
#: no bound on the accepted steps of a call (``np.iinfo`` costs a few microseconds a look)
_NO_LIMIT = int(np.iinfo(np.int64).max)


class LoopHost(Protocol):
    """What a loop reads of the run it serves (:class:`lieint.driver.Driver` is the one).

    Written as a protocol so that the loops, one layer below the driver, need not import it.
    """

    system: Any
    method: Any
    observer: Any
    kind: str
    loop: Any
    t0: float
    t1: float
    direction: float
    h: float | None
    rtol: float
    atol: float
    max_step: float | None
    project: bool
    save_every: int
    save_times: np.ndarray | None
    plan: Any
    controller: Any
    backend_request: str

    def before_end(self, t: float) -> bool: ...


@dataclass
class Carry:
    """The exact state of a run between two steps.

    ``state`` is the loop's own representation of the system state (the state dict on the
    generic path, a compiled kernel's arrays otherwise); ``method_state`` is what the method
    carries between steps.
    """

    k: int
    t: float
    state: dict
    h: float | None = None
    method_state: Any = None
    nfev: int = 0
    nrejected: int = 0


@dataclass
class Segment:
    """What one :meth:`Driver.advance` produced: saved times ``(m,)``, saved states
    ``(m, *batch, ...)`` per field, and a failure message when the run cannot go on."""

    t: np.ndarray
    states: dict[str, np.ndarray]
    failure: str | None = None

    @property
    def rows(self) -> int:
        return int(self.t.size)


@functools.cache
def _fast() -> types.SimpleNamespace:
    """The compiled engine's modules the loops call, imported on first use — numba loads with
    them, and a run on the generic path never needs them — and once (an ``import`` statement in
    a function costs 0.6 µs a call; this cached call a tenth of that)."""
    from .fast import engine, finite

    return types.SimpleNamespace(engine=engine, finite=finite)


def fixed_loop(driver: LoopHost, y0: dict):
    """The compiled engine where it covers system and method, else the generic loop (dense
    output, events and ``t_eval`` are served from the engine's steps too)."""
    if driver.backend_request == "numpy":
        return _FixedLoop(driver, "backend='numpy' asked for the generic path")
    kernel, reason = _fast().engine.engine_for(
        driver.system, driver.method, y0, project=driver.project, h=driver.plan.h
    )
    if kernel is not None:
        return _KernelLoop(driver, kernel)
    if driver.backend_request == "numba":
        raise ValueError(f"`backend='numba'`: no compiled kernel covers this run: {reason}. Use 'auto' or 'numpy'.")
    return _FixedLoop(driver, reason)


class _GenericRows:
    """What the generic loops share: the carry holds the user's state itself."""

    d: LoopHost

    def first_row(self, carry: Carry) -> Segment:
        return Segment(np.array([self.d.t0]), {k: v[None] for k, v in carry.state.items()})

    def user_state(self, carry: Carry) -> dict:
        return carry.state


class _FixedLoop(_GenericRows):
    """Fixed steps on the global grid, generic numpy path (any system, any method)."""

    name = "numpy"

    def __init__(self, driver: LoopHost, reason: str):
        self.d, self.reason = driver, reason

    def start(self, y0: dict) -> Carry:
        d = self.d
        return Carry(0, d.t0, dict(y0), d.plan.h, d.method.init(d.system, d.t0, y0, d.plan.h))

    def advance(self, carry: Carry, max_steps: int | None) -> Segment:
        d = self.d
        system, method, plan = d.system, d.method, d.plan
        k_to = plan.nsteps if max_steps is None else min(plan.nsteps, carry.k + max_steps)
        saves = plan.saves_between(d.save_every, carry.k, k_to)
        y = carry.state
        saved = {name: np.empty((saves.size, *arr.shape)) for name, arr in y.items()}
        slot, failure = 0, None
        mstate = carry.method_state
        with np.errstate(over="ignore", invalid="ignore"):  # overflow is reported as a failure
            for k in range(carry.k, k_to):
                tk, hk = plan.t0 + k * plan.h, plan.step_size(k)
                try:
                    result = method.step(system, tk, y, hk, mstate)
                except np.linalg.LinAlgError as exc:  # a linear solve met a non-finite stage
                    failure = (
                        f"Step {k + 1} (t = {tk:.6g}) failed in a linear solve ({exc}): the stages became "
                        f"non-finite, the step `h` = {abs(plan.h):g} is far too large for this motion. Reduce `h`."
                    )
                    break
                carry.nfev += result.nfev
                try:
                    y_new = system.project(result.y) if d.project else result.y
                except np.linalg.LinAlgError:  # the SVD of a non-finite R
                    failure = _nonfinite(k + 1, plan.time(k + 1), f"Reduce the step `h` = {abs(plan.h):g}")
                    break
                saving = slot < saves.size and saves[slot] == k + 1
                if (saving or (k + 1) % _FINITE_CHECK_EVERY == 0) and not _all_finite(y_new):
                    failure = _nonfinite(k + 1, plan.time(k + 1), f"Reduce the step `h` = {abs(plan.h):g}")
                    break
                y_prev, y, mstate = y, y_new, result.state
                carry.k = k + 1
                if d.observer is not None and d.observer.step(tk, y_prev, plan.time(k + 1), y, result):
                    break
                if saving:
                    for name, arr in y.items():
                        saved[name][slot] = arr
                    slot += 1
        carry.state, carry.method_state, carry.t = y, mstate, plan.time(carry.k)
        return _stopped(
            d,
            carry,
            Segment(plan.times(saves[:slot]), {k: v[:slot] for k, v in saved.items()}, failure),
        )


class _CompiledRows:
    """What the compiled loops share: the kernel holds the state in its own representation, and
    turns it into the user's rows; it may also know the step check's radius of ξ."""

    kernel: Any
    d: LoopHost

    def first_row(self, carry: Carry) -> Segment:
        y = self.kernel.user_state(carry.state)
        return Segment(np.array([self.d.t0]), {k: v[None] for k, v in y.items()})

    def user_state(self, carry: Carry) -> dict:
        return self.kernel.user_state(carry.state)

    def generator_radius(self, states: dict, limit: float = 0.0) -> float | None:
        """The largest ad spectral radius of ξ(y) over the rows ``states`` (the user's frame),
        or an upper bound of it when that is below ``limit``, when the kernel computes it
        (``generator_radius``), else None."""
        radius = getattr(self.kernel, "generator_radius", None)
        return radius(states, limit) if radius is not None else None


class _KernelLoop(_CompiledRows):
    """A compiled kernel (:mod:`lieint.fast`) stepping whole segments of the grid."""

    name = "numba"

    def __init__(self, driver: LoopHost, kernel):
        self.d, self.kernel = driver, kernel
        self.reason = kernel.describe()
        self.threads = kernel.threads

    def start(self, y0: dict) -> Carry:
        return Carry(0, self.d.t0, self.kernel.start(y0), self.d.plan.h)

    def advance(self, carry: Carry, max_steps: int | None, with_start: bool = False) -> Segment:
        """At most ``max_steps`` steps (all that remain by default) in one kernel call;
        ``with_start`` puts the carry's state first among the rows (the kernel writes it where
        it writes the others: a whole run's rows need no concatenation). With dense output,
        events or ``t_eval`` the steps go in stretches the observer sees (:meth:`_observed`)."""
        d, plan = self.d, self.d.plan
        k_to = plan.nsteps if max_steps is None else min(plan.nsteps, carry.k + max_steps)
        if d.observer is not None:
            return self._observed(carry, k_to, with_start)
        saves = plan.saves_between(d.save_every, carry.k, k_to)
        new, states = self.kernel.advance(carry.state, carry.k, k_to, plan, saves, d.project, with_start=with_start)
        s = int(with_start)
        rows = saves.size + s
        failure = None
        if _fast().finite.all_finite([*states.values(), *new.values()]):
            carry.state, done = new, k_to
        else:
            finite = np.ones(rows, dtype=bool)
            for v in states.values():
                finite &= np.isfinite(v).all(axis=tuple(range(1, v.ndim)))  # also for no saved rows
            bad = int(np.argmin(finite)) if not finite.all() else rows
            states = {k: v[:bad] for k, v in states.items()}
            saves = saves[: max(bad - s, 0)]
            done = int(saves[-1]) if saves.size else carry.k
            # the run stops here (a failed run is not resumed: the failure would recur)
            failure = _nonfinite(done, plan.time(done), f"Reduce the step `h` = {abs(plan.h):g}", until=k_to)
        carry.nfev += _evaluations(self.kernel, done - carry.k, k_to - carry.k)
        t = plan.times(saves, first=carry.t if s else None)
        if failure:  # the rows kept before the first non-finite one
            t = t[: next(iter(states.values())).shape[0]]
        carry.k, carry.t = done, plan.time(done)
        return Segment(t, states, failure)

    def advance_from_start(self, carry: Carry) -> Segment:
        """The whole run from a fresh carry: its first row (the starting state) and every saved
        row in one segment."""
        return self.advance(carry, None, with_start=True)

    def _observed(self, carry: Carry, k_end: int, with_start: bool) -> Segment:
        """Steps to ``k_end`` in stretches of growing length (512 … 8,192 steps: a terminal event
        wastes little, the memory of the kept steps stays bounded), each stretch's every step
        kept (its state and increment) and handed to the observer as a table of steps
        (:meth:`lieint.observe.StepObserver.segment`), which locates the events on the steps'
        interpolants, extends the dense output and saves the ``t_eval`` rows."""
        d, plan, kernel = self.d, self.d.plan, self.kernel
        times, parts, failure = [], [], None
        if with_start:
            times.append(np.array([carry.t]))
            parts.append({k: v[None] for k, v in kernel.user_state(carry.state).items()})
        chunk = 512
        nothing = np.empty(0, dtype=np.int64)
        while carry.k < k_end:
            k_from, k_to = carry.k, min(k_end, carry.k + chunk)
            chunk = min(2 * chunk, 8192)
            # every step is kept, the starting state first: the saved rows are among them (one
            # conversion, and no copy but the final join)
            new, _, (kept_Y, kept_U) = kernel.advance(carry.state, k_from, k_to, plan, nothing, d.project, keep=True)
            rows = kernel.user_rows(kept_Y)
            start, steps = {k: v[0] for k, v in rows.items()}, {k: v[1:] for k, v in rows.items()}
            good = _finite_rows(steps)
            if good < k_to - k_from:  # the run stops before the first non-finite state
                done = k_from + good
                failure = _nonfinite(done + 1, plan.time(done + 1), f"Reduce the step `h` = {abs(plan.h):g}")
                steps = {k: v[:good] for k, v in steps.items()}
                rows = {k: v[: good + 1] for k, v in rows.items()}
                kept_U, k_to = kept_U[:good], done
                new = kernel.internal(_last(steps, start))
            saves = plan.saves_between(d.save_every, k_from, k_to)
            if saves.size == k_to - k_from:  # every step saved: the rows after the start, no copy
                states = {k: v[1:] for k, v in rows.items()}
            else:
                states = {k: v[saves - k_from] for k, v in rows.items()}
            table = d.observer.table(
                plan.times(np.arange(k_from, k_to + 1)), rows, self._increments(kept_U), kernel.tableau.cayley
            )
            stopped = d.observer.segment(table)
            done = k_from + table.steps
            carry.nfev += _evaluations(kernel, done - k_from, k_to - k_from)
            carry.k, carry.t = done, plan.time(done)
            carry.state = new if not stopped else kernel.internal(d.observer.stop[1])
            times.append(plan.times(saves))
            parts.append(states)
            if stopped:
                carry.t = d.observer.stop[0]
            if stopped or failure:
                break
        return _stopped(d, carry, _joined(times, parts, failure, lambda: self.user_state(carry)))

    def _increments(self, kept_U):
        """The kept steps' increments in the user's algebra, converted when an interpolant asks
        for one (None for classical RK, whose dense output interpolates the state arrays)."""
        if self.kernel.du == 0:
            return None
        kernel = self.kernel
        return lambda j: _take(kernel.increments(kept_U[j : j + 1]), 0)


class _AdaptiveLoop(_GenericRows):
    """Accepted and rejected steps under the step-size controller (generic numpy path)."""

    name = "numpy"

    def __init__(self, driver: LoopHost, reason: str = "adaptive steps run on the generic path"):
        self.d, self.reason = driver, reason
        self.h_min = 1e-14 * max(1.0, abs(driver.t0), abs(driver.t1))

    def start(self, y0: dict) -> Carry:
        d = self.d
        h = d.h if d.h is not None else d.controller.initial_step(d.system, d.t0, y0, d.t1, d.method.error_order)
        h = _first_trial(d, h)
        return Carry(0, d.t0, dict(y0), h, d.method.init(d.system, d.t0, y0, h))

    def advance(self, carry: Carry, max_steps: int | None) -> Segment:
        d = self.d
        system, method, ctrl = d.system, d.method, d.controller
        q = method.error_order
        t, y, h, mstate = carry.t, carry.state, carry.h, carry.method_state
        times, rows = [], []
        taken, failure = 0, None
        budget = _row_budget(d, y)
        rejected = False  # the current step was rejected at least once (scipy: no growth then)
        forward, h_max = d.direction > 0, d.max_step
        while d.before_end(t) and (max_steps is None or taken < max_steps):
            if abs(h) > h_max:  # scipy's max_step: no trial step is longer
                h = math.copysign(h_max, h)
            h = min(h, d.t1 - t) if forward else max(h, d.t1 - t)  # the last step lands on t1
            try:
                with np.errstate(over="ignore", invalid="ignore"):
                    result = method.step(system, t, y, h, mstate)
                carry.nfev += result.nfev
                err = ctrl.error_norm(y, result.y, result.error)
            except DexpinvRangeError:
                err = math.inf
            if not math.isfinite(err) or err >= 1.0:
                carry.nrejected += 1
                rejected = True
                h *= ctrl.factor(err, q)
                if abs(h) < self.h_min:
                    failure = self._too_small(t)
                    break
                continue
            t_prev, y_prev = t, y
            t = d.t1 if d.direction * (d.t1 - (t + h)) <= self.h_min else t + h
            y = system.project(result.y) if d.project else result.y
            mstate = result.state
            carry.k += 1
            taken += 1
            if d.observer is not None and d.observer.step(t_prev, y_prev, t, y, result):
                break
            if carry.k % d.save_every == 0 or t == d.t1:
                budget.hold(len(rows) + 1)
                times.append(t)
                rows.append(y)
            h *= ctrl.factor(err, q, after_rejection=rejected)
            rejected = False
        carry.t, carry.state, carry.h, carry.method_state = t, y, h, mstate
        return _stopped(d, carry, Segment(np.array(times), _stack(rows, y), failure))

    def _too_small(self, t: float) -> str:
        d = self.d
        return (
            f"the step size fell below {self.h_min:.3g} at t = {t:.6g} without meeting rtol = "
            f"{d.rtol:g}, atol = {d.atol:g}; loosen the tolerances or check the model"
        )


def _evaluations(kernel, done: int, ran: int) -> int:
    """The evaluations of ``done`` of the ``ran`` steps a compiled call took: what the steps
    reported (a map's Newton or fixed-point iterations, an RKMK step's stages), in proportion
    when the run kept fewer steps than it took (a terminal event, a non-finite state)."""
    if ran <= 0 or done <= 0:
        return 0
    reported = getattr(kernel, "evaluations", None)
    if reported is None:
        return kernel.stages * done
    return reported if done == ran else round(reported * done / ran)


def adaptive_loop(driver: LoopHost, y0: dict):
    """The compiled engine's controller loop where it covers system and method, else the generic
    loop (dense output, events and ``t_eval`` are served from the engine's steps too)."""
    if driver.backend_request == "numpy":
        return _AdaptiveLoop(driver, "backend='numpy' asked for the generic path")
    kernel, reason = _fast().engine.engine_for(driver.system, driver.method, y0, adaptive=True, project=driver.project)
    if kernel is not None:
        return _AdaptiveKernelLoop(driver, kernel)
    if driver.backend_request == "numba":
        raise ValueError(f"`backend='numba'`: no compiled kernel covers this run: {reason}. Use 'auto' or 'numpy'.")
    return _AdaptiveLoop(driver, reason)


class _AdaptiveKernelLoop(_CompiledRows, _AdaptiveLoop):
    """The compiled adaptive kernel (:mod:`lieint.fast.adaptive`): the whole controller loop in
    machine code; the carry holds the kernel's state, ``t`` and the next trial step ``h``."""

    name = "numba"

    def __init__(self, driver: LoopHost, kernel):
        super().__init__(driver, kernel.describe())
        self.kernel, self.threads = kernel, kernel.threads

    def start(self, y0: dict) -> Carry:
        d = self.d
        state = self.kernel.start(y0)
        if d.h is not None:
            h = d.h
        else:  # the first trial step with the engine's compiled vector field (two evaluations
            # of the generic one cost 40–85 µs of an adaptive call on the heavy top and the balls)
            h = self.kernel.initial_step(y0, d.t0, d.t1, d.controller, d.method.error_order)
        return Carry(0, d.t0, state, _first_trial(d, h), None)

    def advance(self, carry: Carry, max_steps: int | None, with_start: bool = False) -> Segment:
        """At most ``max_steps`` accepted steps (all that remain by default); ``with_start`` puts
        the carry's state first among the rows (the kernel writes it where it writes the others:
        a whole run's rows need no concatenation)."""
        d = self.d
        left = _NO_LIMIT if max_steps is None else max_steps
        if d.observer is not None:
            if not with_start:
                return self._observed(carry, left)
            first = self.first_row(carry)  # before the steps move the carry
            segment = self._observed(carry, left)
            return _joined([first.t, segment.t], [first.states, segment.states], segment.failure, dict)
        times, parts, failure = [], [], None
        budget, held = _row_budget(d, self.kernel.row_bytes), 0
        start = with_start
        while d.before_end(carry.t) and left > 0:
            # at most the accepted steps whose rows still fit under the memory limit, and one
            # row more, which the budget refuses: the kernel's buffer never outgrows the limit
            room = (budget.rows - held + 1) * d.save_every
            state, (t, h, k), (acc, rej, nfev), t_saved, saved, small = self.kernel.advance_adaptive(
                carry.state, carry.t, d.t1, carry.h, carry.k, min(left, room), d.save_every, d.project, d.controller,
                self.h_min, d.max_step, with_start=start,
            )  # fmt: skip
            held -= int(start)  # the starting row is the run's first, not one its steps saved
            start = False
            carry.state, carry.t, carry.h, carry.k = state, t, h, k
            carry.nrejected += rej
            carry.nfev += nfev
            left -= acc
            times.append(t_saved)
            parts.append(saved)
            held += t_saved.size
            budget.hold(held)
            if small:
                failure = self._too_small(t)
                break
        if start:  # no step taken (an empty span): the starting row alone
            first = self.first_row(carry)
            times.insert(0, first.t)
            parts.insert(0, first.states)
        return _joined(times, parts, failure, lambda: self.user_state(carry))

    def advance_from_start(self, carry: Carry) -> Segment:
        """The whole run from a fresh carry: its first row (the starting state) and every saved
        row in one segment."""
        return self.advance(carry, None, with_start=True)

    def _observed(self, carry: Carry, left: int) -> Segment:
        """Accepted steps in stretches of growing length (as :meth:`_KernelLoop._observed`), every
        accepted step kept for the observer; the user's rows are the steps a run without an
        observer saves (every ``save_every``-th accepted step and the last)."""
        d, kernel = self.d, self.kernel
        times, parts, failure = [], [], None
        budget, held = _row_budget(d, self.user_state(carry)), 0
        chunk = 256
        while d.before_end(carry.t) and left > 0:
            start, t_start, k_start = self.user_state(carry), carry.t, carry.k
            flat_start = carry.state["Y"]
            state, (t, h, k), (acc, rej, nfev), t_steps, steps, small, (kept_Y, kept_U) = kernel.advance_adaptive(
                carry.state, carry.t, d.t1, carry.h, carry.k, min(left, chunk), 1, d.project, d.controller,
                self.h_min, d.max_step, keep=True,
            )  # fmt: skip
            chunk = min(2 * chunk, 8192)
            carry.state, carry.t, carry.h, carry.k = state, t, h, k
            carry.nrejected += rej
            carry.nfev += nfev
            left -= acc
            rows = {name: np.concatenate([start[name][None], v]) for name, v in steps.items()}
            times_here = np.concatenate([[t_start], t_steps])
            table = d.observer.table(
                times_here, rows, self._increments(kept_U), kernel.tableau.cayley,
                restep=self._restep(times_here, flat_start, kept_Y),
            )  # fmt: skip
            stopped = d.observer.segment(table)
            numbers = k_start + 1 + np.arange(table.steps)
            keep = (numbers % d.save_every == 0) | (t_steps[: table.steps] == d.t1)
            times.append(t_steps[: table.steps][keep])
            parts.append({name: v[: table.steps][keep] for name, v in steps.items()})
            held += int(keep.sum())
            budget.hold(held)
            if stopped:
                carry.k, carry.t = k_start + table.steps, d.observer.stop[0]
                carry.state = kernel.internal(d.observer.stop[1])
                break
            if small:
                failure = self._too_small(t)
                break
        return _stopped(d, carry, _joined(times, parts, failure, lambda: self.user_state(carry)))

    def _increments(self, kept_U):
        kernel = self.kernel
        return lambda j: _take(kernel.increments(kept_U[j : j + 1]), 0)

    def _restep(self, times, flat_start, kept_Y):
        """``restep(j, t)`` of a table of the energy pairs' steps (None for other methods): their
        dense output steps again from each step's start (:class:`lieint.dense.Restep`) — a curve
        through the rows would err ~10⁵× more than their steps, which may spin the body by radians
        about the momentum axis — with the engine's own step."""
        kernel = self.kernel
        if not getattr(kernel.method, "keeps_energy", False):
            return None

        def restep(j, t):
            Y = flat_start if j == 0 else kept_Y[j - 1]
            return kernel.restep(Y, float(times[j]), float(t) - float(times[j]))

        return restep


class ScipyLoop:
    """scipy's ``OdeSolver`` stepping itself; rows saved at accepted steps or, through its dense
    output, at the requested save times (projected copies when the run projects)."""

    name = "scipy"
    reason = "scipy's solve_ivp solver"

    def __init__(self, driver: LoopHost):
        self.d = driver

    def start(self, y0: dict) -> Carry:
        d = self.d
        solver, layout = d.method.start(d.system, d.t0, y0, d.t1, d.rtol, d.atol, first_step=None)
        self.layout = layout
        self.next_save = 1  # index into save_times (0 is t0)
        # the save times as direction·t, increasing either way (decreasing times backward), for
        # the bisection of each step
        st = d.save_times
        self.save_keys = None if st is None else (st if d.direction > 0 else -st)
        return Carry(0, d.t0, {"solver": solver}, None)

    def first_row(self, carry: Carry) -> Segment:
        y0 = self.user_state(carry)
        return Segment(np.array([self.d.t0]), {k: np.asarray(v)[None] for k, v in y0.items()})

    def user_state(self, carry: Carry) -> dict:
        return self.layout.unpack(carry.state["solver"].y.copy())

    def _row(self, z: np.ndarray) -> dict:
        y = self.layout.unpack(z)
        return self.d.system.project(y) if self.d.project else y

    def advance(self, carry: Carry, max_steps: int | None) -> Segment:
        d = self.d
        solver = carry.state["solver"]
        times, rows = [], []
        taken, failure = 0, None
        budget = _row_budget(d, self.user_state(carry))
        nfev0 = solver.nfev
        while solver.status == "running" and (max_steps is None or taken < max_steps):
            t_old = solver.t
            message = solver.step()
            if solver.status == "failed":
                failure = f"scipy's {d.method.name} failed at t = {t_old:.6g}: {message}"
                break
            taken += 1
            carry.k += 1
            t_reach, stopped = solver.t, False
            if d.observer is not None:
                y_new = self.layout.unpack(solver.y.copy())
                stopped = d.observer.step_with(t_old, solver.t, y_new, self._dense(solver))
                t_reach = d.observer.stop[0] if stopped else t_reach
            if stopped and d.save_times is None:
                break
            if d.save_times is None:
                if carry.k % d.save_every == 0 or solver.status == "finished":
                    budget.hold(len(rows) + 1)
                    times.append(solver.t)
                    rows.append(self._row(solver.y.copy()))
                continue
            st = d.save_times
            stop = int(np.searchsorted(self.save_keys, d.direction * t_reach, side="right"))
            if stop > self.next_save:
                dense = solver.dense_output()
                budget.hold(len(rows) + stop - self.next_save)
                for j in range(self.next_save, stop):
                    z = solver.y.copy() if st[j] == solver.t else dense(st[j])
                    times.append(float(st[j]))
                    rows.append(self._row(z))
                self.next_save = stop
            if stopped:
                break
        carry.nfev += solver.nfev - nfev0
        carry.t = d.t1 if solver.status == "finished" else solver.t
        return _stopped(d, carry, Segment(np.array(times), _stack(rows, self.user_state(carry)), failure))

    def _dense(self, solver):
        """scipy's interpolant of the last step, as states."""
        dense, unpack = solver.dense_output(), self.layout.unpack
        return lambda t: unpack(dense(t))


# -- helpers ---------------------------------------------------------------------------------------


def _first_trial(d: LoopHost, h: float) -> float:
    """The first trial step of an adaptive run from its size ``h`` (given, or scipy's estimate):
    at most ``max_step`` and the span, signed by the run's direction."""
    return d.direction * min(h, d.max_step, abs(d.t1 - d.t0))


def _row_budget(d: LoopHost, like: dict | int) -> RowBudget:
    """The rows an adaptive segment may hold (:class:`lieint.limits.RowBudget`), each a time and
    a state like ``like`` (or of ``like`` bytes): tolerances below what round-off lets the error
    estimate resolve drive the step size down without end, every step saved."""
    size = like if isinstance(like, int) else sum(np.asarray(v).nbytes for v in like.values())
    return RowBudget(
        8 + size,
        lambda rows: (
            f"the memory of the {rows} rows saved so far by an adaptive run of {d.method.name} with "
            f"`rtol` = {d.rtol:g}, `atol` = {d.atol:g}, `save_every` = {d.save_every} (bytes)"
        ),
        "loosen the tolerances (round-off bounds how small they can usefully be), raise save_every, "
        "or stream the run to a file (lieint run --out, lieint.runs.run)",
    )


def _stopped(d: LoopHost, carry: Carry, segment: Segment) -> Segment:
    """After a terminal event: the run ends at the event (its state is the last row)."""
    stop = d.observer.stop if d.observer is not None else None
    if stop is None or (carry.t == stop[0] and segment.rows and segment.t[-1] == stop[0]):
        return segment
    t_stop, y_stop = stop
    if d.kind != "scipy" and not isinstance(d.loop, _CompiledRows):  # a compiled loop set its own
        carry.state = y_stop
    carry.t = t_stop
    keep = d.direction * segment.t < d.direction * t_stop  # the rows before the event, either way in time
    return Segment(
        np.append(segment.t[keep], t_stop),
        {k: np.concatenate([v[keep], np.asarray(y_stop[k])[None]]) for k, v in segment.states.items()},
        segment.failure,
    )


def _joined(times: list, parts: list[dict], failure, like: Callable[[], dict]) -> Segment:
    """One segment of the saved times and rows of several kernel calls (``like()``: a state, for
    the shapes of a segment of no rows)."""
    if not parts:
        return Segment(np.empty(0), {name: np.empty((0, *np.shape(v))) for name, v in like().items()}, failure)
    if len(parts) == 1:  # one call's rows, fresh already
        return Segment(times[0], parts[0], failure)
    states = {name: np.concatenate([p[name] for p in parts]) for name in parts[0]}
    return Segment(np.concatenate(times), states, failure)


def _finite_rows(rows: dict) -> int:
    """How many leading rows of ``rows`` (a dict of ``(m, ...)`` arrays) are finite."""
    if _fast().finite.all_finite(list(rows.values())):  # the usual case, in one pass
        return int(next(iter(rows.values())).shape[0])
    finite = None
    for v in rows.values():
        ok = np.isfinite(v).all(axis=tuple(range(1, v.ndim)))
        finite = ok if finite is None else finite & ok
    if finite is None or finite.all():
        return 0 if finite is None else int(finite.size)
    return int(np.argmin(finite))


def _last(rows: dict, start: dict) -> dict:
    """The last row of ``rows``, or ``start`` when there is none."""
    if next(iter(rows.values())).shape[0] == 0:
        return start
    return {k: v[-1] for k, v in rows.items()}


def _take(x, j):
    """Element j of an array, or of each array of a tuple (a product group's algebra)."""
    return tuple(_take(part, j) for part in x) if isinstance(x, tuple) else x[j]


def _stack(rows: list[dict], like: dict) -> dict:
    if rows:
        return {name: np.stack([r[name] for r in rows]) for name in rows[0]}
    return {name: np.empty((0, *np.shape(v))) for name, v in like.items()}


def _finite(arr: np.ndarray) -> bool:
    return bool(np.logical_and.reduce(np.isfinite(arr), axis=None))


def _all_finite(y: dict) -> bool:
    return all(_finite(arr) for arr in y.values())


def _nonfinite(k: int, t: float, advice: str, until: int | None = None) -> str:
    """The message of a run whose state became non-finite by step k, or (a compiled segment,
    which reports only its saved rows) after step k and by step ``until``."""
    where = f"by step {k}" if until is None else f"after step {k} and by step {until}"
    return (
        f"The state became non-finite (NaN or inf) {where} (t = {t:.6g}); the run stopped there. "
        f"{advice} or check the initial state."
    )
