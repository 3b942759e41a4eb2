"""Runge–Kutta–Munthe-Kaas methods (Lie–Euler is the one-stage case), MATH.md §6.

The systems of lieint are moved by *right* actions ρ, so the group path obeys
``ġ = g ξ``; with ``g = exp(u)`` the stage equation is ``u̇ = dexp⁻¹_{−u}(ξ)`` (the odd
Bernoulli terms change sign compared with the textbook left-action form). A step from
``y₀`` with tableau ``(A, b, c)`` is::

    u_i = h Σ_j a_ij k_j,   y_i = ρ(φ(u_i), y₀),
    k_i = dφ⁻¹_{−u_i}(ξ(t + c_i h, y_i)),
    y₁ = ρ(φ(h Σ_j b_j k_j), y₀),

with the coordinate map ``φ = exp`` (``dexp⁻¹`` truncated after degree ``p − 2`` by default,
or exact) or ``φ = cay`` (``dcay⁻¹`` is exact). Because the new state is the old one moved by
a group element, every invariant of the action (spectrum of A, |Γ|, …) is kept to round-off.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .tableau import ButcherTableau

__all__ = ["COORDINATES", "LieMethod", "coordinate_map", "rkmk_stages"]

COORDINATES = ("exp", "cayley")


@dataclass(frozen=True)
class LieMethod:
    """An RKMK method declared as data: a tableau, a coordinate map, a dexp⁻¹ truncation.

    Parameters
    ----------
    name : str
        Name shown in tables ("rkmk4").
    tableau : ButcherTableau
        Explicit tableau of order p; the method has order p.
    coordinates : {"exp", "cayley"}
        Coordinate map from the algebra to the group.
    dexpinv_degree : int or None
        Keep the Bernoulli series of dexp⁻¹ up to ``ad_u^degree``; must be ≥ p − 2 or the
        order drops. ``None`` uses the exact closed form (so(3), so(n) spectral). Ignored for
        Cayley coordinates, whose dcay⁻¹ is exact.

    Notes
    -----
    Order p; ``tableau.stages`` generator evaluations and as many coordinate maps per step.
    Invariants of the group action are preserved to round-off; the energy is not (it errs
    at order p).

    Examples
    --------
    >>> from lieint.methods import LieMethod, tableaux
    >>> LieMethod("rkmk4-cayley", tableaux.RK4, coordinates="cayley").order
    4
    """

    name: str
    tableau: ButcherTableau
    coordinates: str = "exp"
    dexpinv_degree: int | None = None

    kind = "lie"

    def __post_init__(self):
        if not isinstance(self.tableau, ButcherTableau):
            raise TypeError(f"`tableau` must be a ButcherTableau; got {type(self.tableau).__name__}.")
        if self.coordinates not in COORDINATES:
            raise ValueError(f"`coordinates` must be one of {list(COORDINATES)}; got {self.coordinates!r}.")
        d = self.dexpinv_degree
        if d is not None:
            if isinstance(d, bool) or not isinstance(d, (int, np.integer)) or d < 0:
                raise ValueError(f"`dexpinv_degree` must be None or an integer >= 0; got {d!r}.")
            if d < self.order - 2:
                raise ValueError(
                    f"`dexpinv_degree` = {d} caps an order-{self.order} RKMK method at order {d + 2}; "
                    f"use a degree >= {self.order - 2} or None (exact)."
                )

    @property
    def order(self) -> int:
        return self.tableau.order

    @property
    def stages(self) -> int:
        return self.tableau.stages

    def stage_increments(self, system, t: float, y: dict, h: float) -> list:
        """The stage increments ``k_i = dφ⁻¹_{−u_i}(ξ(t + c_i h, ρ(φ(u_i), y)))`` of one step."""
        return rkmk_stages(system, self.tableau, self.coordinates, self.dexpinv_degree, t, y, h)

    def step(self, system, t: float, y: dict, h: float) -> tuple[dict, int]:
        """One step from ``(t, y)`` of size ``h``; returns ``(y₁, generator evaluations)``."""
        ks = self.stage_increments(system, t, y, h)
        U = _combine(system.group, self.tableau.b, ks, h)
        return system.act(coordinate_map(system.group, self.coordinates, U), y), self.tableau.stages


def coordinate_map(group, coordinates: str, u):
    """φ(u): ``exp`` or ``cay``."""
    return group.exp(u) if coordinates == "exp" else group.cay(u)


def rkmk_stages(system, tableau, coordinates: str, degree, t: float, y: dict, h: float) -> list:
    """The RKMK stages of a right action: ``u_i = h Σ_j a_ij k_j``,
    ``k_i = dφ⁻¹_{−u_i}(ξ(t + c_i h, ρ(φ(u_i), y)))`` (see the module docstring)."""
    group = system.group
    A, c = tableau.A, tableau.c
    ks: list = []
    for i in range(tableau.stages):
        u = _combine(group, A[i, :i], ks, h)
        if u is None:
            ks.append(system.generator(t + c[i] * h, y))
            continue
        xi = system.generator(t + c[i] * h, system.act(coordinate_map(group, coordinates, u), y))
        if coordinates == "exp":
            ks.append(group.dexpinv(group.negate(u), xi, degree))
        else:
            ks.append(group.dcayinv(group.negate(u), xi))
    return ks


def _combine(group, coeffs: np.ndarray, ks: list, h: float):
    """``h Σ_j coeffs_j k_j`` skipping zero coefficients; None when all are zero."""
    pairs = [(float(a) * h, k) for a, k in zip(coeffs, ks, strict=True) if a != 0.0]
    if not pairs:
        return None
    return group.lincomb([w for w, _ in pairs], [k for _, k in pairs])
