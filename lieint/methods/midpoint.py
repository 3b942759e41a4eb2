"""The implicit (Lie–Poisson) midpoint rule on the rigid-body equations (docs/theory.md §11).

One step from ``y₀`` solves for the midpoint ``y_m``::

    y_m = y₀ + (h/2) f(t + h/2, y_m),   y₁ = 2 y_m − y₀,

with ``f`` the system's vector field on the embedding space: ``Ȧ = [A, Ω(A)]`` (+ ``M X_G ∧ Γ``
for the heavy top), ``Γ̇ = −ΩΓ``, ``Ṙ = RΩ``. The rule is symmetric, of order 2, and keeps
every quadratic first integral of the equations to the solver's tolerance: the energy
``T = ¼ tr(ΩA)`` (heavy top: ``T − M⟨Γ, X_G⟩``), ``tr A²``, ``|Γ|²``, the n = 3 Casimir
``⟨Π, Γ⟩`` and ``RᵀR = I`` — for R the update is exactly ``R₁ = R₀ cay(hΩ(A_m))``. In n = 3
and 4 every Casimir of the free top is quadratic (n = 4: ``tr A²`` and the Pfaffian), so the
spectrum of A is kept; in n ≥ 5 ``tr A⁴`` is not. It is not a Lie-group method: the space
momentum ``R A Rᵀ`` is kept only to the order of the method.

The midpoint is found by fixed-point iteration started from the explicit Euler half step. Its
contraction factor is about ``(h/2)‖∂f/∂y‖`` (``h‖Ω‖/2`` for the free top), so it converges
linearly; it stops when the update is below round-off (``‖δy‖ ≤ 4ε‖y‖`` on every field) or
stops decreasing, and raises ``RuntimeError`` when it diverges or needs more than 200 iterations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import Method, MethodSpec, StepResult
from .registry import register

__all__ = ["LieMidpoint", "implicit_midpoint"]

_EPS = np.finfo(float).eps
_MAX_ITER = 200
#: systems whose equations are Lie–Poisson with quadratic invariants the rule keeps
_STRUCTURES = ("free_top", "heavy_top")


def implicit_midpoint(f, t: float, y: dict, h: float) -> tuple[dict, int]:
    """Solve ``y_m = y + (h/2) f(t + h/2, y_m)`` by fixed-point iteration; return ``(y_m, evaluations)``."""
    half = 0.5 * h
    tm = t + half
    k = f(tm, y)
    ym = {name: y[name] + half * k[name] for name in y}
    last = np.inf
    scale = {name: max(float(np.max(np.abs(y[name]))), 1.0e-300) for name in y}
    for it in range(1, _MAX_ITER + 1):
        k = f(tm, ym)
        new = {name: y[name] + half * k[name] for name in y}
        size = max(float(np.max(np.abs(new[name] - ym[name]))) / scale[name] for name in y)
        ym = new
        if size <= 4.0 * _EPS or (size >= last and size <= 1e3 * _EPS):
            return ym, it + 1
        if size >= last and it > 3:
            break
        last = size
    raise RuntimeError(
        f"implicit midpoint step h = {h:g} at t = {t:g}: the fixed-point iteration did not converge "
        f"(last relative update {size:.3g} after {it} iterations); take a smaller `h`."
    )


@dataclass(frozen=True)
class LieMidpoint(Method):
    """The implicit midpoint rule on a Lie–Poisson rigid body (see the module docstring).

    Examples
    --------
    >>> import lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    >>> sol = lieint.integrate(top, y0, (0.0, 10.0), h=0.1, method="lie_midpoint")
    >>> bool(sol.drift("energy").max() < 1e-13)
    True
    """

    name: str = "lie_midpoint"
    order: int = 2

    keeps_group_fields = True  # R₁ = R₀ cay(hΩ(A_m)) is orthogonal to round-off

    def check_system(self, system) -> None:
        structure = getattr(system, "structure", frozenset())
        if not any(s in structure for s in _STRUCTURES):
            raise ValueError(
                f"`method` {self.name!r} applies to Lie–Poisson rigid bodies (structure one of "
                f"{list(_STRUCTURES)}: lieint.EulerTop, lieint.HeavyTop); got {type(system).__name__} "
                f"with structure {sorted(structure)}."
            )

    def compiled(self):
        """The compiled engine's form: a map with stage code for the 3D top
        (:mod:`lieint.fast.top3_midpoint`) and for compiled pieces (:mod:`lieint.fast.midpoint`:
        the heavy top, and the n-D top through its pieces)."""
        from ..fast.forms import MapForm

        return MapForm("midpoint", COMPILED_MIDPOINT)

    def step(self, system, t: float, y: dict, h: float, state=None) -> StepResult:
        ym, nfev = implicit_midpoint(system.vector_field, t, y, h)
        return StepResult({name: 2.0 * ym[name] - y[name] for name in y}, None, nfev, None)


#: where the midpoint has compiled stage code: system form (class name) -> module
COMPILED_MIDPOINT = {"Top3Form": "lieint.fast.top3_midpoint", "PiecesForm": "lieint.fast.midpoint"}


def _build(coordinates: str | None = None) -> LieMidpoint:
    return LieMidpoint()


register(
    MethodSpec(
        "lie_midpoint",
        "midpoint",
        2,
        _build,
        description="implicit Lie–Poisson midpoint rule: symmetric, keeps every quadratic invariant",
    )
)
