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
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

__all__ = ["WARMUP_SYSTEMS", "WarmupItem", "warmup"]


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
    # the default adaptive method (its energy family; Cayley coordinates share the kernel)
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


def warmup(
    systems: Iterable[str] | None = None, report: Callable[[WarmupItem], None] | None = None
) -> list[WarmupItem]:
    """Compile the engine's kernels for ``systems`` (names of :data:`WARMUP_SYSTEMS`; default:
    all of them) with every compiled method family, so that later runs start at once.

    Parameters
    ----------
    systems : iterable of str, optional
        Which systems; default all of :data:`WARMUP_SYSTEMS`.
    report : callable, optional
        Called with each :class:`WarmupItem` as it finishes (the command line prints it).

    Returns
    -------
    list of WarmupItem

    Examples
    --------
    >>> from lieint.warmup import warmup
    >>> items = warmup(["euler_top"])  # doctest: +SKIP
    """
    from . import ivp
    from .fast import _jit

    names = list(WARMUP_SYSTEMS) if systems is None else list(systems)
    unknown = [name for name in names if name not in WARMUP_SYSTEMS]
    if unknown:
        raise ValueError(f"`systems`: unknown {unknown}; choose from {sorted(WARMUP_SYSTEMS)}.")
    items = []
    for name in names:
        system, y0 = WARMUP_SYSTEMS[name]()
        runs = list(_RUNS)
        if name in ("euler_top", "euler_top_nd"):  # the Moser–Veselov maps' own kernels
            runs.append(("Moser–Veselov map", dict(method="moser_veselov", h=0.01)))
        if name == "euler_top":  # the splitting's own kernel; an ensemble runs in SIMD lanes
            runs.append(("splitting into exact rotations", dict(method="splitting2", h=0.01)))
            batch = system.initial_state(angular_velocity=np.tile([0.3, 1.0, 0.2], (64, 1)))
            runs.append(("RKMK, SIMD lanes (ensemble)", dict(method="rkmk4", h=0.01, y0=batch)))
        if name in ("heavy_top", "chaplygin_ball"):  # an ensemble of these 3D bodies runs in SIMD lanes
            batch = system.initial_state(angular_velocity=np.tile([0.3, 1.0, 0.2], (8, 1)))
            runs.append(("RKMK, SIMD lanes (ensemble)", dict(method="rkmk4", h=0.01, y0=batch)))
        for family, keywords in runs:
            keywords = dict(keywords)
            state = keywords.pop("y0", y0)
            before = _jit.compilations()
            cpu, wall = time.process_time(), time.perf_counter()
            ivp.integrate(system, state, (0.0, 0.05), backend="numba", **keywords)
            item = WarmupItem(
                name, family, time.process_time() - cpu, time.perf_counter() - wall, _jit.compilations() > before
            )
            items.append(item)
            if report is not None:
                report(item)
    return items
