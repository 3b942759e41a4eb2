"""The contract a mechanical system fulfils for the integrators (MATH.md §6).

A system is a state (a dict of named arrays with leading batch dimensions), a matrix Lie
group acting on it on the *right*, ``y ↦ ρ(g, y)``, and a generator ``ξ(t, y)`` in the Lie
algebra, so that ``ẏ = ρ_*(ξ(t, y)) y`` (the infinitesimal action). Invariants are named
functions of ``(t, y)``. The integrators know nothing else about the system.

To add a system, subclass :class:`LieGroupSystem` and implement

1. ``fields`` -- name → trailing shape of each state array (e.g. ``{"A": (n, n)}``);
2. :meth:`generator` -- ``ξ(t, y)``, an algebra element of shape ``(*batch, m, m)``;
3. :meth:`act` -- the right action ``ρ(g, y)`` of group elements ``(*batch, m, m)``;
4. :meth:`infinitesimal_action` -- ``d/ds ρ(exp(s ξ), y)`` at ``s = 0``;
5. optionally :meth:`project` (exact projection of fields onto their manifolds) and
   entries of ``invariant_functions``.

Generators and actions must be pure array functions (no hidden state), so that a compiled
fast path can replace them.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping

import numpy as np

from .._validation import as_float_array
from ..groups.base import LieGroup

__all__ = ["LieGroupSystem", "State"]

State = dict[str, np.ndarray]
InvariantFunction = Callable[[np.ndarray, State], np.ndarray]


class LieGroupSystem(ABC):
    """Base class of systems stepped by Lie-group methods (see the module docstring)."""

    group: LieGroup
    fields: dict[str, tuple[int, ...]]
    #: invariants that measure a defect (zero for the exact flow): their drift is their size
    defects: frozenset[str] = frozenset({"orthogonality"})
    #: True when ξ(t, y) does not depend on t (lets the driver evaluate it batched over times)
    autonomous: bool = False

    @abstractmethod
    def generator(self, t: float | np.ndarray, y: State) -> np.ndarray:
        """The Lie-algebra element ``ξ(t, y)`` with ``ẏ = ρ_*(ξ) y``."""

    @abstractmethod
    def act(self, g: np.ndarray, y: State) -> State:
        """The right action ``ρ(g, y)``; ``ρ(g h, y) = ρ(h, ρ(g, y))``."""

    @abstractmethod
    def infinitesimal_action(self, xi: np.ndarray, y: State) -> State:
        """``d/ds ρ(exp(s ξ), y)`` at ``s = 0``: the vector field of the generator."""

    # -- derived ---------------------------------------------------------------------
    def vector_field(self, t: float | np.ndarray, y: State) -> State:
        """``ẏ`` on the embedding space (used by classical and scipy baselines)."""
        return self.infinitesimal_action(self.generator(t, y), y)

    def project(self, y: State) -> State:
        """Exact projection of each field onto its manifold (default: none)."""
        return y

    @property
    def invariant_functions(self) -> Mapping[str, InvariantFunction]:
        """name → ``f(t, y)`` of the first integrals and defects this system reports."""
        return {}

    def invariants(self, t: np.ndarray, y: State, names=None) -> dict[str, np.ndarray]:
        """Evaluate the named invariants (all by default) on states with any leading shape."""
        funcs = self.invariant_functions
        names = list(funcs) if names is None else list(names)
        unknown = [n for n in names if n not in funcs]
        if unknown:
            raise ValueError(f"Unknown invariant(s) {unknown}; this system provides {list(funcs)}.")
        return {name: funcs[name](t, y) for name in names}

    def batch_shape(self, y: State) -> tuple[int, ...]:
        """Leading batch shape of a validated state."""
        name, shape = next(iter(self.fields.items()))
        arr = y[name]
        return arr.shape[: arr.ndim - len(shape)]

    def validate_state(self, y: Mapping[str, np.ndarray], name: str = "y0") -> State:
        """Check keys, shapes, finiteness and batch consistency; return float arrays.

        Subclasses extend this with their manifold checks (skewness, rotations).
        """
        if not isinstance(y, Mapping):
            raise TypeError(
                f"`{name}` must be a state dict with keys {list(self.fields)} "
                f"(use `system.initial_state(...)`); got {type(y).__name__}."
            )
        missing = [k for k in self.fields if k not in y]
        extra = [k for k in y if k not in self.fields]
        if missing or extra:
            raise ValueError(
                f"`{name}` must have exactly the keys {list(self.fields)}; missing {missing}, unexpected {extra}."
            )
        out: State = {}
        batch: tuple[int, ...] | None = None
        for key, shape in self.fields.items():
            arr = as_float_array(y[key], f"{name}['{key}']")
            if arr.shape[arr.ndim - len(shape) :] != shape or arr.ndim < len(shape):
                raise ValueError(
                    f"`{name}['{key}']` must have shape (..., {', '.join(map(str, shape))}); got shape {arr.shape}."
                )
            b = arr.shape[: arr.ndim - len(shape)]
            if batch is None:
                batch = b
            elif b != batch:
                raise ValueError(f"All fields of `{name}` must share one batch shape; got {batch} and {b} for '{key}'.")
            out[key] = arr
        return out

    def __repr__(self) -> str:
        return f"{type(self).__name__}(group={self.group!r}, fields={list(self.fields)})"
