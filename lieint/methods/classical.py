"""Classical explicit Runge–Kutta on the embedded equations: the baseline (docs/theory.md §6).

The state's arrays are stepped as points of the ambient vector space with the system's
vector field ``ẏ = ρ_*(ξ(t, y)) y``; nothing keeps R on SO(n) or the spectrum of A fixed
except the optional projection applied by the driver after each step.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

from ..fast.forms import ClassicalForm
from . import tableaux
from .base import Method, MethodSpec, StepResult
from .registry import register
from .tableau import ButcherTableau

__all__ = ["ClassicalRK"]


@dataclass(frozen=True)
class ClassicalRK(Method):
    """An explicit Runge–Kutta method on the embedding space.

    Parameters
    ----------
    name : str
        Name shown in tables ("rk4").
    tableau : ButcherTableau
        The method's tableau (order p, s stages).
    """

    name: str
    tableau: ButcherTableau

    @property
    def order(self) -> int:  # type: ignore[override]
        return self.tableau.order

    @property
    def stages(self) -> int:
        return self.tableau.stages

    def step(self, system, t: float, y: dict, h: float, state=None) -> StepResult:
        A, b, c = self.tableau.A, self.tableau.b, self.tableau.c
        ks: list[dict] = []
        for i in range(self.tableau.stages):
            yi = _axpy(y, A[i, :i], ks, h)
            ks.append(system.vector_field(t + c[i] * h, yi))
        return StepResult(_axpy(y, b, ks, h), None, self.tableau.stages, None, dense=(ks, h))

    def compiled(self):
        """Classical RK on the state arrays runs in the compiled engine
        (:class:`lieint.fast.forms.ClassicalForm`; unless a subclass changes the step)."""
        if not self.steps_as(ClassicalRK):
            return None
        return ClassicalForm(self.tableau.A, self.tableau.b, self.tableau.c)


def _axpy(y: dict, coeffs, ks: list[dict], h: float) -> dict:
    out = dict(y)
    for a, k in zip(coeffs, ks, strict=True):
        if a != 0.0:
            for name in out:
                out[name] = out[name] + (a * h) * k[name]
    return out


def _build(name: str, tableau: ButcherTableau, coordinates: str | None = None) -> ClassicalRK:
    return ClassicalRK(name, tableau)


register(
    MethodSpec(
        "rk4",
        "rk",
        4,
        partial(_build, "rk4", tableaux.RK4),
        description="classical RK4 on the embedded equations (the baseline)",
    )
)
