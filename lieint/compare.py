"""The main job: run several methods on one scene and tabulate accuracy against cost.

The embedded default scene is an asymmetric 3D top (``I = (1, 2, 3)``) started close to its
unstable middle axis, where the body flips (the Dzhanibekov effect) and the exact solution
in Jacobi elliptic functions is the reference.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass

import numpy as np

from .integrate import integrate
from .methods.registry import get_method
from .systems.euler_top import EulerTop

__all__ = ["DEFAULT_METHODS", "ComparisonRow", "DefaultScene", "format_rows", "run_comparison"]

DEFAULT_METHODS = ("lie_euler", "rkmk2", "rkmk4", "rkmk6", "rk4", "scipy:DOP853")


@dataclass(frozen=True)
class DefaultScene:
    """Asymmetric 3D top near its unstable middle axis (the Dzhanibekov flip)."""

    moments: tuple[float, float, float] = (1.0, 2.0, 3.0)
    angular_velocity: tuple[float, float, float] = (0.01, 1.0, 0.01)
    t_end: float = 100.0

    def build(self):
        top = EulerTop.from_principal_moments(self.moments)
        return top, top.initial_state(angular_velocity=self.angular_velocity)


@dataclass
class ComparisonRow:
    """One line of the comparison table."""

    method: str
    coordinates: str
    step: str
    steps: int
    nfev: int
    cpu_time: float
    error: float
    energy_drift: float
    casimir_drift: float
    orthogonality: float
    success: bool


def run_comparison(
    methods=DEFAULT_METHODS,
    h: float = 0.01,
    t_end: float | None = None,
    coordinates: str = "exp",
    project: bool = True,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    scene: DefaultScene | None = None,
    saves: int = 1000,
) -> list[ComparisonRow]:
    """Integrate the scene with each method and measure it against the exact solution.

    ``error`` is ``max_t ‖A(t) − A_exact(t)‖_F / ‖A(0)‖_F`` over the saved times (about
    ``saves`` of them); drifts are relative maxima over the run; ``orthogonality`` is the
    final ``‖RᵀR − I‖_F``; ``cpu_time`` is the process time of the integration alone.
    """
    scene = scene or DefaultScene()
    t_end = scene.t_end if t_end is None else t_end
    top, y0 = scene.build()
    steps = max(1, round(t_end / h))
    save_every = max(1, steps // saves)
    rows = []
    for name in methods:
        lie = get_method(name).kind == "lie"
        sol = integrate(
            top,
            y0,
            (0.0, t_end),
            h=h,
            method=name,
            coordinates=coordinates if lie else None,
            project=project,
            save_every=save_every,
            rtol=rtol,
            atol=atol,
        )
        exact = top.exact_solution(sol.t, y0)["A"]
        err = np.linalg.norm(sol.states["A"] - exact, axis=(-2, -1)).max() / np.linalg.norm(y0["A"])
        scipy = get_method(name).kind == "scipy"
        rows.append(
            ComparisonRow(
                method=name,
                coordinates=coordinates if lie else "-",
                step=f"rtol={rtol:g}" if scipy else f"{h:g}",
                steps=sol.nsteps,
                nfev=sol.nfev,
                cpu_time=sol.stats["cpu_time"],
                error=float(err),
                energy_drift=float(sol.drift("energy")),
                casimir_drift=float(sol.drift("casimirs")),
                orthogonality=float(sol.invariants["orthogonality"][-1]),
                success=sol.success,
            )
        )
    return rows


_COLUMNS = [
    ("method", "method", "{}"),
    ("coordinates", "coords", "{}"),
    ("step", "step", "{}"),
    ("steps", "steps", "{:d}"),
    ("nfev", "evals", "{:d}"),
    ("cpu_time", "CPU [s]", "{:.3f}"),
    ("error", "error", "{:.2e}"),
    ("energy_drift", "energy drift", "{:.2e}"),
    ("casimir_drift", "Casimir drift", "{:.2e}"),
    ("orthogonality", "|RᵀR-I|", "{:.1e}"),
]


def format_rows(rows: list[ComparisonRow], fmt: str = "table") -> str:
    """Render the rows as an aligned text table, CSV or JSON."""
    if fmt == "json":
        return json.dumps([_jsonable(asdict(r)) for r in rows], indent=2)
    cells = [[spec.format(getattr(r, key)) for key, _, spec in _COLUMNS] for r in rows]
    header = [title for _, title, _ in _COLUMNS]
    if fmt == "csv":
        keys = [key for key, _, _ in _COLUMNS]
        return "\n".join([",".join(keys)] + [",".join(c) for c in cells])
    widths = [max(len(header[i]), *(len(c[i]) for c in cells)) for i in range(len(header))]
    line = "  ".join(h.rjust(w) for h, w in zip(header, widths, strict=True))
    out = [line, "-" * len(line)]
    out += ["  ".join(c.rjust(w) for c, w in zip(row, widths, strict=True)) for row in cells]
    return "\n".join(out)


def _jsonable(d: dict) -> dict:
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}
