"""Classical explicit Runge–Kutta on the embedded equations: the baseline (MATH.md §6).

The state's arrays are stepped as points of the ambient vector space with the system's
vector field ``ẏ = ρ_*(ξ(t, y)) y``; nothing keeps R on SO(n) or the spectrum of A fixed
except the optional projection applied by the driver after each step.
"""

from __future__ import annotations

from dataclasses import dataclass

from .tableau import ButcherTableau

__all__ = ["ClassicalRK"]


@dataclass(frozen=True)
class ClassicalRK:
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

    kind = "classical"
    coordinates = None

    @property
    def order(self) -> int:
        return self.tableau.order

    @property
    def stages(self) -> int:
        return self.tableau.stages

    def step(self, system, t: float, y: dict, h: float) -> tuple[dict, int]:
        """One step from ``(t, y)`` of size ``h``; returns ``(y₁, vector-field evaluations)``."""
        A, b, c = self.tableau.A, self.tableau.b, self.tableau.c
        ks: list[dict] = []
        for i in range(self.tableau.stages):
            yi = _axpy(y, A[i, :i], ks, h)
            ks.append(system.vector_field(t + c[i] * h, yi))
        return _axpy(y, b, ks, h), self.tableau.stages


def _axpy(y: dict, coeffs, ks: list[dict], h: float) -> dict:
    out = dict(y)
    for a, k in zip(coeffs, ks, strict=True):
        if a != 0.0:
            for name in out:
                out[name] = out[name] + (a * h) * k[name]
    return out
