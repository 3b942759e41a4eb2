"""Events with scipy's semantics, located on the dense output of the group.

An event is a function ``g(t, y) -> float`` of the time and the state dict; an event occurs
where ``g`` changes sign between two accepted steps, and its time is found by Brent's method
(:func:`scipy.optimize.brentq`, ``xtol = 1e-12``) on the step's interpolant
(:mod:`lieint.dense`), so the event state lies on the manifold too. As in
:func:`scipy.integrate.solve_ivp`:

* ``g.terminal`` (bool or a positive int n): stop the run at the (n-th) occurrence;
* ``g.direction`` (> 0, < 0 or 0): keep only crossings from negative to positive, from
  positive to negative, or both.

Several events may be given as a list; ``Solution.t_events[i]`` and ``Solution.y_events[i]``
hold the times ``(k_i,)`` and the states (dict of ``(k_i, ...)`` arrays) of the i-th one.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["Event", "EventLog", "as_events"]

#: tolerance of the event times (absolute, in time)
EVENT_XTOL = 1e-12


@dataclass
class Event:
    """One event function with its settings (see the module docstring).

    ``vectorized``: whether ``fn`` takes the rows of many steps at once (times ``(m,)``, states
    of ``(m, ...)`` arrays) and returns ``(m,)`` values — True, False, or None: tried once on a
    compiled run's steps and kept when it agrees with the one-row calls (see
    :meth:`EventLog.segment`)."""

    fn: Callable
    terminal: int = 0
    direction: float = 0.0
    name: str = ""
    vectorized: bool | None = None

    def __call__(self, t: float, y: dict) -> float:
        value = self.fn(t, y)
        try:
            return float(value)
        except (TypeError, ValueError):
            raise ValueError(
                f"event {self.name!r} must return one number g(t, y); got {type(value).__name__} "
                f"of shape {np.shape(value)} (events need a single body, not a batch)."
            ) from None


def as_events(events) -> list[Event]:
    """Check and normalise ``events`` (a callable or a sequence of callables)."""
    if events is None:
        return []
    items = [events] if callable(events) else list(events) if isinstance(events, (list, tuple)) else None
    if items is None:
        raise TypeError(f"`events` must be a callable g(t, y) or a list of them; got {type(events).__name__}.")
    out = []
    for i, fn in enumerate(items):
        if not callable(fn):
            raise TypeError(f"`events[{i}]` must be a callable g(t, y); got {type(fn).__name__}.")
        terminal = getattr(fn, "terminal", False)
        if isinstance(terminal, (bool, np.bool_)):
            count = 1 if terminal else 0
        elif isinstance(terminal, (int, np.integer)) and terminal >= 0:
            count = int(terminal)
        else:
            raise ValueError(f"`events[{i}].terminal` must be a bool or an integer >= 0; got {terminal!r}.")
        direction = getattr(fn, "direction", 0.0)
        try:
            direction = float(direction)
        except (TypeError, ValueError):
            raise ValueError(f"`events[{i}].direction` must be a number; got {direction!r}.") from None
        vectorized = getattr(fn, "vectorized", None)
        if vectorized is not None and not isinstance(vectorized, (bool, np.bool_)):
            raise ValueError(f"`events[{i}].vectorized` must be True, False or None; got {vectorized!r}.")
        out.append(Event(fn, count, direction, getattr(fn, "__name__", f"event {i}"), vectorized))
    return out


class EventLog:
    """Watches the accepted steps of a run for the sign changes of its events.

    Call :meth:`start` with the initial state, then :meth:`step` after each accepted step
    with its interpolant; ``stop`` becomes ``(t, y)`` once a terminal event has fired.
    """

    def __init__(self, events: list[Event]):
        self.events = events
        self.times: list[list[float]] = [[] for _ in events]
        self.states: list[list[dict]] = [[] for _ in events]
        self.counts = [0] * len(events)
        self.values: list[float] = []
        self.stop: tuple[float, dict] | None = None

    def start(self, t0: float, y0: dict) -> None:
        self.values = [ev(t0, y0) for ev in self.events]

    def step(self, t0: float, t1: float, y1: dict, interpolant, new=None) -> tuple[float, dict] | None:
        """Record the events in ``(t0, t1]`` (``[t1, t0)`` for a step backward in time: a
        crossing's direction is read in the run's order, from ``t0`` to ``t1``, as scipy's);
        return ``(t, y)`` of a terminal one, else None (``new``: the events' values at
        ``(t1, y1)`` when known)."""
        from scipy.optimize import brentq

        new = [ev(t1, y1) for ev in self.events] if new is None else list(new)
        found = []
        for i, (ev, a, b) in enumerate(zip(self.events, self.values, new, strict=True)):
            up, down = a < 0 <= b, a > 0 >= b
            if not ((up and ev.direction >= 0) or (down and ev.direction <= 0)):
                continue

            def g(t, ev=ev, a=a, b=b):
                # Brent's method asks for the bracket's ends first: their values are known (the
                # interpolant passes through the step's ends), so they are not computed again
                if t == t0:
                    return a
                if t == t1:
                    return b
                return ev(t, interpolant(t))

            lo, hi = (t0, t1) if t1 >= t0 else (t1, t0)
            t_event = t1 if b == 0 else brentq(g, lo, hi, xtol=EVENT_XTOL, rtol=4 * np.finfo(float).eps)
            found.append((t_event, i))
        self.values = new
        way = 1.0 if t1 >= t0 else -1.0  # the events in the order the run meets them
        for t_event, i in sorted(found, key=lambda found: (way * found[0], found[1])):
            y_event = y1 if t_event == t1 else interpolant(t_event)
            self.times[i].append(t_event)
            self.states[i].append(y_event)
            self.counts[i] += 1
            ev = self.events[i]
            if ev.terminal and self.counts[i] >= ev.terminal:
                self.stop = (t_event, y_event)
                return self.stop
        return None

    def segment(self, table) -> tuple[float, dict] | None:
        """Record the events over the steps of a :class:`lieint.dense.StepTable` (a compiled
        run's): every event's values at the step ends at once where the event function takes
        many rows (:meth:`values_at`), then, at each step where one changes sign, what
        :meth:`step` does for that step (the time by Brent's method on its interpolant).
        Returns ``(t, y)`` of a terminal event, else None."""
        m = table.steps
        if not m:
            return None
        values = np.stack([self.values_at(ev, table) for ev in self.events])  # (events, m)
        before = np.concatenate([np.asarray(self.values, dtype=float)[:, None], values[:, :-1]], axis=1)
        up, down = (before < 0) & (values >= 0), (before > 0) & (values <= 0)
        direction = np.array([ev.direction for ev in self.events])[:, None]
        crossing = (up & (direction >= 0)) | (down & (direction <= 0))
        for j in np.flatnonzero(crossing.any(axis=0)):
            self.values = list(before[:, j])
            stop = self.step(float(table.t[j]), float(table.t[j + 1]), table.row(j + 1), table.interpolant(int(j)),
                             new=values[:, j])  # fmt: skip
            if stop is not None:
                return stop
        self.values = list(values[:, -1])
        return None

    @staticmethod
    def values_at(ev: Event, table) -> np.ndarray:
        """``g(t_i, y_i)`` at the ends of the table's steps (``(m,)``, the start excluded): one call
        with every row when the event function takes many (``ev.vectorized``; when not said, tried
        and kept if its values agree with one-row calls at three rows), else one call a row."""
        m = table.steps
        rows = {k: v[1:] for k, v in table.rows.items()}
        times = table.t[1:]
        if ev.vectorized is not False and m > 1:
            try:
                with np.errstate(all="ignore"):
                    got = np.asarray(ev.fn(times, rows), dtype=float)
            except Exception:  # a function of one row: called row by row below
                got = None
            if got is not None and got.shape == (m,):
                if ev.vectorized is None:  # the first look: three rows one by one must agree
                    picks = sorted({0, m // 2, m - 1})
                    one = [ev(float(times[i]), {k: v[i] for k, v in rows.items()}) for i in picks]
                    same = all(a == b or (math.isfinite(a) and abs(a - b) <= 1e-13 * max(abs(a), abs(b)))
                               for a, b in zip(one, got[picks], strict=True))  # fmt: skip
                    ev.vectorized = bool(same)
                if ev.vectorized:
                    return got
            elif ev.vectorized is None:
                ev.vectorized = False
        return np.array([ev(float(times[i]), {k: v[i] for k, v in rows.items()}) for i in range(m)], dtype=float)

    def results(self, like: dict) -> tuple[list[np.ndarray], list[dict]]:
        """``t_events`` and ``y_events`` (dicts of stacked arrays, empty ones shaped like ``like``)."""
        t_events = [np.array(ts, dtype=float) for ts in self.times]
        y_events = []
        for rows in self.states:
            if rows:
                y_events.append({k: np.stack([r[k] for r in rows]) for k in rows[0]})
            else:
                y_events.append({k: np.empty((0, *np.shape(v))) for k, v in like.items()})
        return t_events, y_events
