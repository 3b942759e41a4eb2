"""Run a whole study on one scene: the plan, the reference, every point, the metadata."""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field, replace

from ..scenes import Scene, build_system
from .machine import machine_info, set_threads
from .measure import BUDGET, QUICK_BUDGET, WARM_UP_FRACTION, StudyRow, _compiled_declared, measure_point, point_calls
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


def _warm_series(scene: Scene, entry: PlanEntry, variant, setting, backend: str) -> None:
    """A series' warm-up call in a process of its own (:func:`compile_ahead`): the system is
    built there again from the (prepared) scene."""
    system, y0 = build_system(scene)
    point_calls(system, y0, (scene.t_start, scene.t_end), entry, variant, setting, backend)[1]()


def compile_ahead(scene: Scene, system, y0: dict, plan: list[PlanEntry], backend: str, jobs: int | None) -> dict:
    """Compile the kernels of the study's compiled series before anything is timed, in ``jobs``
    processes at once when the disk cache turns out to be cold.

    The first compiled series warms up here; if numba had to compile for it, the cache is cold
    and the warm-ups of one series per other kernel run in fresh processes, one per core
    (:func:`lieint.warmup.compile_in_processes`), which fill the cache that the timed calls then
    load. Nothing is timed meanwhile, so the processes do not disturb a measurement. With
    ``jobs`` = 1 nothing happens here. Returns what it did (``metadata["compiled_ahead"]``)."""
    from ..fast import _jit
    from ..methods.registry import get_method
    from ..warmup import compile_in_processes, usable_cpus

    # one series per kernel: the methods of one compiled family and kind (the energy-keeping
    # pairs apart) run one loop's kernel, their coefficients being data; two processes compiling
    # the same kernel at once would only race to write it
    series, kernels = [], set()
    for entry in plan:
        method = get_method(entry.method)
        if backend != "auto" or not _compiled_declared(system, method):
            continue
        for variant in entry.variants:
            kernel = (method.compiled().family, entry.kind, entry.family.endswith("energy"), variant.project)
            if kernel not in kernels:
                kernels.add(kernel)
                series.append((entry, variant, entry.settings[0]))
    done = {"series": len(series), "processes": 0, "wall": 0.0}
    if not series or jobs == 1:  # one process: each series compiles as it starts, as it always did
        return done
    wall = time.perf_counter()
    before = _jit.compilations()
    entry, variant, setting = series[0]
    try:
        point_calls(system, y0, (scene.t_start, scene.t_end), entry, variant, setting, backend)[1]()
    except Exception:  # the series' own first point reports it
        pass
    if _jit.compilations() > before and len(series) > 1:
        # the controller loops first: the longest compilations, started while the pool is widest
        rest = sorted(series[1:], key=lambda one: one[0].kind != "adaptive")
        tasks = [functools.partial(_warm_series, scene, *one, backend) for one in rest]
        done["processes"] = min(usable_cpus() if jobs is None else jobs, len(tasks))
        compile_in_processes(tasks, jobs)
    done["wall"] = time.perf_counter() - wall
    return done


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
    compile_jobs: int | None = 1,
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
        ahead = compile_ahead(scene, system, y0, plan, backend, compile_jobs)
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
        "compiled_ahead": ahead,
        "timing": (
            "warm: one untimed call per method and variant first, over the first "
            f"{WARM_UP_FRACTION:g} of the span with the same settings (compilation, caches; its wall time "
            "is cold_wall of the series' first point; on a cold numba cache the compiled series were "
            "compiled before, in parallel processes: compiled_ahead), then up to `repeats` timed calls of "
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
