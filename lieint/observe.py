"""What the driver does between accepted steps when a run asks for dense output, events or
``t_eval``: one interpolant per step (:mod:`lieint.dense`), the events watched on it
(:mod:`lieint.events`) and the rows at the requested times.

The driver (:mod:`lieint.driver`) calls :meth:`StepObserver.start` once and
:meth:`StepObserver.step` after every accepted step; a terminal event sets ``stop`` and the
driver ends the run there. At the end :meth:`StepObserver.finish` puts ``sol``,
``t_events``, ``y_events`` (and the ``t_eval`` rows) on the :class:`~lieint.Solution`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .dense import DenseOutput, EmbeddedHermite, Increment, LieHermite, Restep, StepTable, earlier_nodes
from .events import EventLog, as_events

__all__ = ["StepObserver", "group_action_of"]


def group_action_of(method) -> bool | str:
    """How ``method`` moves the state, as :class:`StepObserver` takes it (``group_action``)."""
    if getattr(method, "group_action", False):
        return True
    return "fields" if getattr(method, "keeps_group_fields", False) else False


class StepObserver:
    """Dense output, events and ``t_eval`` rows of one run.

    Parameters
    ----------
    system : LieGroupSystem
    t0 : float
    t_eval : ndarray, optional
        Times in the span at which to save the state (from the interpolants; ``t0`` itself is
        saved from the initial state), strictly increasing (strictly decreasing for a run
        backward in time); they need not start at ``t0`` nor end at ``t1``.
    dense_output : bool
        Keep every interpolant (``sol.sol``).
    events : callable or list of callables, optional
        See :mod:`lieint.events`.
    project : bool
        Project the ``t_eval`` rows onto the manifold (as the driver does for saved rows).
    order : int, optional
        The method's order p: Lie-group interpolants then also match the last one (p = 5, 6)
        or two (p ≥ 7) earlier step ends, so that the dense output has order min(p, 8)
        (cubic, quintic, degree 7; the first steps of a run have fewer earlier ends).
    direction : float, default 1.0
        +1 for a run forward in time, −1 backward (``t1 < t0``: the ``t_eval`` times decrease).
    group_action : {False, True, "fields"}
        How the method moves the state. True: by the group action, so a step that reports no
        :class:`~lieint.dense.Increment` gets one from the system's
        :meth:`~lieint.systems.base.LieGroupSystem.relative_element` (``g = R₀ᵀR₁``) and is
        interpolated on the group like any Lie-group step. "fields": only the group-valued
        fields stay on the group (the Lie–Poisson midpoint); the curve ``ρ(exp(u(θ)), y₀)`` is
        then corrected by ``h₀₁(θ) (y₁ − ρ(exp(u₁), y₀))`` so that it ends at ``y₁`` (the
        correction vanishes to round-off on the fields moved as ``Y ↦ Y g``).
    """

    def __init__(
        self,
        system,
        t0: float,
        *,
        t_eval=None,
        dense_output: bool = False,
        events=None,
        project=False,
        order=None,
        group_action=False,
        direction: float = 1.0,
    ):
        self.system, self.t0 = system, float(t0)
        self.direction = -1.0 if direction < 0 else 1.0
        self.group_action = group_action
        self.extra_nodes = 0 if not order or order <= 4 else 1 if order <= 6 else 2
        self.history: list[tuple] = []  # (t_j, ξ_j, u_j) of the last steps, newest last
        self.t_eval = None if t_eval is None else np.asarray(t_eval, dtype=float)
        self.dense = DenseOutput(t0) if dense_output else None
        self.log = EventLog(as_events(events))
        self.project = bool(project)
        self.rows: list[dict] = []
        self.next_eval = 0
        self.nfev = 0
        self._cache: tuple | None = None  # (t, y, ξ or f, is-Lie) at the last step's end
        self.stop: tuple[float, dict] | None = None

    @property
    def active(self) -> bool:
        return self.dense is not None or bool(self.log.events) or self.t_eval is not None

    def start(self, t0: float, y0: dict) -> None:
        self.log.start(t0, y0)
        self._save_until(t0, y0, None, t0)

    # -- per step --------------------------------------------------------------------------
    def step(self, t0: float, y0: dict, t1: float, y1: dict, result) -> bool:
        """After an accepted step of a lieint method; True when a terminal event stops the run."""
        return self.step_with(t0, t1, y1, self._interpolant(t0, y0, t1, y1, result))

    def step_with(self, t0: float, t1: float, y1: dict, interpolant) -> bool:
        """After an accepted step whose interpolant is given (scipy's dense output)."""
        stop = self.log.step(t0, t1, y1, interpolant) if self.log.events else None
        t_end, y_end = (t1, y1) if stop is None else stop
        if self.dense is not None:
            self.dense.append(t_end, interpolant)
        self._save_until(t_end, y_end, interpolant, t1)
        if stop is not None:
            self.stop = stop
            return True
        return False

    def segment(self, table) -> bool:
        """After a stretch of compiled steps (a :class:`lieint.dense.StepTable`); True when a
        terminal event stops the run (within the table: ``stop`` holds its time and state)."""
        stop = self.log.segment(table) if self.log.events else None
        if stop is not None:
            table.truncate(stop[0])
        if self.dense is not None:
            self.dense.extend(table)
        if self.t_eval is not None:
            self._save_table(table, stop)
        self.history = table.next_history()
        self.nfev += table.nfev
        table.nfev = 0
        if stop is not None:
            self.stop = stop
            return True
        return False

    def table(self, t, rows: dict, increments, cayley: bool = False, restep=None):
        """A :class:`~lieint.dense.StepTable` of steps ending at ``t`` (the stretch's start first),
        with this run's history of earlier steps. Steps without increments of a method that moves
        by the group action get each step's element from its states, as :meth:`step` does;
        ``restep(j, t)`` (the energy pairs) steps again from step end j instead."""
        derived = False
        if increments is None and self.group_action and len(t) > 1:
            first = ({k: v[0] for k, v in rows.items()}, {k: v[1] for k, v in rows.items()})
            derived = self.group_action if self.system.relative_element(*first) is not None else False
        return StepTable(
            self.system, t, rows, increments, cayley=cayley, extra_nodes=self.extra_nodes, history=self.history,
            derived=derived, restep=restep,
        )  # fmt: skip

    def _save_table(self, table, stop) -> None:
        """The ``t_eval`` rows within the table (as far as its end)."""
        te, t_end, way = self.t_eval, table.end, self.direction
        while self.next_eval < te.size and way * te[self.next_eval] <= way * t_end:
            s = float(te[self.next_eval])
            y = stop[1] if stop is not None and s == stop[0] else table(s)
            self.rows.append(self.system.project(y) if self.project else y)
            self.next_eval += 1

    def _save_until(self, t_end: float, y_end: dict, interpolant, t1: float) -> None:
        if self.t_eval is None:
            return
        te, way = self.t_eval, self.direction
        while self.next_eval < te.size and way * te[self.next_eval] <= way * t_end:
            s = float(te[self.next_eval])
            y = y_end if s == t_end else interpolant(s)
            self.rows.append(self.system.project(y) if self.project else y)
            self.next_eval += 1

    def _interpolant(self, t0: float, y0: dict, t1: float, y1: dict, result):
        system = self.system
        increment = result.dense
        if isinstance(increment, Restep):  # the method's own step from y₀, of any size up to h
            # with the ends as the run keeps them (a last step snapped onto t1, a projected y₁)
            return dataclasses.replace(increment, t0=t0, y0=y0, t1=t1, y1=y1)
        if self.group_action and not isinstance(increment, Increment):
            g = system.relative_element(y0, y1)
            increment = None if g is None else Increment(g=g)
        lie = isinstance(increment, Increment)
        evaluate = system.generator if lie else system.vector_field
        if self._cache is not None and self._cache[0] == t0 and self._cache[1] is y0 and self._cache[3] == lie:
            d0 = self._cache[2]
        else:
            d0 = evaluate(t0, y0)
            self.nfev += 1
        d1 = evaluate(t1, y1)
        self.nfev += 1
        self._cache = (t1, y1, d1, lie)
        if lie:
            group = system.group
            u = increment.algebra(group)
            earlier = earlier_nodes(group, self.history)
            if self.extra_nodes:
                self.history = [*self.history, (t0, d0, u)][-self.extra_nodes :]
            mismatch = None
            if self.group_action == "fields":
                moved = system.act(group.exp(u), y0)
                mismatch = {k: y1[k] - moved[k] for k in y1}
            return LieHermite(system, t0, t1, y0, u, d0, d1, y1, earlier, mismatch=mismatch)
        return EmbeddedHermite(t0, t1, y0, y1, d0, d1)

    # -- the result ------------------------------------------------------------------------
    def finish(self, sol) -> None:
        """Put the dense output, the events and the ``t_eval`` rows on the solution."""
        like = {k: v[0] for k, v in sol.states.items()}
        sol.sol = self.dense
        if self.stop is not None and sol.success:
            sol.status = 1  # scipy's OdeResult: a terminal event stopped the run
        if self.log.events:
            sol.t_events, sol.y_events = self.log.results(like)
        if self.t_eval is not None:
            n = len(self.rows)
            sol.t = self.t_eval[:n].copy()
            sol.states = (
                {k: np.stack([r[k] for r in self.rows]) for k in like}
                if n
                else {k: np.empty((0, *np.shape(v))) for k, v in like.items()}
            )
            sol.__post_init__()  # the lazy invariants follow the new rows
        sol.stats.nfev += self.nfev
