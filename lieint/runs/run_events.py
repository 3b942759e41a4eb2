"""A scene's ``[[events]]`` in a streamed run: located on the steps' interpolants, recorded in
the run file, carried across checkpoints so that a resumed run records the same events bit for
bit.

The events are watched by the same :class:`~lieint.observe.StepObserver` as in
:func:`lieint.integrate` (the driver hands it every accepted step; the run then takes the
generic path). Each event gets a group ``events/NAME`` in the HDF5 file with a dataset ``t``
(the event times) and one dataset per state field (the states there, on the group), appended
after every segment. A terminal event ends the run at the event (the last saved row is its
state), as in :func:`lieint.integrate`.

What a resume needs besides the driver's carry is small and exact: the number of events of
each kind recorded up to the checkpoint (the datasets are cut back to it, and the counts of
terminal events continue from it) and, for methods of order p > 4, the last one or two step
increments the interpolant passes through (:mod:`lieint.dense`). The event functions' values
at the checkpoint's state are recomputed from that state, which gives the same bits.
"""

from __future__ import annotations

import numpy as np

from ..observe import StepObserver, group_action_of

__all__ = ["StreamedEvents"]


class StreamedEvents:
    """The events of one streamed run (see the module docstring).

    Parameters
    ----------
    system : LieGroupSystem
    method : Method
    t0 : float
    events : list of callables
        The scene's event functions (:func:`lieint.scenes.engine.scene_events`).
    project : bool
        Whether the run projects its states.
    """

    def __init__(self, system, method, t0: float, events: list, *, project: bool):
        self.observer = StepObserver(
            system, t0, events=events, project=project, order=method.order, group_action=group_action_of(method)
        )
        self.log = self.observer.log
        self.keys = self._keys([ev.name for ev in self.log.events])
        self.written = [0] * len(self.keys)

    @staticmethod
    def _keys(names: list[str]) -> list[str]:
        """HDF5 group names: the events' names ('/' is not allowed in one), made unique."""
        keys: list[str] = []
        for i, name in enumerate(names):
            key = str(name).replace("/", "_") or f"event {i}"
            keys.append(key if key not in keys else f"{key} ({i})")
        return keys

    # -- the file -----------------------------------------------------------------------------
    def create(self, f, like: dict) -> None:
        """Empty, growable datasets ``events/NAME/t`` and ``events/NAME/FIELD``."""
        group = f.require_group("events")
        for key, ev in zip(self.keys, self.log.events, strict=True):
            g = group.create_group(key)
            g.attrs["terminal"] = int(ev.terminal)
            g.attrs["direction"] = float(ev.direction)
            g.create_dataset("t", shape=(0,), maxshape=(None,), dtype="f8", chunks=(256,))
            for name, value in like.items():
                shape = np.shape(value)
                g.create_dataset(name, shape=(0, *shape), maxshape=(None, *shape), dtype="f8", chunks=(64, *shape))
        f.flush()

    def write_new(self, f) -> None:
        """Append the events located since the last call."""
        for i, key in enumerate(self.keys):
            times, states = self.log.times[i], self.log.states[i]
            new = len(times) - self.written[i]
            if new <= 0:
                continue
            g = f["events"][key]
            n = g["t"].shape[0]
            g["t"].resize((n + new,))
            g["t"][n:] = times[self.written[i] :]
            for name in g:
                if name == "t":
                    continue
                ds = g[name]
                ds.resize((n + new, *ds.shape[1:]))
                ds[n:] = np.stack([np.asarray(y[name]) for y in states[self.written[i] :]])
            self.written[i] = len(times)
        f.flush()

    def cut(self, f, counts: list[int]) -> None:
        """Drop the events recorded after the checkpoint (``counts`` of each kind are kept)."""
        for key, count in zip(self.keys, counts, strict=True):
            g = f["events"][key]
            for ds in g.values():
                ds.resize((count, *ds.shape[1:]))
        f.flush()

    # -- checkpoints ----------------------------------------------------------------------------
    def checkpoint(self) -> tuple[dict[str, np.ndarray], dict]:
        """Arrays and attributes a resume needs (the counts and the interpolant's history)."""
        arrays: dict[str, np.ndarray] = {"events:counts": np.asarray(self.log.counts, dtype=np.int64)}
        for j, (tj, xij, uj) in enumerate(self.observer.history):
            arrays[f"events:history{j}:t"] = np.asarray(float(tj))
            arrays[f"events:history{j}:xi"] = np.asarray(xij)
            arrays[f"events:history{j}:u"] = np.asarray(uj)
        return arrays, {"events_history": len(self.observer.history)}

    def restore(self, f, arrays: dict, attrs: dict, t: float, y: dict) -> None:
        """Continue from a checkpoint taken at ``(t, y)``: the file's events cut back to it."""
        counts = [int(c) for c in arrays["events:counts"]]
        self.cut(f, counts)
        self.log.counts = list(counts)
        self.log.times = [[] for _ in counts]
        self.log.states = [[] for _ in counts]
        self.written = [0] * len(counts)
        self.log.start(t, y)  # the events' values at the checkpoint's state: the same bits
        self.observer.history = [
            (
                float(arrays[f"events:history{j}:t"]),
                arrays[f"events:history{j}:xi"],
                arrays[f"events:history{j}:u"],
            )
            for j in range(int(attrs.get("events_history", 0)))
        ]

    def restart(self, f) -> None:
        """A run recomputed from its start (scipy's solvers): every event is written again."""
        self.cut(f, [0] * len(self.keys))
        self.written = [0] * len(self.keys)
