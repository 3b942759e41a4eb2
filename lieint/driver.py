"""The one driver: steps a system with a method, saves, projects, counts, and builds the result.

:func:`lieint.integrate`, streamed runs (:mod:`lieint.runs`), the work–precision study and the
command line all run through :class:`Driver`:

* ``start(y0) -> Carry`` — the exact state of a run between steps (what a checkpoint holds);
* ``advance(carry, max_steps) -> Segment`` — continue for at most ``max_steps`` accepted steps
  (or to the end), returning the rows saved on the way;
* ``solution(y0, segments, carry, ...)`` — the one place that builds a :class:`~lieint.Solution`.

How the steps are chosen depends on the method (see :mod:`lieint.methods.base`):

* fixed-step methods walk the global grid of a :class:`~lieint.control.Plan` (a compiled kernel
  takes over whole segments where one covers system and method, see :mod:`lieint.fast`);
* methods with an error estimate (``adaptive``) are wrapped by a
  :class:`~lieint.control.StepSizeController`;
* scipy's solvers choose their own steps; the driver calls their ``step()`` and saves through
  their dense output (``self_controlled``).

Because the carry is exact across segment boundaries, a run split anywhere gives the same bits
as one that is not.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from .control import Plan, StepSizeController
from .limits import check as check_limit
from .loops import Carry, ScipyLoop, Segment, adaptive_loop, fixed_loop
from .solution import Solution

__all__ = ["Carry", "Driver", "Segment", "Stats"]


@dataclass
class Stats:
    """What a run cost and how it ran (every method, every front end).

    Attributes
    ----------
    method : str
        The method's name.
    order : int or None
        Its order.
    coordinates : str or None
        Coordinate map of Lie-group methods.
    backend : str
        "numba" (compiled kernel), "numpy" (generic path) or "scipy".
    backend_reason : str
        Why this back end ran (e.g. why no compiled kernel covers the run).
    nsteps : int
        Accepted steps.
    nrejected : int
        Rejected trial steps (adaptive methods).
    nfev : int
        Generator / vector-field evaluations (one evaluation moves the whole batch); for an
        implicit map, its iterations (the Moser–Veselov maps' Newton iterations, the midpoint's
        fixed-point evaluations). On the compiled engine each body iterates on its own and a
        batch reports the most any body spent.
    cpu_time, wall_time : float
        Seconds spent stepping (process CPU time, all threads; and elapsed time).
    h : float or None
        Step of fixed-step methods.
    rtol, atol : float or None
        Tolerances of adaptive methods.
    project : bool
        Whether the state was projected onto its manifold.
    save_every : int
        Saving stride in steps.
    threads : int
        Threads the compiled kernel may use (1 on the generic path).
    """

    method: str
    order: int | None
    coordinates: str | None
    backend: str
    backend_reason: str = ""
    nsteps: int = 0
    nrejected: int = 0
    nfev: int = 0
    cpu_time: float = 0.0
    wall_time: float = 0.0
    h: float | None = None
    rtol: float | None = None
    atol: float | None = None
    project: bool = False
    save_every: int = 1
    threads: int = 1

    def __getitem__(self, key: str):
        # a mapping view for readers of the earlier dict of statistics
        return getattr(self, key)


class Driver:
    """Run ``method`` on ``system`` over ``t_span`` (arguments validated by the caller).

    Parameters
    ----------
    system : LieGroupSystem
    method : Method
    t_span : (float, float)
        ``(t0, t1)``; ``t1 < t0`` integrates backward in time (every step is then negative:
        ``direction`` is −1).
    h : float, optional
        Step size (positive; its sign follows ``t_span``) of fixed-step methods (required for
        them); first trial step of adaptive ones; for scipy's solvers, the grid of save times.
    rtol, atol : float
        Tolerances of adaptive methods.
    project : bool
        Project the state onto its manifold after every step (scipy: the saved copies only).
    save_every : int
        Save every k-th step (and the last one).
    t_eval : ndarray, optional
        Save times of scipy's solvers.
    max_step : float, optional
        The largest step of lieint's adaptive methods (scipy's ``max_step``; None: no bound).
    backend : {"auto", "numpy", "numba"}
    observer : StepObserver, optional
        Dense output, events and ``t_eval`` rows of lieint's methods (:mod:`lieint.observe`);
        it sees every accepted step (the compiled engine hands it tables of its kept steps) and may
        stop the run.
    """

    def __init__(
        self,
        system,
        method,
        t_span: tuple[float, float],
        *,
        h: float | None = None,
        rtol: float = 1e-8,
        atol: float = 1e-10,
        project: bool = False,
        save_every: int = 1,
        t_eval=None,
        max_step: float | None = None,
        backend: str = "auto",
        observer=None,
    ):
        self.system, self.method = system, method
        self.observer = observer if observer is not None and observer.active else None
        self.t0, self.t1 = float(t_span[0]), float(t_span[1])
        #: +1 forward in time, −1 backward (``t1 < t0``): the sign of every step
        self.direction = 1.0 if self.t1 >= self.t0 else -1.0
        self.h, self.rtol, self.atol = h, rtol, atol
        self.max_step = math.inf if max_step is None else float(max_step)
        self.project, self.save_every, self.backend_request = bool(project), int(save_every), backend
        method.check_system(system)
        if method.self_controlled:
            self.kind = "scipy"
            if t_eval is not None:
                self.save_times = np.asarray(t_eval, dtype=float)
            elif h is not None:
                plan = Plan.make(self.t0, self.t1, self.direction * h)
                self.save_times = plan.times(plan.save_steps(self.save_every))
            else:
                self.save_times = None
        elif method.adaptive:
            self.kind = "adaptive"
            self.controller = StepSizeController(rtol, atol)
        else:
            if h is None:
                raise ValueError(f"`h` (the step size) is required for the fixed-step method {method.name!r}.")
            self.kind = "fixed"
            self.plan = Plan.make(self.t0, self.t1, self.direction * h)
        self.loop = None

    # -- the run -----------------------------------------------------------------------------
    def start(self, y0: dict) -> Carry:
        """The carry before the first step (``y0`` validated; projected first when asked)."""
        y0 = self.initial(y0)
        if self.kind == "fixed":
            self.loop = fixed_loop(self, y0)
        elif self.kind == "adaptive":
            self.loop = adaptive_loop(self, y0)
        else:
            self.loop = ScipyLoop(self)
        carry = self.loop.start(y0)
        if self.observer is not None:
            self.observer.start(self.t0, self.loop.user_state(carry))
        return carry

    def initial(self, y0: dict) -> dict:
        """The state the run starts from (projected when the run projects)."""
        return self.system.project(y0) if self.project else y0

    def done(self, carry: Carry) -> bool:
        """True once the run has reached ``t1`` (or a terminal event stopped it)."""
        if self.observer is not None and self.observer.stop is not None:
            return True
        if self.kind == "fixed":
            return carry.k >= self.plan.nsteps
        return not self.before_end(carry.t)

    def before_end(self, t: float) -> bool:
        """Whether ``t`` lies before ``t1`` in the run's direction (the run goes on from there)."""
        return t < self.t1 if self.direction > 0 else t > self.t1

    def advance(self, carry: Carry, max_steps: int | None = None) -> Segment:
        """Take at most ``max_steps`` accepted steps (all that remain by default)."""
        if max_steps is not None and max_steps < 1:
            raise ValueError(f"`max_steps` must be >= 1; got {max_steps!r}.")
        return self.loop.advance(carry, max_steps)

    def user_state(self, carry: Carry) -> dict:
        """The state dict of the carry."""
        return self.loop.user_state(carry)

    def generator_radius(self, states: dict, limit: float = 0.0) -> float | None:
        """The largest ad spectral radius of the generator ξ(y) over the rows ``states`` when the
        run's back end computes it in one pass (a compiled kernel's ``generator_radius``: the
        3D top's ``max |ω|``), else None (the caller evaluates ξ). Below ``limit`` an upper
        bound may stand for it (the step check asks only whether it reaches π/h)."""
        radius = getattr(self.loop, "generator_radius", None)
        return radius(states, limit) if radius is not None else None

    @property
    def backend(self) -> str:
        return self.loop.name if self.loop is not None else "?"

    @property
    def backend_reason(self) -> str:
        return getattr(self.loop, "reason", "")

    @property
    def checkpointable(self) -> bool:
        """False for scipy's solvers, whose internal state cannot be saved (a resumed run
        recomputes from the start and skips the rows written already)."""
        return self.kind != "scipy"

    def total_steps(self) -> int | None:
        """Steps of the whole run when known in advance (fixed grids)."""
        return self.plan.nsteps if self.kind == "fixed" else None

    def progress(self, carry: Carry) -> float:
        """Fraction of ``[t0, t1]`` covered."""
        return min(1.0, (carry.t - self.t0) / (self.t1 - self.t0))

    # -- the result ----------------------------------------------------------------------------
    def stats(self, carry: Carry, cpu: float = 0.0, wall: float = 0.0) -> Stats:
        m, fixed = self.method, self.kind == "fixed"
        # by position, in the order of Stats' fields (sixteen keywords cost 0.6 µs a call)
        return Stats(
            m.name, m.order, m.coordinates, self.backend, self.backend_reason,  # method … backend_reason
            carry.k, carry.nrejected, carry.nfev, cpu, wall,  # nsteps … wall_time
            self.h if fixed else None, None if fixed else self.rtol, None if fixed else self.atol,  # h, rtol, atol
            self.project, self.save_every, getattr(self.loop, "threads", 1),  # project, save_every, threads
        )  # fmt: skip

    def run(self, y0: dict):
        """Integrate over the whole span; returns the :class:`~lieint.Solution`."""
        if self.kind == "fixed":  # every saved row is held in memory: refuse what cannot fit
            rows = self.plan.nsteps // self.save_every + 2
            size = 0
            for v in y0.values():  # a loop, not a generator: no frame resumed per field
                size += np.asarray(v).nbytes
            size *= rows
            check_limit(
                "LIEINT_MAX_MEMORY",
                float(size),
                lambda: (
                    f"the memory for the {rows} rows saved with `h` = {abs(self.plan.h):g}, "
                    f"`save_every` = {self.save_every} (bytes)"
                ),
                "raise save_every, or stream the run to a file (lieint run --out, lieint.runs.run)",
            )
        cpu0, wall0 = time.process_time(), time.perf_counter()
        carry = self.start(y0)
        whole = getattr(self.loop, "advance_from_start", None)
        if whole is not None:  # a compiled kernel writes the first row beside the others
            first, segments = whole(carry), []
        else:
            first = self.loop.first_row(carry)
            segments = [self.advance(carry)]
        cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
        return self.solution(first, segments, carry, cpu, wall)

    def solution(self, first: Segment, segments: list[Segment], carry: Carry, cpu: float, wall: float):
        """The :class:`~lieint.Solution` of the rows ``first`` and ``segments`` saved (``first``
        alone: the whole run's rows in one segment, taken as they are when contiguous — a copy
        of an ensemble's rows costs the page faults of fresh memory, about a millisecond for
        4,096 tops)."""
        parts = [first, *segments]
        if len(parts) == 1:
            t = np.asarray(first.t, dtype=float)
            states = {name: np.ascontiguousarray(v) for name, v in first.states.items()}
        else:
            t = np.concatenate([p.t for p in parts])
            states = {name: np.concatenate([p.states[name] for p in parts]) for name in first.states}
        if segments:
            failure = next((s.failure for s in parts if s.failure), None)
        else:  # one part (a compiled whole run): its failure, or None
            failure = first.failure or None
        stats = self.stats(carry, cpu, wall)
        stop = self.observer.stop if self.observer is not None else None
        if failure:
            message = failure
        elif stop is not None:
            message = f"A terminal event stopped the run at t = {stop[0]:.12g} after {carry.k} steps."
        elif self.kind == "fixed":
            message = f"Reached t1 = {self.t1:g} in {carry.k} steps."
        else:
            message = f"Reached t1 = {self.t1:g} in {carry.k} accepted steps ({carry.nrejected} rejected)."
        sol = Solution(t, states, self.system, self.method.name, stats, failure is None, message)
        if self.observer is not None:
            self.observer.finish(sol)
        return sol
