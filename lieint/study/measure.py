"""One point of a study: run, time honestly, say which back end ran, measure the error.

Timing: one untimed warm-up call per series — the same call over the first
``WARM_UP_FRACTION`` of the span: same system, method, step or tolerances, projection and back
end, so the same compiled code, numba cache loads, scipy first-call imports and caches; its wall
time is kept as ``cold_wall`` of the series' first point — then ``repeats`` timed calls of the
whole :func:`lieint.integrate` call — what a user pays — each with the process CPU time (all
threads) and the wall time; the row keeps the minimum and the median of each. A point whose
timed calls exceed the budget (``BUDGET`` seconds in the full sweep, ``QUICK_BUDGET`` in the
quick one) stops repeating early (its ``repeats`` says how many calls were timed).

Back end: the driver reports which loop ran (``Solution.stats.backend``: "numba", "numpy",
"scipy") and why. A run on the generic numpy path although both the system and the method
declare a compiled form is a *fallback* (for example a fixed step too large for the kernel's a-priori
dexp⁻¹ bound, or an adaptive pair on a system whose compiled form has no adaptive kernel): the row
says so (``fallback`` and ``backend_reason``) and the figures draw it as a series of its own, so
that a curve never mixes two code paths silently. (Adaptive RKMK pairs on the 3D top run the
compiled controller loop, :mod:`lieint.fast.adaptive`.)
"""

from __future__ import annotations

import statistics
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..groups.base import DexpinvRangeError
from ..ivp import integrate
from ..methods.registry import get_method
from .plan import ATOL_RATIO, GRID, PlanEntry, Variant
from .reference import Reference, state_error

__all__ = ["BUDGET", "StudyRow", "Timing", "measure_point", "point_calls", "timed"]

#: seconds of timed calls after which a point stops repeating (slow points are timed fewer times)
BUDGET = 2.0
#: the same for the quick sweep (the main job): a point slower than this is timed once
QUICK_BUDGET = 0.5
#: the warm-up call covers this fraction of the span (what it warms does not depend on the span)
WARM_UP_FRACTION = 0.05


@dataclass
class Timing:
    """Seconds of the timed calls (after one warm-up)."""

    cpu_min: float
    cpu_median: float
    wall_min: float
    wall_median: float
    cold_wall: float
    repeats: int


def timed(fn, repeats: int, *, warm_up: bool = True, budget: float = BUDGET, warm_fn=None):
    """``(Timing, result)``: one untimed warm-up call (of ``warm_fn``, by default ``fn``; none
    when ``warm_up`` is False), then ``repeats`` timed calls of ``fn`` — fewer when the timed
    calls so far exceed ``budget`` seconds of wall time (at least one is always timed;
    ``Timing.repeats`` says how many were)."""
    if not isinstance(repeats, int) or repeats < 1:
        raise ValueError(f"`repeats` must be a positive integer; got {repeats!r}.")
    cold = float("nan")
    if warm_up:
        w0 = time.perf_counter()
        (fn if warm_fn is None else warm_fn)()
        cold = time.perf_counter() - w0
    cpus, walls, result = [], [], None
    while len(cpus) < repeats and (not walls or sum(walls) < budget):
        c0, w0 = time.process_time(), time.perf_counter()
        result = fn()
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    timing = Timing(min(cpus), statistics.median(cpus), min(walls), statistics.median(walls), cold, len(cpus))
    return timing, result


@dataclass
class StudyRow:
    """One point of a sweep (one method, variant and setting), as tables and figures show it.

    Times are in seconds; ``error`` is relative to ``‖y(0)‖`` over the whole state
    (``field_errors`` per field, same scale). ``resolved`` is False when the error is within
    ``RESOLVED`` × the reference's floor.
    """

    scene: str
    method: str
    family: str
    variant: str
    setting: str
    projection: bool
    h: float | None
    rtol: float | None
    steps: int
    rejected: int
    nfev: int
    backend: str
    backend_reason: str
    fallback: bool
    threads: int
    cpu_min: float
    cpu_median: float
    wall_min: float
    wall_median: float
    cold_wall: float
    repeats: int
    error: float
    resolved: bool
    energy_drift: float
    casimir_drift: float
    orthogonality: float
    success: bool
    field_errors: dict = field(default_factory=dict)
    message: str = ""

    @property
    def cpu_time(self) -> float:
        """The median CPU time (the time the figures plot)."""
        return self.cpu_median

    @property
    def series(self) -> str:
        """The legend label: method, scipy variant, back end (and a fallback said as such)."""
        label = self.method
        if self.family == "scipy":
            label += f" ({self.variant})"
        backend = f"{self.backend}, fallback" if self.fallback else self.backend
        return f"{label} [{backend}]"


def _compiled_declared(system, method) -> bool:
    return system.compiled() is not None and method.compiled() is not None


def point_calls(
    system, y0: dict, span: tuple[float, float], entry: PlanEntry, variant: Variant, setting, backend: str = "auto"
):
    """The two calls of one point of a study: ``fn()``, the timed run over the whole ``span``,
    and ``warm_fn()``, the untimed warm-up with the same settings over the first
    ``WARM_UP_FRACTION`` of it (at least ten steps of a fixed grid) — what a series' first
    compilation happens in. Each returns the :class:`lieint.Solution`."""
    T = span[1] - span[0]
    grid = np.linspace(*span, GRID + 1)
    method = get_method(entry.method)
    if entry.kind == "fixed":
        n = int(setting)

        def run(t1, full=True):
            return integrate(
                system,
                y0,
                (span[0], t1),
                h=T / n,
                method=entry.method,
                project=variant.project,
                save_every=max(1, n // GRID),
                backend=backend,
            )
    elif method.self_controlled:

        def run(t1, full=True):
            return integrate(
                system,
                y0,
                (span[0], t1),
                method=entry.method,
                rtol=setting,
                atol=setting * ATOL_RATIO,
                project=variant.project,
                t_eval=grid if full else None,
            )
    else:

        def run(t1, full=True):
            return integrate(
                system,
                y0,
                (span[0], t1),
                method=entry.method,
                rtol=setting,
                atol=setting * ATOL_RATIO,
                project=variant.project,
                save_every=1,
            )

    def fn():
        return run(span[1])

    def warm_fn():
        # the same settings over the first part of the span (at least ten steps of a fixed
        # grid): it warms what the timed calls use; their warnings are the ones that count
        part = WARM_UP_FRACTION * T
        if entry.kind == "fixed":
            part = max(part, 10 * T / int(setting))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return run(span[0] + min(T, part), full=False)

    return fn, warm_fn


def measure_point(
    scene,
    system,
    y0: dict,
    entry: PlanEntry,
    variant: Variant,
    setting,
    reference: Reference,
    scale: float,
    *,
    repeats: int = 3,
    backend: str = "auto",
    warm_up: bool = True,
    budget: float = BUDGET,
) -> StudyRow:
    """Run and time one point, and measure its error against ``reference``.

    ``warm_up`` runs one untimed call first (the same settings over the first
    ``WARM_UP_FRACTION`` of the span); the study warms up once per series (the first point of
    each method and variant), which is what first-call costs (compilation, imports) depend on.
    ``budget``: seconds of timed calls after which the point stops repeating.
    """
    span = (scene.t_start, scene.t_end)
    T = span[1] - span[0]
    method = get_method(entry.method)
    fn, warm_fn = point_calls(system, y0, span, entry, variant, setting, backend)
    try:
        timing, sol = timed(fn, repeats, warm_up=warm_up, budget=budget, warm_fn=warm_fn)
    except (DexpinvRangeError, np.linalg.LinAlgError) as exc:  # the step is too large for this method
        return _failed(scene, entry, variant, setting, T, str(exc))
    stats = sol.stats
    if sol.success:
        error, per_field = state_error(sol.t, sol.states, reference, scale)
    else:
        error, per_field = float("nan"), {}
    inv = sol.invariants
    return StudyRow(
        scene=scene.name,
        method=entry.method,
        family=entry.family,
        variant=variant.name,
        setting=entry.label(setting, T),
        projection=variant.project,
        h=stats.h,
        rtol=stats.rtol,
        steps=int(stats.nsteps),
        rejected=int(stats.nrejected),
        nfev=int(stats.nfev),
        backend=stats.backend,
        backend_reason=stats.backend_reason,
        fallback=stats.backend == "numpy" and backend == "auto" and _compiled_declared(system, method),
        threads=_threads(stats.backend),
        cpu_min=timing.cpu_min,
        cpu_median=timing.cpu_median,
        wall_min=timing.wall_min,
        wall_median=timing.wall_median,
        cold_wall=timing.cold_wall,
        repeats=timing.repeats,
        error=error,
        resolved=bool(np.isfinite(error)) and reference.resolved(error),
        energy_drift=_max_drift(sol, "energy"),
        casimir_drift=_max_drift(sol, "casimirs"),
        orthogonality=float(np.max(inv["orthogonality"])) if "orthogonality" in inv else float("nan"),
        success=bool(sol.success),
        field_errors=per_field,
        message="" if sol.success else sol.message,
    )


def _failed(scene, entry, variant, setting, T, message) -> StudyRow:
    """The row of a point whose run raised (shown as failed, with the reason)."""
    nan = float("nan")
    return StudyRow(
        scene=scene.name,
        method=entry.method,
        family=entry.family,
        variant=variant.name,
        setting=entry.label(setting, T),
        projection=variant.project,
        h=T / setting if entry.kind == "fixed" else None,
        rtol=None if entry.kind == "fixed" else setting,
        steps=0,
        rejected=0,
        nfev=0,
        backend="none",
        backend_reason="the run raised before finishing",
        fallback=False,
        threads=1,
        cpu_min=nan,
        cpu_median=nan,
        wall_min=nan,
        wall_median=nan,
        cold_wall=nan,
        repeats=0,
        error=nan,
        resolved=False,
        energy_drift=nan,
        casimir_drift=nan,
        orthogonality=nan,
        success=False,
        message=message,
    )


def _threads(backend: str) -> int:
    """Threads the run could use: numba's current setting for compiled runs, else one."""
    if backend != "numba":
        return 1
    import numba

    return int(numba.get_num_threads())


def _max_drift(sol, name: str) -> float:
    if name not in sol.system.invariants:
        return float("nan")
    with np.errstate(invalid="ignore"):
        return float(np.max(sol.drift(name)))
