"""The result of :func:`lieint.integrate`."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["Invariants", "Solution"]


class Invariants(Mapping):
    """Lazy mapping name → invariant series ``(m, *batch, ...)``.

    Each invariant is computed from the saved states on first access and cached, so a run
    pays only for the invariants it looks at.
    """

    def __init__(self, system, t: np.ndarray, states: dict):
        self._system = system
        self._t = t
        self._states = states
        self._cache: dict[str, np.ndarray] = {}

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self._cache:
            funcs = self._system.invariant_functions
            if name not in funcs:
                raise KeyError(f"Unknown invariant {name!r}; this system provides {list(funcs)}.")
            t = self._t.reshape(self._t.shape + (1,) * (len(self._states_batch())))
            self._cache[name] = np.asarray(funcs[name](t, self._states))
        return self._cache[name]

    def _states_batch(self) -> tuple[int, ...]:
        return self._system.batch_shape({k: v[0] for k, v in self._states.items()})

    def __iter__(self) -> Iterator[str]:
        return iter(self._system.invariant_functions)

    def __len__(self) -> int:
        return len(self._system.invariant_functions)

    def __repr__(self) -> str:
        return f"Invariants({list(self)})"


@dataclass
class Solution:
    """Saved trajectory of an integration.

    Attributes
    ----------
    t : ndarray, shape (m,)
        Saved times.
    states : dict of ndarray
        Each state field at the saved times, shape ``(m, *batch, ...)``.
    invariants : Mapping of ndarray
        Lazily evaluated invariants, shape ``(m, *batch, ...)``.
    method : str
        The method's name.
    nsteps : int
        Steps taken (fixed-step methods) or 0 (scipy, see ``stats``).
    nfev : int
        Generator / vector-field evaluations (per batch: one evaluation moves all members).
    success : bool
        False if the run stopped early (non-finite state, solver failure).
    message : str
        What happened, and what to do about it when it failed.
    stats : dict
        Step size, projection flag, CPU time and other run details.
    """

    t: np.ndarray
    states: dict[str, np.ndarray]
    system: Any
    method: str
    nsteps: int
    nfev: int
    success: bool
    message: str
    stats: dict[str, Any] = field(default_factory=dict)
    invariants: Invariants = field(init=False, repr=False)

    def __post_init__(self):
        self.invariants = Invariants(self.system, self.t, self.states)

    def drift(self, name: str, relative: bool = True) -> np.ndarray:
        """Largest deviation of an invariant from its initial value, per batch member.

        ``max_t ‖I(t) − I(0)‖ / ‖I(0)‖`` (norms over the invariant's own axes); absolute when
        ``relative=False`` or when ``I(0) = 0``. For a defect (``system.defects``, e.g.
        ``orthogonality``, zero for the exact flow) this is the largest defect reached.
        """
        values = self.invariants[name]
        batch_ndim = len(self.system.batch_shape({k: v[0] for k, v in self.states.items()}))
        extra = tuple(range(1 + batch_ndim, values.ndim))
        if name in getattr(self.system, "defects", ()):
            size = np.sqrt(np.sum(values * values, axis=extra)) if extra else np.abs(values)
            return np.max(size, axis=0)
        dev = values - values[:1]
        err = np.sqrt(np.sum(dev * dev, axis=extra)) if extra else np.abs(dev)
        err = np.max(err, axis=0)
        if not relative:
            return err
        ref = values[0]
        ref = np.sqrt(np.sum(ref * ref, axis=tuple(range(batch_ndim, ref.ndim)))) if extra else np.abs(ref)
        return np.where(ref > 0, err / np.where(ref > 0, ref, 1.0), err)

    def __repr__(self) -> str:
        batch = self.system.batch_shape({k: v[0] for k, v in self.states.items()})
        return (
            f"Solution(method={self.method!r}, saved={self.t.size}, batch={batch}, nsteps={self.nsteps}, "
            f"nfev={self.nfev}, success={self.success}, fields={list(self.states)})"
        )
