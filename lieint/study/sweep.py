"""Run a whole study on one scene: the plan, the reference, every point, the metadata."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from ..scenes import Scene, build_system
from .machine import machine_info, set_threads
from .measure import BUDGET, QUICK_BUDGET, WARM_UP_FRACTION, StudyRow, measure_point
from .plan import PlanEntry, study_plan
from .reference import RESOLVED, Reference, reference_for, state_scale

__all__ = ["Study", "run_study_full"]

#: numba threads of a study unless asked otherwise: one trajectory has nothing to run in
#: parallel, and a thread pool's start-up would be timed as the cost of every compiled call
DEFAULT_THREADS = 1
#: a series stops once one of its points takes longer than this (CPU seconds per call): the
#: full sweep's limit, and the quick sweep's (the main job ``lieint compare`` is the quick sweep,
#: and the methods without a compiled kernel cost seconds per call at its finer points)
MAX_SECONDS = 5.0
QUICK_MAX_SECONDS = 1.0


@dataclass
class Study:
    """A finished study of one scene.

    Attributes
    ----------
    scene : Scene
        The scene as studied (its outputs extended by the orientation, so R is compared).
    reference : Reference
        The truth (kind, floor).
    plan : list of PlanEntry
    rows : list of StudyRow
    metadata : dict
        The machine (:func:`lieint.study.machine_info`), threads, back end asked for, repeats,
        sweep size, timing protocol.
    """

    scene: Scene
    reference: Reference
    plan: list[PlanEntry]
    rows: list[StudyRow]
    metadata: dict = field(default_factory=dict)

    def __iter__(self):
        # unpacks as ``rows, reference_kind``: the earlier return value of ``run_study``
        return iter((self.rows, self.reference.kind))

    @property
    def span(self) -> float:
        return self.scene.t_end - self.scene.t_start

    def describe(self) -> str:
        """One line: the scene, its span and the reference with its floor."""
        return (
            f"{self.scene.name}: T = {self.span:g}; error = max_t |y - y_ref| / |y0| over the whole state "
            f"({', '.join(self.reference.fields)}) against {self.reference.kind}; reference floor "
            f"{self.reference.floor:.1e} (errors below {RESOLVED:g}x the floor are marked unresolved)"
        )


def prepare(scene: Scene):
    """``(scene, system, y0)`` with the orientation added to the outputs (R is compared too) and
    an ``[ensemble]`` table dropped: a study runs the scene's nominal trajectory.

    A body named by ``[body] system`` integrates its whole state whatever the outputs, so
    only scenes built from the body tables (where R is simulated on demand) get the addition."""
    outputs = scene.outputs if scene.system is not None else (*scene.outputs, "orientation")
    scene = replace(scene, outputs=tuple(dict.fromkeys(outputs)), ensemble=None)
    system, y0 = build_system(scene)
    return scene, system, y0


def _warm_kernel(scene, system, y0, entry: PlanEntry, variant, backend: str) -> None:
    """Load the compiled kernel once when a series' first point fell back to the generic path,
    so that the kernel's first call is not timed in a later point of the series: ten steps of
    the finest step of the sweep (inside the kernel's range whenever any step of it is)."""
    from ..ivp import integrate

    h = (scene.t_end - scene.t_start) / max(entry.settings)
    integrate(
        system,
        y0,
        (scene.t_start, scene.t_start + 10 * h),
        h=h,
        method=entry.method,
        project=variant.project,
        backend=backend,
    )


def run_study_full(
    scene: Scene,
    *,
    methods=None,
    quick: bool = True,
    repeats: int = 3,
    threads: int | None = DEFAULT_THREADS,
    backend: str = "auto",
    max_seconds: float | str | None = "auto",
    skip_inapplicable: bool = False,
    progress=None,
) -> Study:
    """Run the study of ``scene``; see :func:`lieint.study.run_study` for the parameters."""
    if isinstance(max_seconds, str) and max_seconds == "auto":
        max_seconds = QUICK_MAX_SECONDS if quick else MAX_SECONDS
    if backend not in ("auto", "numpy"):
        raise ValueError(f"`backend` must be 'auto' or 'numpy'; got {backend!r}.")
    if max_seconds is not None and not (isinstance(max_seconds, int | float) and max_seconds > 0):
        raise ValueError(f"`max_seconds` must be a positive number, 'auto' or None; got {max_seconds!r}.")
    ensemble = scene.ensemble
    scene, system, y0 = prepare(scene)
    not_applicable: dict[str, str] = {}
    plan = study_plan(system, scene, methods, quick=quick, skipped=not_applicable if skip_inapplicable else None)
    reference = reference_for(scene, system, y0)
    scale = state_scale(y0, reference.fields)
    previous = set_threads(None)
    used_threads = set_threads(threads)
    rows, skipped = [], []
    try:
        for entry in plan:
            for variant in entry.variants:
                for i, setting in enumerate(entry.settings):
                    row = measure_point(
                        scene,
                        system,
                        y0,
                        entry,
                        variant,
                        setting,
                        reference,
                        scale,
                        repeats=repeats,
                        backend=backend,
                        warm_up=i == 0,
                        budget=QUICK_BUDGET if quick else BUDGET,
                    )
                    rows.append(row)
                    if progress:
                        progress(row)
                    if i == 0 and row.fallback:
                        _warm_kernel(scene, system, y0, entry, variant, backend)
                    rest = entry.settings[i + 1 :]
                    if max_seconds is not None and rest and row.cpu_median > max_seconds:
                        # finer steps and tighter tolerances cost more still: stop the series, say so
                        skipped.append(
                            {
                                "method": entry.method,
                                "variant": variant.name,
                                "settings": [entry.label(s, scene.t_end - scene.t_start) for s in rest],
                                "reason": f"{row.setting} took {row.cpu_median:.1f} s CPU > {max_seconds:g} s",
                            }
                        )
                        break
    finally:  # the caller's thread setting is theirs
        set_threads(previous)
    metadata = {
        "machine": machine_info(threads),
        "numba_threads": used_threads,
        "backend_requested": backend,
        "repeats": repeats,
        "sweep": "quick" if quick else "full",
        "timing": (
            "warm: one untimed call per method and variant first, over the first "
            f"{WARM_UP_FRACTION:g} of the span with the same settings (compilation, caches; its wall time "
            "is cold_wall of the series' first point), then up to `repeats` timed calls of "
            f"lieint.integrate over the whole span (fewer when they exceed {QUICK_BUDGET if quick else BUDGET:g} s); "
            "CPU = process time of all threads, wall = elapsed"
        ),
        "span": [scene.t_start, scene.t_end],
        "scene_step": scene.step,
        "reference": {"kind": reference.kind, "floor": reference.floor, "exact": reference.exact},
        "max_seconds": max_seconds,
        "skipped": skipped,
        "not_applicable": not_applicable,
    }
    if ensemble:
        metadata["note"] = "the scene's [ensemble] was dropped: the study runs the nominal trajectory"
    return Study(scene, reference, plan, rows, metadata)
