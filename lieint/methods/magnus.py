"""Magnus methods for generators that depend on t only: ``ġ = g ξ(t)`` (docs/theory.md §6, right action).

For a time-only generator the solution is ``g(t + h) = g(t) exp(Ω(h))`` with Ω the Magnus
series. The textbook formulas are written for the left equation ``Ẏ = A(t) Y``; the right
equation is the left one for ``Y = g⁻¹`` with ``A = −ξ``, so ``Ω_right = −Ω_left[A = −ξ]``
(the commutator terms change sign). With Gauss–Legendre nodes (Blanes, Casas, Oteo, Ros,
*The Magnus expansion and some of its applications*, Phys. Rep. 470 (2009) 151–238, §5.2;
Iserles, Nørsett, Phil. Trans. R. Soc. A 357 (1999) 983–1019):

* ``magnus4`` (order 4, 2 evaluations): nodes ``½ ∓ √3/6``,
  ``Ω = h/2 (A₁ + A₂) − (√3/12) h² [A₁, A₂]``;
* ``magnus6`` (order 6, 3 evaluations): nodes ``½ − √15/10, ½, ½ + √15/10``,
  ``α₁ = h A₂``, ``α₂ = (√15 h/3)(A₃ − A₁)``, ``α₃ = (10 h/3)(A₃ − 2A₂ + A₁)``,
  ``C₁ = [α₁, α₂]``, ``C₂ = −(1/60)[α₁, 2α₃ + C₁]``,
  ``Ω = α₁ + α₃/12 + (1/240)[−20α₁ − α₃ + C₁, α₂ + C₂]``.

They apply only to systems whose generator ignores the state (structure tag ``"time_only"``,
e.g. :class:`lieint.PrescribedRotation`) on matrix groups.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial

import numpy as np

from ..dense import Increment
from .base import Method, MethodSpec, StepResult
from .registry import register

__all__ = ["Magnus"]


def _bracket(X, Y):
    return X @ Y - Y @ X


def _omega4(h: float, A: list) -> np.ndarray:
    A1, A2 = A
    return (h / 2) * (A1 + A2) - (math.sqrt(3.0) / 12) * h * h * _bracket(A1, A2)


def _omega6(h: float, A: list) -> np.ndarray:
    A1, A2, A3 = A
    a1 = h * A2
    a2 = (math.sqrt(15.0) * h / 3) * (A3 - A1)
    a3 = (10 * h / 3) * (A3 - 2 * A2 + A1)
    C1 = _bracket(a1, a2)
    C2 = -(1 / 60) * _bracket(a1, 2 * a3 + C1)
    return a1 + a3 / 12 + (1 / 240) * _bracket(-20 * a1 - a3 + C1, a2 + C2)


_RULES = {
    "magnus4": (4, (0.5 - math.sqrt(3.0) / 6, 0.5 + math.sqrt(3.0) / 6), _omega4),
    "magnus6": (6, (0.5 - math.sqrt(15.0) / 10, 0.5, 0.5 + math.sqrt(15.0) / 10), _omega6),
}


@dataclass(frozen=True)
class Magnus(Method):
    """A Magnus method of order 4 or 6 (see the module docstring).

    Parameters
    ----------
    name : {"magnus4", "magnus6"}

    Notes
    -----
    One exponential and 2 (order 4) or 3 (order 6) generator evaluations per step; the new
    state is the old one moved by a group element.
    """

    name: str

    group_action = True

    def __post_init__(self):
        if self.name not in _RULES:
            raise ValueError(f"`name` must be one of {list(_RULES)}; got {self.name!r}.")

    @property
    def order(self) -> int:  # type: ignore[override]
        return _RULES[self.name][0]

    @property
    def nodes(self) -> tuple[float, ...]:
        return _RULES[self.name][1]

    def check_system(self, system) -> None:
        if "time_only" not in getattr(system, "structure", frozenset()):
            raise ValueError(
                f"`method` {self.name!r} (a Magnus method) needs a generator that depends on t only "
                f"(structure tag 'time_only', e.g. lieint.PrescribedRotation); {type(system).__name__} "
                "has a state-dependent generator: use an RKMK, commutator-free or Crouch–Grossman method."
            )

    def compiled(self):
        """The compiled engine's form: a map with stage code for prescribed rotations
        (:mod:`lieint.fast.magnus`: the rates sampled at the nodes, the steps in machine code); its
        ``substeps`` are the rule's Gauss nodes. None for a subclass with a step of its own."""
        if not self.steps_as(Magnus, ("step", "check_system")):
            return None
        from ..fast.forms import MapForm

        return MapForm("magnus", {"PrescribedForm": "lieint.fast.magnus"}, tuple(float(c) for c in self.nodes))

    def step(self, system, t: float, y: dict, h: float, state=None) -> StepResult:
        group = system.group
        # the right equation ġ = gξ is the left one for g⁻¹ with A = −ξ: Ω = −Ω_left[−ξ]
        A = [-system.generator(t + c * h, y) for c in self.nodes]
        u = -_RULES[self.name][2](h, A)
        return StepResult(system.act(group.exp(u), y), None, len(self.nodes), None, dense=Increment(u=u))


def _build(name: str, coordinates: str | None = None) -> Magnus:
    return Magnus(name)


for _name, (_order, _nodes, _) in _RULES.items():
    register(
        MethodSpec(
            _name,
            "magnus",
            _order,
            partial(_build, _name),
            (),
            False,
            f"Magnus method of order {_order} with {len(_nodes)} Gauss nodes (generators depending on t only)",
        )
    )
