"""Adaptive RKMK from embedded pairs: ask for an accuracy instead of a step.

A pair is an explicit tableau of order p with a second weight vector b̂ of order q < p (both
checked against the rooted-tree conditions). One RKMK step gives ``y₁ = ρ(φ(h Σ b_j k_j), y₀)``
and ``ŷ₁ = ρ(φ(h Σ b̂_j k_j), y₀)``; the error is measured **on the state**, componentwise
``|y₁ − ŷ₁| / (atol + rtol·max(|y₀|, |y₁|))`` in the RMS norm over every field (as scipy does),
not on the Lie-algebra increment. A step with error > 1 is rejected and retried smaller —
never accepted silently — and the next step is ``h·min(5, max(0.2, 0.9·err^{−1/(q+1)}))``.
The method propagates the order-p solution, so dexp⁻¹ is truncated at degree p − 2 (a
truncation at degree 5 would cap an order-8 pair at order 7). A stage that leaves the dexp⁻¹
series radius counts as a rejection.

The pairs' coefficients are read from scipy's explicit Runge–Kutta classes (Bogacki–Shampine
3(2), Dormand–Prince 5(4), and Dormand–Prince 8(5) of DOP853 with its fifth-order estimator),
with the first-same-as-last stage appended as an extra row.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np

from ..groups.base import DexpinvRangeError
from .lie import COORDINATES, _combine, coordinate_map, rkmk_stages
from .order_conditions import order_residuals, tree_string
from .tableau import ButcherTableau

__all__ = ["ADAPTIVE_PAIRS", "AdaptiveLieMethod", "EmbeddedPair", "embedded_pair"]


@dataclass(frozen=True, eq=False)
class EmbeddedPair:
    """A tableau of order p (``tableau``) with embedded weights ``b_hat`` of order q."""

    tableau: ButcherTableau
    b_hat: np.ndarray
    embedded_order: int

    def __post_init__(self):
        b_hat = np.asarray(self.b_hat, dtype=float)
        if b_hat.shape != (self.tableau.stages,):
            raise ValueError(f"`b_hat` must have {self.tableau.stages} weights; got shape {b_hat.shape}.")
        for tree, residual in order_residuals(self.tableau.A, b_hat, self.embedded_order):
            if abs(residual) > 1e-12:
                raise ValueError(
                    f"embedded weights of {self.tableau.name!r} fail the order-{self.embedded_order} "
                    f"condition for the tree {tree_string(tree)} by {residual:.3g}"
                )
        b_hat.setflags(write=False)
        object.__setattr__(self, "b_hat", b_hat)

    @property
    def order(self) -> int:
        return self.tableau.order


def _with_fsal(name, A, B, C, E, order, embedded_order) -> EmbeddedPair:
    """Append the FSAL stage (row = b, node 1) and form b̂ = b + E."""
    s = B.size
    A_ext = np.zeros((s + 1, s + 1))
    A_ext[:s, : min(s, A.shape[1])] = A[:s, : min(s, A.shape[1])]
    A_ext[s, :s] = B
    b_ext = np.append(B, 0.0)
    tab = ButcherTableau(name, A=A_ext, b=b_ext, c=np.append(C[:s], 1.0), order=order)
    return EmbeddedPair(tab, b_ext + E[: s + 1], embedded_order)


@cache
def embedded_pair(name: str) -> EmbeddedPair:
    """The embedded pair of a name in ``ADAPTIVE_PAIRS`` (built from scipy's coefficients)."""
    from scipy.integrate._ivp import dop853_coefficients as d853
    from scipy.integrate._ivp.rk import RK23, RK45

    if name == "bs32":
        return _with_fsal("Bogacki-Shampine 3(2)", RK23.A, RK23.B, RK23.C, RK23.E, 3, 2)
    if name == "dp54":
        return _with_fsal("Dormand-Prince 5(4)", RK45.A, RK45.B, RK45.C, RK45.E, 5, 4)
    if name == "dp85":
        return _with_fsal("Dormand-Prince 8(5)", d853.A, d853.B, d853.C, d853.E5, 8, 5)
    raise ValueError(f"unknown embedded pair {name!r}; choose from {list(ADAPTIVE_PAIRS.values())}")


#: method name → pair name
ADAPTIVE_PAIRS = {"rkmk23": "bs32", "rkmk45": "dp54", "rkmk853": "dp85"}


@dataclass(frozen=True)
class AdaptiveLieMethod:
    """RKMK with an embedded pair and error control on the state.

    Parameters
    ----------
    name : str
        "rkmk23", "rkmk45", "rkmk853" or a name of your own.
    pair : EmbeddedPair
        Order p with an order-q estimate.
    coordinates : {"exp", "cayley"}
    dexpinv_degree : int or None
        Default p − 2 (see the module docstring); None is the exact closed form.
    """

    name: str
    pair: EmbeddedPair
    coordinates: str = "exp"
    dexpinv_degree: int | None = None

    kind = "adaptive"

    def __post_init__(self):
        if self.coordinates not in COORDINATES:
            raise ValueError(f"`coordinates` must be one of {list(COORDINATES)}; got {self.coordinates!r}.")
        d = self.dexpinv_degree
        if d is not None and d < self.order - 2:
            raise ValueError(
                f"`dexpinv_degree` = {d} caps the order-{self.order} pair at order {d + 2}; use a "
                f"degree >= {self.order - 2} or None (exact)."
            )

    @property
    def order(self) -> int:
        return self.pair.order

    @property
    def stages(self) -> int:
        return self.pair.tableau.stages

    def attempt(self, system, t: float, y: dict, h: float):
        """One trial step: ``(y₁, ŷ₁, evaluations)``; raises DexpinvRangeError past the radius."""
        group, tab = system.group, self.pair.tableau
        ks = rkmk_stages(system, tab, self.coordinates, self.dexpinv_degree, t, y, h)
        y1 = system.act(coordinate_map(group, self.coordinates, _combine(group, tab.b, ks, h)), y)
        y_hat = system.act(coordinate_map(group, self.coordinates, _combine(group, self.pair.b_hat, ks, h)), y)
        return y1, y_hat, tab.stages


def error_norm(y0: dict, y1: dict, y_hat: dict, rtol: float, atol: float) -> float:
    """RMS over every state component of ``|y₁ − ŷ₁| / (atol + rtol·max(|y₀|, |y₁|))``."""
    total, count = 0.0, 0
    for name in y1:
        scale = atol + rtol * np.maximum(np.abs(y0[name]), np.abs(y1[name]))
        r = (y1[name] - y_hat[name]) / scale
        total += float(np.sum(r * r))
        count += r.size
    return float(np.sqrt(total / max(count, 1)))


def integrate_adaptive(system, y, t0, t1, h0, stepper, project, save_every, rtol, atol):
    """Accepted steps from t0 to t1 (the last one clipped to end on t1); returns the saved
    times and states and the statistics."""
    q = stepper.pair.embedded_order
    if h0 is None:
        f = system.vector_field(t0, y)
        d0 = np.sqrt(sum(float(np.sum(v * v)) for v in y.values()))
        d1 = np.sqrt(sum(float(np.sum(v * v)) for v in f.values()))
        h0 = 0.01 * d0 / d1 if d1 > 0 and d0 > 0 else 1e-6 * max(1.0, abs(t1 - t0))
    h = min(h0, t1 - t0)
    t, times, saved = t0, [t0], [y]
    accepted = rejected = nfev = 0
    failure = None
    h_min = 1e-14 * max(1.0, abs(t0), abs(t1))
    while t < t1:
        h = min(h, t1 - t)
        try:
            with np.errstate(over="ignore", invalid="ignore"):
                y1, y_hat, n = stepper.attempt(system, t, y, h)
            nfev += n
            err = error_norm(y, y1, y_hat, rtol, atol)
        except DexpinvRangeError:
            err = np.inf
        if not np.isfinite(err) or err > 1.0:
            rejected += 1
            h *= 0.2 if not np.isfinite(err) else max(0.2, 0.9 * err ** (-1.0 / (q + 1)))
            if h < h_min:
                failure = (
                    f"the step size fell below {h_min:.3g} at t = {t:.6g} without meeting rtol = {rtol:g}, "
                    f"atol = {atol:g}; loosen the tolerances or check the model"
                )
                break
            continue
        t = t1 if t1 - (t + h) <= h_min else t + h
        y = system.project(y1) if project else y1
        accepted += 1
        if accepted % save_every == 0 or t == t1:
            times.append(t)
            saved.append(y)
        h *= min(5.0, max(0.2, 0.9 * err ** (-1.0 / (q + 1)))) if err > 0 else 5.0
    states = {name: np.stack([s[name] for s in saved]) for name in saved[0]}
    return np.array(times), states, {"accepted": accepted, "rejected": rejected, "nfev": nfev, "failure": failure}
