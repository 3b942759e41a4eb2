"""The stepper contract every method fulfils, and the method registry's record.

A method is a stateless object (frozen dataclass) with two verbs, after diffrax's solvers:

1. ``init(system, t0, y0, h) -> state`` — whatever the method carries from step to step
   (None for one-step methods; an implicit method's last solution as the next guess; an
   FSAL stage). It must be plain data (arrays, numbers, tuples, dicts of arrays or None) so
   that a streamed run can checkpoint it.
2. ``step(system, t, y, h, state) -> StepResult`` — one step of size ``h`` from ``(t, y)``:
   the new state ``y₁``, a local error estimate (the difference of an embedded pair, on the
   state's fields; None for methods without one), the evaluations spent, the new method
   state, and what dense output needs (``dense``; None until a method supplies it).

Adaptivity is not the method's business: a step-size controller (:mod:`lieint.control`)
wraps ``step`` for every method whose ``adaptive`` is True. Projection, saving, monitors and
statistics are the driver's (:mod:`lieint.driver`). scipy's ``solve_ivp`` solvers are the one
exception: they choose their own steps, so the driver runs them through an adapter
(:mod:`lieint.methods.scipy_ivp`) that answers to the same ``init``/``step`` verbs with
``self_controlled = True``.

A method says which systems it applies to with :meth:`Method.check_system`, in terms of what
a system declares (its group, its ``structure``), never by naming a concrete system class.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Method", "MethodSpec", "StepResult"]


@dataclass
class StepResult:
    """What one step produced (see the module docstring).

    Attributes
    ----------
    y : dict
        The state after the step (before any projection by the driver).
    error : dict, tuple of two dicts, or None
        Local error estimate per field (``y₁ − ŷ₁`` of an embedded pair), or None; a pair
        ``(y₁ − ŷ₅, y₁ − ŷ₃)`` for DOP853's combined estimate (:mod:`lieint.control`).
    nfev : int
        Generator / vector-field evaluations spent (one evaluation moves a whole batch).
    state : Any
        The method's state after the step (passed to the next ``step``).
    h : float or None
        The step actually taken when the method chooses it (self-controlled methods); None
        means the ``h`` that was asked for.
    dense : Any
        Data for dense output over the step (method-specific), or None.
    """

    y: dict
    error: dict | tuple[dict, dict] | None
    nfev: int
    state: Any = None
    h: float | None = None
    dense: Any = None


class Method(ABC):
    """Base class of integrators (see the module docstring for the contract).

    Subclasses are frozen dataclasses that declare ``name``, ``order`` and, where they apply,
    ``coordinates`` ("exp"/"cayley"), ``adaptive`` (``step`` returns an error estimate and a
    controller chooses ``h``) and ``self_controlled`` (the method chooses its own steps).
    """

    name: str
    #: order of the global error (None: variable order, e.g. LSODA)
    order: int | None
    #: the coordinate map of Lie-group methods ("exp" or "cayley"), None for others
    coordinates: str | None = None
    #: True when ``step`` returns an error estimate for a step-size controller
    adaptive: bool = False
    #: True when the method chooses its own steps (scipy's solvers)
    self_controlled: bool = False
    #: True when the new state is the old one moved by the group action (keeps its invariants)
    group_action: bool = False
    #: True when the state's group-valued fields (the attitude R) stay on the group to round-off
    #: although the other fields are not moved by the group action (the Lie–Poisson midpoint):
    #: dense output then interpolates those fields on the group (:mod:`lieint.dense`)
    keeps_group_fields: bool = False

    def check_system(self, system) -> None:
        """Raise ``ValueError`` naming ``method`` when this method cannot step ``system``.

        The default accepts every system; methods with requirements (a splitting, a
        symplectic structure) override it.
        """
        return None

    def init(self, system, t0: float, y0: dict, h: float | None) -> Any:
        """The method's state before the first step (default: none)."""
        return None

    @abstractmethod
    def step(self, system, t: float, y: dict, h: float, state: Any) -> StepResult:
        """One step of size ``h`` from ``(t, y)``."""

    @property
    def error_order(self) -> int | None:
        """Order q of the error estimate of an adaptive method (the controller's exponent)."""
        return None

    def compiled(self):
        """The method's form for the compiled engine (:mod:`lieint.fast.forms`), or None."""
        return None

    def steps_as(self, cls: type, names: tuple[str, ...] = ("step",)) -> bool:
        """True when this object steps exactly as ``cls`` defines it: none of ``names`` is
        overridden by a subclass or set on the instance. A declaration for the compiled
        kernels stands for the class's own step; a subclass that changes it integrates
        something else and must run on the generic path."""
        own = getattr(self, "__dict__", {})
        return all(getattr(type(self), name) is getattr(cls, name) and name not in own for name in names)


@dataclass(frozen=True)
class MethodSpec:
    """One entry of the method registry: a name and how to build it.

    Attributes
    ----------
    name : str
        The name users pass as ``method=`` ("rkmk4", "scipy:DOP853", …).
    family : str
        "rkmk", "rk", "rkmk-embedded", "scipy", … (tables group by it).
    order : int or None
        Order of the global error (None: variable).
    build : callable
        ``build(coordinates=None, **options) -> Method``.
    coordinates : tuple of str
        Coordinate maps the method accepts (first is the default); empty when none.
    adaptive : bool
        Takes ``rtol``/``atol`` and chooses its steps.
    description : str
        One line for listings and the guide.
    options : tuple of str
        Extra keyword options ``build`` accepts (e.g. "dexpinv_degree").
    """

    name: str
    family: str
    order: int | None
    build: Callable[..., Method] = field(repr=False, compare=False)
    coordinates: tuple[str, ...] = ()
    adaptive: bool = False
    description: str = ""
    options: tuple[str, ...] = ()
