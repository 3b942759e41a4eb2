"""Compile the engine's kernels ahead of the first run (``lieint warmup``, :func:`warmup`).

numba compiles a kernel on its first call in an environment whose disk cache does not hold it
yet — a fresh install, a new numba, a cluster node's empty home directory — and caches the
machine code for every later process. A cluster job or a CI run that would otherwise pay that
in its first integration compiles here instead, once: each built-in system with each compiled
method family (fixed-step RKMK in exponential and Cayley coordinates, the embedded pairs'
controller loop, classical RK, the products of exponentials of the commutator-free and
Crouch–Grossman methods, the SIMD lanes of an ensemble of 3D tops, heavy tops or Chaplygin
balls, the tops' Moser–Veselov maps and the 3D top's splitting), and the pieces of the generic
form. Items the cache already holds cost a fraction of a second.

numba compiles under one lock per process, so a process compiles one kernel at a time whatever
its threads; :func:`compile_in_processes` spreads the first calls over fresh processes, one per
core, which write the disk cache that the caller then loads (``lieint warmup --jobs``, and the
study of ``lieint compare`` on a cold cache).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["WARMUP_SYSTEMS", "WarmupItem", "compile_in_processes", "usable_cpus", "warmup"]


def _euler_top(n: int):
    def build():
        from .systems.euler_top import EulerTop

        top = EulerTop(np.diag(np.linspace(1.0, 2.0, n)))
        X = np.triu(np.full((n, n), 0.3), 1)
        return top, top.initial_state(Omega=X - X.T)

    return build


def _heavy_top():
    from .systems.heavy_top import HeavyTop

    system = HeavyTop(np.diag([1.0, 2.0, 3.0]), 1.0, [0.0, 0.1, 0.3], [0.0, 0.0, -9.81])
    return system, system.initial_state(angular_velocity=[0.3, 1.0, 0.2])


def _free_body():
    from .systems.free_body import FreeBody

    system = FreeBody(np.diag([1.0, 2.0, 3.0]), mass=1.0)
    return system, system.initial_state(angular_velocity=[0.3, 1.0, 0.2], velocity=[0.1, 0.0, 0.0])


def _chaplygin_ball():
    from .systems.chaplygin import ChaplyginBall

    system = ChaplyginBall(np.diag([0.1, 0.12, 0.15]), mass=1.0, radius=1.0)
    return system, system.initial_state(angular_velocity=[0.3, 1.0, 0.2])


def _rolling_ball():
    from .systems.rolling_ball import RollingBall

    system = RollingBall(
        np.diag([0.1, 0.12, 0.15]), mass=1.0, radius=1.0, center_of_mass=[0.0, 0.0, -0.2], gravity=[0.0, 0.0, -9.81]
    )
    return system, system.initial_state(angular_velocity=[0.3, 1.0, 0.2])


#: what ``lieint warmup`` compiles, by name: a small instance of each built-in system with a
#: compiled form (the n-dimensional top for n = 4; every n ≥ 4 shares its kernels)
WARMUP_SYSTEMS: dict[str, Callable] = {
    "euler_top": _euler_top(3),
    "euler_top_nd": _euler_top(4),
    "heavy_top": _heavy_top,
    "free_body": _free_body,
    "chaplygin_ball": _chaplygin_ball,
    "rolling_ball": _rolling_ball,
}

#: the method families each system is warmed with: (label, integrate's keywords)
_RUNS = (
    ("RKMK, exponential coordinates", dict(method="rkmk4", h=0.01)),
    ("RKMK, Cayley coordinates", dict(method="rkmk4", h=0.01, coordinates="cayley")),
    ("embedded pair (controller loop)", dict(method="rkmk45", rtol=1e-6, atol=1e-9)),
    # the default adaptive method (its energy family; the tops' Cayley coordinates share the
    # kernel, the compiled pieces' have stage code of their own: lieint.fast.generic_step)
    ("energy-keeping pair (controller loop)", dict(method="rkmk853+energy", rtol=1e-6, atol=1e-9)),
    ("classical RK", dict(method="rk4", h=0.01)),
    ("commutator-free, Crouch–Grossman", dict(method="cf4", h=0.01)),
)


@dataclass(frozen=True)
class WarmupItem:
    """One system and method family warmed: the CPU and wall seconds it took and whether numba
    had to compile (False: the disk cache held every kernel it needed)."""

    system: str
    family: str
    cpu: float
    wall: float
    compiled: bool


def _items(names: list[str]) -> list[tuple[str, str, dict]]:
    """``(system, family, integrate's keywords)`` of each kernel warmed, in order."""
    items = []
    for name in names:
        runs = list(_RUNS)
        if name in ("euler_top", "euler_top_nd"):  # the Moser–Veselov maps' own kernels
            runs.append(("Moser–Veselov map", dict(method="moser_veselov", h=0.01)))
        if name == "euler_top":  # the splitting's own kernel; an ensemble runs in SIMD lanes
            runs.append(("splitting into exact rotations", dict(method="splitting2", h=0.01)))
            runs.append(("RKMK, SIMD lanes (ensemble)", dict(method="rkmk4", h=0.01, bodies=64)))
        if name in ("heavy_top", "chaplygin_ball"):  # an ensemble of these 3D bodies runs in SIMD lanes
            runs.append(("RKMK, SIMD lanes (ensemble)", dict(method="rkmk4", h=0.01, bodies=8)))
        items.extend((name, family, keywords) for family, keywords in runs)
    return items


def _warm_item(name: str, family: str, keywords: dict) -> WarmupItem:
    """One kernel warmed: a short run of a small instance of the system (an ensemble of
    ``bodies`` copies of its state where the keywords ask for one)."""
    from . import ivp
    from .fast import _jit

    system, y0 = WARMUP_SYSTEMS[name]()
    keywords = dict(keywords)
    bodies = keywords.pop("bodies", None)
    if bodies is not None:
        y0 = system.initial_state(angular_velocity=np.tile([0.3, 1.0, 0.2], (bodies, 1)))
    before = _jit.compilations()
    cpu, wall = time.process_time(), time.perf_counter()
    ivp.integrate(system, y0, (0.0, 0.05), backend="numba", **keywords)
    return WarmupItem(name, family, time.process_time() - cpu, time.perf_counter() - wall, _jit.compilations() > before)


def warmup(
    systems: Iterable[str] | None = None,
    report: Callable[[WarmupItem], None] | None = None,
    jobs: int | None = 1,
) -> list[WarmupItem]:
    """Compile the engine's kernels for ``systems`` (names of :data:`WARMUP_SYSTEMS`; default:
    all of them) with every compiled method family, so that later runs start at once.

    Parameters
    ----------
    systems : iterable of str, optional
        Which systems; default all of :data:`WARMUP_SYSTEMS`.
    report : callable, optional
        Called with each :class:`WarmupItem` as it finishes (the command line prints it).
    jobs : int or None, default 1
        Processes compiling at once (:func:`compile_in_processes`; None: one per usable CPU).
        Each item's CPU time is then that of its own process; an item whose process failed
        runs again here, so that its error is raised.

    Returns
    -------
    list of WarmupItem
        In the order of the systems and families (the order they finish in with ``jobs`` > 1).

    Examples
    --------
    >>> from lieint.warmup import warmup
    >>> items = warmup(["euler_top"], jobs=2)  # doctest: +SKIP
    """
    import functools

    names = list(WARMUP_SYSTEMS) if systems is None else list(systems)
    unknown = [name for name in names if name not in WARMUP_SYSTEMS]
    if unknown:
        raise ValueError(f"`systems`: unknown {unknown}; choose from {sorted(WARMUP_SYSTEMS)}.")
    jobs = _check_jobs(jobs)
    todo = _items(names)
    done: list[WarmupItem] = []

    def finished(item: WarmupItem) -> None:
        done.append(item)
        if report is not None:
            report(item)

    if jobs > 1 and len(todo) > 1:
        tasks = [functools.partial(_warm_item, *one) for one in todo]
        results = compile_in_processes(tasks, jobs, done=lambda i, item: item is not None and finished(item))
        todo = [one for one, item in zip(todo, results, strict=True) if item is None]
    for one in todo:  # one process, or what a process could not do (its error is raised here)
        finished(_warm_item(*one))
    return done


def usable_cpus() -> int:
    """The CPUs this process may run on (its affinity where the platform tells it, else the
    machine's count)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def _check_jobs(jobs) -> int:
    if jobs is None:
        return usable_cpus()
    if isinstance(jobs, bool) or not isinstance(jobs, int | np.integer) or jobs < 1:
        raise ValueError(f"`jobs` must be a positive integer (processes compiling at once); got {jobs!r}.")
    return int(jobs)


def compile_in_processes(
    tasks: Sequence[Callable[[], object]],
    jobs: int | None = None,
    done: Callable[[int, object], object] | None = None,
) -> list:
    """Call ``tasks`` in up to ``jobs`` fresh processes at once, for the kernels they compile.

    numba compiles a kernel on its first call and keeps it in its disk cache; a process compiles
    one kernel at a time (numba's compiler lock), so on a cold cache the first calls of many
    kernels take as many times one core. Here each task runs in a process of its own pool
    (started by ``spawn``: a fork would copy numba's and the BLAS's threads), the pool as wide as
    ``jobs``, and the caller then finds the kernels in the cache. ``spawn`` imports the caller's
    main module again in each process, so a script that calls this keeps its work under
    ``if __name__ == "__main__":`` (as for any spawn pool). The tasks are for their side
    effect: a task that fails is left for the caller's own call of the same thing to report, and
    a pool that cannot start or breaks (a process killed, no memory) ends this quietly for the
    same reason.

    Parameters
    ----------
    tasks : sequence of callable
        Picklable callables without arguments (module-level functions, ``functools.partial``
        of them); each returns a picklable value or None.
    jobs : int, optional
        Processes at once; default :func:`usable_cpus`. With one job, or one task, the tasks run
        in this process, one after the other.
    done : callable, optional
        Called in this process as each task finishes, with its index and its value.

    Returns
    -------
    list
        Each task's return value, in the order of ``tasks`` (None for a task that failed, or
        that a broken pool did not run).
    """
    jobs = _check_jobs(jobs)
    results: list = [None] * len(tasks)
    if jobs == 1 or len(tasks) <= 1:
        for i, task in enumerate(tasks):
            results[i] = _call_quietly(task)
            if done is not None:
                done(i, results[i])
        return results
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from concurrent.futures.process import BrokenProcessPool

    try:
        with ProcessPoolExecutor(min(jobs, len(tasks)), mp_context=multiprocessing.get_context("spawn")) as pool:
            futures = {pool.submit(_call_quietly, task): i for i, task in enumerate(tasks)}
            for future in as_completed(futures):
                i = futures[future]
                try:
                    results[i] = future.result()
                except BrokenProcessPool:
                    break
                if done is not None:
                    done(i, results[i])
    except (OSError, BrokenProcessPool):  # no processes to be had: the caller compiles as before
        pass
    return results


def _call_quietly(task):
    """``task()`` in a pool's process; None when it raises (the caller's call reports it)."""
    try:
        return task()
    except Exception:  # reported by the caller's own call
        return None
