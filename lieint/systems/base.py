"""The contract a mechanical system fulfils for the integrators (docs/theory.md §6).

A system is a state (a dict of named arrays with leading batch dimensions), a matrix Lie
group acting on it on the *right*, ``y ↦ ρ(g, y)``, and a generator ``ξ(t, y)`` in the Lie
algebra, so that ``ẏ = ρ_*(ξ(t, y)) y`` (the infinitesimal action). Invariants are named
functions of ``(t, y)``. The integrators know nothing else about the system.

To add a system, subclass :class:`LieGroupSystem` and implement

1. ``group`` -- the Lie group acting (:class:`lieint.groups.SO`, :class:`~lieint.groups.SE`,
   a :class:`~lieint.groups.ProductGroup`, …);
2. ``fields`` -- name → trailing shape of each state array (e.g. ``{"A": (n, n)}``);
3. :meth:`generator` -- ``ξ(t, y)``, an algebra element of ``group`` (batched);
4. :meth:`act` -- the right action ``ρ(g, y)`` of group elements;
5. :meth:`infinitesimal_action` -- ``d/ds ρ(exp(s ξ), y)`` at ``s = 0``;
6. optionally :meth:`project` (exact projection of fields onto their manifolds),
   :attr:`invariants` (name → :class:`Invariant`, each an ``integral`` of the exact flow or a
   ``defect`` that the exact flow keeps at zero), :attr:`outputs` (derived quantities by name,
   :class:`Output`; the state fields are outputs already), :attr:`structure` (tags that let
   special methods recognise what they can step, e.g. ``"free_top"``), :meth:`initial_state`
   (the state from physical keywords; scenes pass their ``[initial]`` keys to it),
   :meth:`compiled` (what a compiled kernel needs, see :mod:`lieint.fast`) and
   :meth:`relative_element` (the group element between two states, when the state determines
   it: dense output on the group for methods that report no increment, :mod:`lieint.dense`),
   and :meth:`parameter_values` with ``_assign_parameter`` (the numeric parameters a run can
   be differentiated by, :func:`lieint.sensitivity`).

Generators and actions must be pure array functions (no hidden state), so that a compiled
fast path can replace them. A system that another package installs under the entry-point group
``lieint.systems`` can be named in a scene (see :mod:`lieint.catalog`).
"""

from __future__ import annotations

import copy
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validation import as_float_array
from ..groups.base import LieGroup

__all__ = ["INVARIANT_KINDS", "Invariant", "LieGroupSystem", "Output", "State"]

State = dict[str, np.ndarray]
InvariantFunction = Callable[[np.ndarray, State], np.ndarray]

#: what an invariant measures: a first integral of the exact flow, or a defect (zero for it)
INVARIANT_KINDS = ("integral", "defect")


@dataclass(frozen=True)
class Invariant:
    """A quantity the exact flow keeps: a first ``integral`` (drift measured relative to its
    initial value) or a ``defect`` that is zero along the exact flow (drift = its size).

    Attributes
    ----------
    function : callable
        ``f(t, y) -> array`` of shape ``(*lead, *shape)`` for states with leading axes ``lead``
        (times and batch members); ``t`` broadcasts against the leading axes.
    kind : {"integral", "defect"}
    description : str
        One line for listings and plots.
    """

    function: InvariantFunction
    kind: str = "integral"
    description: str = ""

    def __post_init__(self):
        if self.kind not in INVARIANT_KINDS:
            raise ValueError(f"`kind` must be one of {list(INVARIANT_KINDS)}; got {self.kind!r}.")

    def __call__(self, t, y: State) -> np.ndarray:
        return np.asarray(self.function(t, y))


@dataclass(frozen=True)
class Output:
    """A derived quantity of the state, saved when a scene or run asks for it by name.

    Attributes
    ----------
    function : callable
        ``f(t, y) -> array`` of shape ``(*lead, *shape)``.
    shape : tuple of int
        Trailing shape per body (``(n, n)`` for a bivector, ``(n,)`` for a point).
    description : str
        One line for listings and plots.
    kind : str
        What the values are, for plots and converters: "bivector", "rotation", "vector",
        "point", "rotor" or "" (anything else).
    """

    function: InvariantFunction
    shape: tuple[int, ...]
    description: str = ""
    kind: str = ""

    def __call__(self, t, y: State) -> np.ndarray:
        return np.asarray(self.function(t, y))


class LieGroupSystem(ABC):
    """Base class of systems stepped by Lie-group methods (see the module docstring)."""

    group: LieGroup
    fields: dict[str, tuple[int, ...]]
    #: True when ξ(t, y) does not depend on t (lets the driver evaluate it batched over times)
    autonomous: bool = False
    #: tags of structure special methods recognise (e.g. "free_top"; see each system)
    structure: frozenset[str] = frozenset()
    #: what each state field is (see :class:`Output`); conventional names are known already
    field_kinds: Mapping[str, str] = {
        "A": "bivector",
        "Omega": "bivector",
        "R": "rotation",
        "Gamma": "vector",
        "G": "vector",
        "center": "point",
        "velocity": "vector",
        "rotor": "rotor",
    }

    @abstractmethod
    def generator(self, t: float | np.ndarray, y: State) -> np.ndarray | tuple[np.ndarray, ...]:
        """The Lie-algebra element ``ξ(t, y)`` with ``ẏ = ρ_*(ξ) y``.

        Parameters
        ----------
        t : float or ndarray
            The time (broadcasting against the leading axes of ``y`` where a system allows it).
        y : dict of ndarray
            The state, leading batch axes first.

        Returns
        -------
        ndarray or tuple of ndarray
            ξ in the algebra of :attr:`group` (a tuple for a product group), batched as ``y``.
        """

    @abstractmethod
    def act(self, g: np.ndarray | tuple[np.ndarray, ...], y: State) -> State:
        """The right action ``ρ(g, y)``; ``ρ(g h, y) = ρ(h, ρ(g, y))``.

        Parameters
        ----------
        g : ndarray or tuple of ndarray
            Group elements of :attr:`group`, batched as ``y`` (or broadcasting).
        y : dict of ndarray
            The state.

        Returns
        -------
        dict of ndarray
            The moved state.
        """

    @abstractmethod
    def infinitesimal_action(self, xi: np.ndarray | tuple[np.ndarray, ...], y: State) -> State:
        """``d/ds ρ(exp(s ξ), y)`` at ``s = 0``: the vector field of the generator.

        Parameters
        ----------
        xi : ndarray or tuple of ndarray
            An algebra element of :attr:`group`, batched as ``y``.
        y : dict of ndarray
            The state.

        Returns
        -------
        dict of ndarray
            The tangent vector at ``y``, field by field.
        """

    def relative_element(self, y0: State, y1: State) -> np.ndarray | None:
        """The group element ``g`` with ``ρ(g, y₀) = y₁`` read off two states, or None.

        Dense output on the group (:mod:`lieint.dense`) needs the increment of a step. A method
        that does not report it (a composition of exact flows, a discrete Lagrangian map) still
        moves the state by the group action, and a state that carries a group element ``Y``
        acted on by right multiplication (``Y ↦ Y g``, e.g. the attitude R) determines it:
        ``g = Y₀⁻¹ Y₁``. The default is None (the state does not determine ``g``; dense output
        then interpolates in the embedding space); systems with such a field override it.

        Parameters
        ----------
        y0, y1 : dict of ndarray
            The states at the two ends of a step.

        Returns
        -------
        ndarray or None
            ``g`` (batched as the states), or None when the states do not determine it.
        """
        return None

    # -- derived ---------------------------------------------------------------------
    def vector_field(self, t: float | np.ndarray, y: State) -> State:
        """``ẏ`` on the embedding space (used by classical and scipy baselines).

        Parameters
        ----------
        t : float or ndarray
            The time.
        y : dict of ndarray
            The state.

        Returns
        -------
        dict of ndarray
            ``ẏ`` field by field: ``ρ_*(ξ(t, y)) y``.
        """
        return self.infinitesimal_action(self.generator(t, y), y)

    def project(self, y: State) -> State:
        """Exact projection of each field onto its manifold (default: none).

        Parameters
        ----------
        y : dict of ndarray
            A state, possibly off its manifold by round-off (e.g. R off SO(n)).

        Returns
        -------
        dict of ndarray
            The nearest state on the manifold (e.g. R by its polar factor).
        """
        return y

    @property
    def invariants(self) -> Mapping[str, Invariant]:
        """name → :class:`Invariant` (first integrals and defects) this system reports."""
        return {}

    @property
    def outputs(self) -> Mapping[str, Output]:
        """name → :class:`Output`: every state field, plus the derived quantities a system adds."""
        return {
            name: Output(_field_getter(name), shape, f"state field {name!r}", self.field_kinds.get(name, ""))
            for name, shape in self.fields.items()
        }

    def evaluate_invariants(
        self, t: float | np.ndarray, y: State, names: Iterable[str] | None = None
    ) -> dict[str, np.ndarray]:
        """Evaluate the named invariants (all by default) on states with any leading shape.

        Parameters
        ----------
        t : float or ndarray
            The times, broadcasting against the leading axes of ``y``.
        y : dict of ndarray
            States with any leading shape (times, batch members).
        names : iterable of str, optional
            Names from :attr:`invariants` (default: all of them).

        Returns
        -------
        dict of ndarray
            name → values, shape ``(*lead, ...)``.
        """
        declared = self.invariants
        names = list(declared) if names is None else list(names)
        unknown = [n for n in names if n not in declared]
        if unknown:
            raise ValueError(f"Unknown invariant(s) {unknown}; this system provides {list(declared)}.")
        return {name: declared[name](t, y) for name in names}

    def evaluate_outputs(self, t: float | np.ndarray, y: State, names: Iterable[str]) -> dict[str, np.ndarray]:
        """Evaluate named outputs or invariants on states with any leading shape.

        Parameters
        ----------
        t : float or ndarray
            The times, broadcasting against the leading axes of ``y``.
        y : dict of ndarray
            States with any leading shape.
        names : iterable of str
            Names from :attr:`outputs` or :attr:`invariants`.

        Returns
        -------
        dict of ndarray
            name → values, shape ``(*lead, ...)``.
        """
        outputs, declared = self.outputs, self.invariants
        result = {}
        for name in names:
            if name in outputs:
                result[name] = outputs[name](t, y)
            elif name in declared:
                result[name] = declared[name](t, y)
            else:
                raise ValueError(
                    f"Unknown output {name!r}; this system provides the outputs {sorted(outputs)} "
                    f"and the invariants {sorted(declared)}."
                )
        return result

    def compiled(self) -> dict | None:
        """What a compiled kernel needs to step this system (see :mod:`lieint.fast`), or None.

        A system on ``SO(n)`` or ``SE(n)`` times a vector space may return
        ``{"kind": "lie", "pieces": ..., "params": ..., "n": n, "translation": bool,
        "abelian": m, "fields": self.fields}`` with its compiled generator, action, vector field
        and projection (:class:`lieint.fast.pieces.CompiledPieces`, numba functions of the
        signatures :data:`lieint.fast.pieces.GENERATOR`, ``ACTION`` and ``FIELD``, each taking
        last a scratch vector ``work`` of the length the pieces declare; or the name of
        built-in pieces): every RKMK method — fixed-step and embedded pairs, exponential and
        Cayley coordinates — and classical RK then run compiled
        (:class:`lieint.fast.generic.LieKernel`).

        Returns
        -------
        dict or None
            The declaration, or None: the system runs on the generic numpy path.
        """
        return None

    def _declared_once(self, key: tuple, build: Callable[[], Any]) -> Any:
        """``build()``, made once per ``key``: the declaration of the last call when ``key`` is
        equal, else a new one.

        ``key`` holds every number the declaration is made of — the arrays' bytes (``tobytes``),
        the scalars and the field names — so that comparing keys costs a fraction of building the
        declaration's parameter vector. A compiled engine is reused only for the very same
        declaration object (:func:`lieint.fast.engine.engine_for`), so a system whose declaration
        is rebuilt at every call never reuses one; keying on the numbers rather than on the
        system's arrays keeps an edited array (``top.gravity[:] = …``) from running with the old
        numbers.
        """
        own = self.__dict__
        cached = own.get("_declared_form")
        if cached is not None and cached[0] == key:
            return cached[1]
        form = build()
        own["_declared_form"] = (key, form)
        return form

    def field_offsets(self) -> dict[str, int]:
        """Where each field starts in the state flattened field after field.

        Returns
        -------
        dict of int
            name → offset in the compiled kernels' state vector (fields in :attr:`fields` order).
        """
        offsets, start = {}, 0
        for name, shape in self.fields.items():
            offsets[name] = start
            start += math.prod(shape)
        return offsets

    def dynamics_as(self, cls: type, names: tuple[str, ...]) -> bool:
        """Whether this system has ``cls``'s equations: none of ``names`` overridden below it.

        A compiled declaration stands for ``cls``'s equations, and a subclass that changes them
        integrates other dynamics on the generic path.

        Parameters
        ----------
        cls : type
            The class whose equations a compiled declaration stands for.
        names : tuple of str
            The methods that define them.

        Returns
        -------
        bool
            True when none of ``names`` is overridden below ``cls`` or set on the instance.
        """
        own = getattr(self, "__dict__", {})
        if type(self) is cls:  # the class itself: only the instance can set one (a tenth of the loop's time)
            return own.keys().isdisjoint(names)
        return all(getattr(type(self), name) is getattr(cls, name) and name not in own for name in names)

    def batch_shape(self, y: State) -> tuple[int, ...]:
        """Leading batch shape of a validated state.

        Parameters
        ----------
        y : dict of ndarray
            A state.

        Returns
        -------
        tuple of int
            Its leading axes (``()`` for one body).
        """
        name, shape = next(iter(self.fields.items()))
        arr = y[name]
        return arr.shape[: arr.ndim - len(shape)]

    def validate_state(self, y: Mapping[str, np.ndarray], name: str = "y0") -> State:
        """Check keys, shapes, finiteness and batch consistency; return float arrays.

        Subclasses extend this with their manifold checks (skewness, rotations).

        Parameters
        ----------
        y : dict of array_like
            A state (e.g. from :meth:`initial_state`).
        name : str, default "y0"
            The argument's name in error messages.

        Returns
        -------
        dict of ndarray
            The fields as float arrays, checked.

        Raises
        ------
        TypeError, ValueError
            Naming the field, what was expected and what was received.
        """
        if type(y) is not dict and not isinstance(y, Mapping):
            raise TypeError(
                f"`{name}` must be a state dict with keys {list(self.fields)} "
                f"(use `system.initial_state(...)`); got {type(y).__name__}."
            )
        if y.keys() != self.fields.keys():  # the keys as sets (one comparison, no lists made)
            missing = [k for k in self.fields if k not in y]
            extra = [k for k in y if k not in self.fields]
            raise ValueError(
                f"`{name}` must have exactly the keys {list(self.fields)}; missing {missing}, unexpected {extra}."
            )
        out: State = {}
        batch: tuple[int, ...] | None = None
        for key, shape in self.fields.items():
            arr = as_float_array(y[key], name, field=key)
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

    # -- numeric parameters (sensitivities, lieint.tangent) --------------------------
    def parameter_values(self) -> dict[str, np.ndarray]:
        """The numeric parameters a run can be differentiated by, under their constructor names.

        Returns
        -------
        dict of ndarray
            name → a copy of its (real) value; empty by default (no parameters offered).
        """
        return {}

    def parameter_refusals(self) -> dict[str, str]:
        """Numeric constructor arguments not offered by :meth:`parameter_values`, with why.

        Returns
        -------
        dict of str
            name → the reason (empty by default).
        """
        return {}

    def with_parameter_step(
        self, name: str, direction: np.ndarray, scale: complex, y: State
    ) -> tuple[LieGroupSystem, State]:
        """This system with parameter ``name`` moved to ``value + scale·direction``, and ``y`` with it.

        The constructor path of the complex step (:func:`lieint.sensitivity`): the copy's
        parameter may be complex, every quantity derived from it is recomputed analytically,
        and nothing is validated again (the real system was, by its constructor). The state is
        held fixed except the fields the parameter defines through the pose (the heavy top's
        ``Γ = Rᵀg`` follows g for the same R; a ball's centre stays at the height r).

        Parameters
        ----------
        name : str
            A key of :meth:`parameter_values`.
        direction : ndarray
            The direction, of the parameter's shape.
        scale : complex
            The step along it (``1j·ε`` for the complex step).
        y : dict of ndarray
            The (validated, real) initial state.

        Returns
        -------
        system : LieGroupSystem
            The moved copy; it declares no compiled form (the compiled kernels are real).
        y : dict of ndarray
            The initial state moved with it (complex where it moved).

        Raises
        ------
        ValueError
            An unknown name, a direction of the wrong shape, or a parameter refused for this
            state (naming why).
        """
        values = self.parameter_values()
        if name not in values:
            raise ValueError(
                f"`parameters` names {name!r}, which {type(self).__name__} does not offer; it offers {sorted(values)}."
            )
        direction = np.asarray(direction)
        if direction.shape != values[name].shape:
            raise ValueError(f"the direction of {name!r} must have shape {values[name].shape}; got {direction.shape}.")
        out = copy.copy(self)
        out.compiled = _no_compiled_form  # the compiled kernels are real: the copy runs generic
        out._assign_parameter(name, values[name] + scale * direction)
        moved = dict(y)
        for field, change in self._parameter_state_change(name, direction, y).items():
            moved[field] = y[field] + scale * change
        return out, moved

    def _assign_parameter(self, name: str, value: np.ndarray) -> None:
        """Set parameter ``name`` of this (copied) system to ``value`` and everything derived from it."""
        raise ValueError(f"{type(self).__name__} offers no numeric parameters.")

    def _parameter_state_change(self, name: str, direction: np.ndarray, y: State) -> State:
        """The change of the initial state's fields per unit of ``direction`` (none by default)."""
        return {}

    def __repr__(self) -> str:
        return f"{type(self).__name__}(group={self.group!r}, fields={list(self.fields)})"


def _no_compiled_form() -> None:
    """The compiled declaration of a system whose parameters are complex: none."""
    return None


def _field_getter(name: str) -> InvariantFunction:
    def get(t, y):
        return y[name]

    return get
