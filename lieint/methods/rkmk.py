"""Runge–Kutta–Munthe-Kaas methods (Lie–Euler is the one-stage case), docs/theory.md §6.

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

With an embedded pair (weights b̂ of order q < p) the step also returns the error estimate
``y₁ − ŷ₁``, ``ŷ₁ = ρ(φ(h Σ_j b̂_j k_j), y₀)``, measured **on the state** (every field, A and R
alike, as scipy measures its pairs on the vector it integrates); the 8(5,3) pair returns its two
estimates (b̂₅ and b̂₃) for DOP853's combination. A step-size controller
(:mod:`lieint.control`) turns them into accepted and rejected steps. The order-p solution is
propagated (local extrapolation, as in Dormand–Prince and scipy).

The pairs keep more of the dexp⁻¹ series by default: degree ``p + 4`` (:data:`PAIR_DEGREE_MARGIN`)
instead of the ``p − 2`` that order p needs. Truncating after ``p − 2`` keeps the order, but the
dropped terms ``B_k/k!·ad_u^k`` carry powers of the whole increment ``|u| = |hξ|``, which is of
order one when the body spins fast (a heavy top spinning at 10 rad/s takes steps of 0.5–1.8 rad at
rtol 1e-6 … 1e-10), and both the solution and the embedded one are built from the same truncated
stages, so the estimate ``y₁ − ŷ₁`` cannot see them. Measured on such a heavy top at rtol 1e-6
(``benchmarks/adaptive_systems.py --local``): rkmk853's true local error is 16× its estimate (median,
94× at the 90th percentile) at degree 6, 0.14× (0.66×) at degree 12 — the exact dexp⁻¹'s 0.14×;
rkmk45's 17.6× at degree 3, 0.12× at degree 9. The odd Bernoulli numbers beyond B₁ vanish, so the
extra brackets are four per stage for rkmk853.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

from ..dense import Increment
from ..fast.forms import RKMKForm
from . import tableaux
from .base import Method, MethodSpec, StepResult
from .registry import AUTO, register
from .tableau import ButcherTableau, EmbeddedPair

__all__ = ["COORDINATES", "RKMK", "coordinate_map", "rkmk_stages"]

#: the coordinate maps of Lie-group methods (the first is the default)
COORDINATES = ("exp", "cayley")


@dataclass(frozen=True)
class RKMK(Method):
    """An RKMK method declared as data: a tableau (or embedded pair), a coordinate map, a
    dexp⁻¹ truncation.

    Parameters
    ----------
    name : str
        Name shown in tables ("rkmk4").
    tableau : ButcherTableau or EmbeddedPair
        Explicit tableau of order p (the method has order p); an embedded pair makes the
        method adaptive (``step`` returns an error estimate).
    coordinates : {"exp", "cayley"}
        Coordinate map from the algebra to the group.
    dexpinv_degree : int or None
        Keep the Bernoulli series of dexp⁻¹ up to ``ad_u^degree``; must be ≥ p − 2 or the
        order drops. ``None`` uses the exact closed form (so(3), so(n) spectral). Ignored for
        Cayley coordinates, whose dcay⁻¹ is exact. The registry's ``"auto"`` is ``p − 2`` for
        a fixed-step tableau and ``p + 4`` for an embedded pair (:func:`default_degree`).

    Notes
    -----
    Order p; ``stages`` generator evaluations and as many coordinate maps per step.
    Invariants of the group action are preserved to round-off; the energy is not (it errs
    at order p).

    Examples
    --------
    >>> from lieint.methods import RKMK, tableaux
    >>> RKMK("rkmk4-cayley", tableaux.RK4, coordinates="cayley").order
    4
    """

    name: str
    tableau: ButcherTableau | EmbeddedPair
    coordinates: str = "exp"
    dexpinv_degree: int | None = None

    group_action = True

    def __post_init__(self):
        if not isinstance(self.tableau, (ButcherTableau, EmbeddedPair)):
            raise TypeError(f"`tableau` must be a ButcherTableau or EmbeddedPair; got {type(self.tableau).__name__}.")
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
    def adaptive(self) -> bool:  # type: ignore[override]
        return isinstance(self.tableau, EmbeddedPair)

    @property
    def butcher(self) -> ButcherTableau:
        """The tableau of the propagated (order-p) solution."""
        return self.tableau.tableau if isinstance(self.tableau, EmbeddedPair) else self.tableau

    @property
    def order(self) -> int:  # type: ignore[override]
        return self.tableau.order

    @property
    def error_order(self) -> int | None:
        """q of the controller's exponent ``1/(q + 1)`` (:attr:`EmbeddedPair.error_order`)."""
        return self.tableau.error_order if isinstance(self.tableau, EmbeddedPair) else None

    @property
    def stages(self) -> int:
        return self.tableau.stages

    def stage_increments(self, system, t: float, y: dict, h: float) -> list:
        """The stage increments ``k_i = dφ⁻¹_{−u_i}(ξ(t + c_i h, ρ(φ(u_i), y)))`` of one step."""
        return rkmk_stages(system, self.butcher, self.coordinates, self.dexpinv_degree, t, y, h)

    def step(self, system, t: float, y: dict, h: float, state=None) -> StepResult:
        group = system.group
        ks = self.stage_increments(system, t, y, h)
        u = _combine(group, self.butcher.b, ks, h)
        g = coordinate_map(group, self.coordinates, u)
        y1 = system.act(g, y)
        error = None
        if isinstance(self.tableau, EmbeddedPair):
            error = self._difference(system, y, y1, self.tableau.b_hat, ks, h)
            if self.tableau.b_hat_low is not None:
                # DOP853's second estimate; the controller combines the two (lieint.control)
                error = (error, self._difference(system, y, y1, self.tableau.b_hat_low, ks, h))
        # dense output interpolates in exponential coordinates (a Cayley step's element is logged)
        increment = Increment(u=u, data=(ks, h)) if self.coordinates == "exp" else Increment(g=g, data=(ks, h))
        return StepResult(y1, error, self.stages, None, dense=increment)

    def _difference(self, system, y: dict, y1: dict, weights, ks: list, h: float) -> dict:
        """``y₁ − ŷ`` per field, ``ŷ = ρ(φ(h Σ_j b̂_j k_j), y₀)``: an embedded solution's error
        estimate, measured on the state (the quantity the user's tolerances are about)."""
        y_hat = system.act(coordinate_map(system.group, self.coordinates, _combine(system.group, weights, ks, h)), y)
        return {name: y1[name] - y_hat[name] for name in y1}

    def compiled(self):
        """RKMK in exponential coordinates with a truncated dexp⁻¹, or in Cayley coordinates,
        runs in the compiled engine (:class:`lieint.fast.forms.RKMKForm`); an embedded pair also
        declares its embedded weights ``b_hat`` (and DOP853's ``b_hat_low``) and the
        controller's error order q."""
        if self.coordinates == "exp" and self.dexpinv_degree is None:
            return None
        if not self.steps_as(RKMK, ("step", "stage_increments", "_difference")):
            return None
        tab = self.butcher
        if isinstance(self.tableau, EmbeddedPair):
            pair = self.tableau
            return RKMKForm(tab.A, tab.b, tab.c, self.coordinates, self.dexpinv_degree, pair.b_hat, pair.b_hat_low,
                            self.error_order)  # fmt: skip
        return RKMKForm(tab.A, tab.b, tab.c, self.coordinates, self.dexpinv_degree)


def coordinate_map(group, coordinates: str, u):
    """φ(u): ``exp`` or ``cay``."""
    return group.exp(u) if coordinates == "exp" else group.cay(u)


def rkmk_stages(system, tableau: ButcherTableau, coordinates: str, degree, t: float, y: dict, h: float) -> list:
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


# -- the registry's entries -------------------------------------------------------------------


#: an embedded pair's default dexp⁻¹ degree is its order plus this (see the module docstring)
PAIR_DEGREE_MARGIN = 4


def default_degree(tableau) -> int:
    """The dexp⁻¹ degree ``dexpinv_degree="auto"`` chooses: ``p − 2`` for a fixed-step
    tableau of order p (what the order needs), ``p + PAIR_DEGREE_MARGIN`` for an embedded pair
    (its estimate cannot see the truncation: the module docstring)."""
    if isinstance(tableau, EmbeddedPair):
        return tableau.order + PAIR_DEGREE_MARGIN
    return max(tableau.order - 2, 0)


def _build(name: str, tableau, coordinates: str | None = None, dexpinv_degree=AUTO) -> RKMK:
    coords = COORDINATES[0] if coordinates is None else coordinates
    degree = default_degree(tableau) if dexpinv_degree is AUTO else dexpinv_degree
    label = name if coords == COORDINATES[0] else f"{name}[{coords}]"
    return RKMK(label, tableau, coordinates=coords, dexpinv_degree=degree)


_FIXED = {
    "lie_euler": (tableaux.EULER, "Lie–Euler: y₁ = ρ(exp(hξ(y₀)), y₀)"),
    "rkmk2": (tableaux.HEUN, "RKMK with Heun's tableau"),
    "rkmk3": (tableaux.KUTTA3, "RKMK with Kutta's third-order tableau"),
    "rkmk4": (tableaux.RK4, "RKMK with the classical RK4 tableau"),
    "rkmk6": (tableaux.BUTCHER6, "RKMK with Butcher's 7-stage sixth-order tableau"),
}
#: what the registry says of the plain pairs where a user chooses one (docs/measurements/adaptive.md)
_NOT_RTOL = "; global error not proportional to rtol near a separatrix (10³–10⁴ × rtol): take {0}+energy"
_EMBEDDED = {
    "rkmk23": (tableaux.BOGACKI_SHAMPINE32, "adaptive RKMK, Bogacki–Shampine 3(2) pair" + _NOT_RTOL.format("rkmk23")),
    "rkmk45": (tableaux.DORMAND_PRINCE54, "adaptive RKMK, Dormand–Prince 5(4) pair" + _NOT_RTOL.format("rkmk45")),
    "rkmk853": (
        tableaux.DORMAND_PRINCE853,
        "adaptive RKMK, Dormand–Prince 8(5) pair of DOP853" + _NOT_RTOL.format("rkmk853"),
    ),
}

for _name, (_tab, _text) in _FIXED.items():
    register(
        MethodSpec(
            _name, "rkmk", _tab.order, partial(_build, _name, _tab), COORDINATES, False, _text, ("dexpinv_degree",)
        )
    )
for _name, (_pair, _text) in _EMBEDDED.items():
    register(
        MethodSpec(
            _name,
            "rkmk-embedded",
            _pair.order,
            partial(_build, _name, _pair),
            COORDINATES,
            True,
            _text,
            ("dexpinv_degree",),
        )
    )
