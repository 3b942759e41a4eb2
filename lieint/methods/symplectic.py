"""Symplectic methods for particles: velocity Verlet and RATTLE (Hairer, Lubich & Wanner,
*Geometric Numerical Integration*, 2nd ed., §VII.1.4).

Both step a state ``{"q", "v"}`` of a system that declares what they need in its
``structure`` (see :mod:`lieint.systems.particles`):

* **velocity Verlet** (``"newtonian"`` systems, ``q̈ = a(t, q)``)::

      v_½ = v₀ + (h/2) a(t₀, q₀),   q₁ = q₀ + h v_½,   v₁ = v_½ + (h/2) a(t₁, q₁).

  Order 2, symplectic, symmetric; one evaluation of a per step (the last one is carried to
  the next step). A force ``f(q)`` that commutes with a linear symmetry keeps its momentum
  map exactly: a central force keeps ``(q − C) ∧ q̇`` and a constant force ``e ∧ q̇`` to
  round-off, because every increment of v lies along ``q − C`` (or e) at the point where q
  stands.

* **RATTLE** (``"surface_constrained"`` systems, ``m q̈ = f + λ∇h`` on ``h(q) = 1``)::

      v_½ = v₀ + (h/2m)(f₀ + λ ∇h(q₀)),   q₁ = q₀ + h v_½,    h(q₁) = 1,
      v₁ = v_½ + (h/2m)(f₁ + μ ∇h(q₁)),                       ⟨∇h(q₁), v₁⟩ = 0.

  λ solves the scalar equation ``h(q₁(λ)) = 1`` by Newton's method to round-off (stopped when
  the correction no longer shrinks); μ is explicit. Order 2, symplectic, symmetric; keeps
  ``h(q) = 1`` and ``⟨∇h, q̇⟩ = 0`` to round-off at every step. On a surface of revolution
  about ``(C, e)`` with f along e both velocity kicks lie in the span of ``q − C`` and e at
  the point where q stands, so Clairaut's trivector ``(q − C) ∧ q̇ ∧ e`` is kept to round-off.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import Method, MethodSpec, StepResult
from .registry import register

__all__ = ["Rattle", "VelocityVerlet"]

_NEWTON_MAX = 50


def _require(system, tag: str, method: str, needs: str) -> None:
    structure = getattr(system, "structure", frozenset())
    if tag not in structure:
        raise ValueError(
            f"`method` {method!r} steps {needs} (systems whose structure includes {tag!r}); "
            f"{type(system).__name__} declares {sorted(structure)}."
        )


@dataclass(frozen=True)
class VelocityVerlet(Method):
    """Velocity Verlet (Störmer–Verlet) for ``q̈ = a(t, q)`` (see the module docstring).

    The method state carries the last step's end point, its ``a(q)`` and the compensations
    of the sums (a dict of arrays, so that a streamed run checkpoints it); it is used only
    when the next step starts from that same state (a projection or another start makes it
    evaluate a afresh and restart the compensation).
    """

    name: str = "verlet"
    order: int = 2

    def check_system(self, system) -> None:
        _require(system, "newtonian", self.name, "Newton's equations with a force of position q̈ = a(t, q)")

    def init(self, system, t0, y0, h):
        return None

    def step(self, system, t, y, h, state=None) -> StepResult:
        q0, v0 = y["q"], y["v"]
        nfev = 0
        carried = _carried(state, y)
        if carried:
            a0, cq, cv = state["a"], state["cq"], state["cv"]
        else:
            a0, nfev = system.acceleration(t, q0), 1
            cq, cv = np.zeros_like(q0), np.zeros_like(v0)
        v_half, cv = _add(v0, (0.5 * h) * a0, cv)
        q1, cq = _add(q0, h * v_half, cq)
        a1 = system.acceleration(t + h, q1)
        v1, cv = _add(v_half, (0.5 * h) * a1, cv)
        return StepResult({"q": q1, "v": v1}, None, nfev + 1, {"q": q1, "v": v1, "a": a1, "cq": cq, "cv": cv})


@dataclass(frozen=True)
class Rattle(Method):
    """RATTLE for a particle on ``h(q) = 1`` (see the module docstring)."""

    name: str = "rattle"
    order: int = 2

    def check_system(self, system) -> None:
        _require(system, "surface_constrained", self.name, "a particle constrained to a surface h(q) = 1")

    def step(self, system, t, y, h, state=None) -> StepResult:
        surface, m = system.surface, system.mass
        q0, v0 = y["q"], y["v"]
        if _carried(state, y):
            cq, cv = state["cq"], state["cv"]
        else:
            cq, cv = np.zeros_like(q0), np.zeros_like(v0)
        g0 = surface.gradient(q0)
        f0 = system.external_force(t, q0)
        kick = 0.5 * h / m
        # q₁(λ) = q₀ + h v_½(λ), v_½(λ) = v₀ + (h/2m)(f₀ + λ∇h(q₀)): h(q₁(λ)) − 1 is a smooth
        # scalar function of λ, solved on the very sums that are stored (compensated)
        lam = np.array(system.multiplier(q0, v0), dtype=float)  # the flow's λ: the root is O(h) from it
        prev = np.full(lam.shape, np.inf)
        for _ in range(_NEWTON_MAX):
            v_half, _ = _add(v0, kick * (f0 + lam[..., None] * g0), cv)
            q1, _ = _add(q0, h * v_half, cq)
            r = surface.h(q1) - 1.0
            slope = h * kick * np.sum(surface.gradient(q1) * g0, axis=-1)
            dlam = r / slope
            lam = lam - dlam
            size = np.abs(dlam)
            # Newton converges quadratically; stop once the correction stops shrinking (round-off)
            if np.all((size == 0) | (size >= 0.5 * prev)):
                break
            prev = np.minimum(size, prev)
        v_half, cv = _add(v0, kick * (f0 + lam[..., None] * g0), cv)
        q1, cq = _add(q0, h * v_half, cq)
        g1 = surface.gradient(q1)
        w, cv = _add(v_half, kick * system.external_force(t + h, q1), cv)
        # μ makes ⟨∇h(q₁), v₁⟩ = 0: remove the normal part of w
        v1, cv = _add(w, -(np.sum(g1 * w, axis=-1) / np.sum(g1 * g1, axis=-1))[..., None] * g1, cv)
        return StepResult({"q": q1, "v": v1}, None, 2, {"q": q1, "v": v1, "cq": cq, "cv": cv})


def _carried(state, y) -> bool:
    """Whether the method state belongs to this y (not after a projection or another start)."""
    return state is not None and np.array_equal(state["q"], y["q"]) and np.array_equal(state["v"], y["v"])


def _add(x: np.ndarray, dx: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Compensated summation ``x + dx`` (Kahan): returns the rounded sum and the part the
    rounding lost, which the next sum adds back. Keeps the round-off of long runs at O(ε) per
    quantity instead of a random walk O(ε √steps) — the increments are small against x."""
    d = dx + c
    s = x + d
    return s, (x - s) + d


def _build_verlet(coordinates: str | None = None) -> VelocityVerlet:
    return VelocityVerlet()


def _build_rattle(coordinates: str | None = None) -> Rattle:
    return Rattle()


register(
    MethodSpec(
        "verlet",
        "symplectic",
        2,
        _build_verlet,
        description="velocity Verlet for q̈ = a(t, q): symplectic, keeps momentum maps of linear symmetries",
    )
)
register(
    MethodSpec(
        "rattle",
        "symplectic",
        2,
        _build_rattle,
        description="RATTLE on a surface h(q) = 1: keeps h(q) = 1 and ⟨∇h, q̇⟩ = 0 to round-off",
    )
)
