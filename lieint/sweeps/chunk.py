"""One chunk of a sweep: its members integrated as batched ensembles, on whatever worker runs it.

A chunk holds consecutive members, i.e. whole or partial ensembles of a few parameter points.
Members that share a system run as **one batched call** of :func:`lieint.integrate` (a compiled
ensemble kernel where one covers the system and method). Members of different systems run as
one batch as well when the systems can be stacked (:func:`lieint.systems.stacked.stack_systems`:
per-member parameters with a leading batch axis) and no compiled kernel would cover them one by
one; otherwise each point's members run as their own batch.

The result depends only on the plan and the chunk index, never on the worker, so a chunk that is
recomputed (a worker killed, a resumed sweep) gives the same bits.
"""

from __future__ import annotations

import os
import socket
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..groups.base import DexpinvRangeError
from .plan import SweepError, SweepPlan

__all__ = ["ChunkResult", "compute_chunk"]


@dataclass
class ChunkResult:
    """What a chunk hands back: member-major arrays and the chunk's metadata.

    Attributes
    ----------
    index : int
        The chunk's index.
    start, stop : int
        Its members ``[start, stop)``.
    t : ndarray, shape (m,)
        The save times.
    states : dict
        Each state field, ``(members, m, *field_shape)``.
    series : dict
        Each requested output or invariant, ``(members, m, *shape)``.
    drifts : dict
        Each requested invariant's drift (:mod:`lieint.drift`), ``(members,)``.
    meta : dict
        Method, back end, timings (s), steps, worker, host, process id, success, message.
    indicators : dict
        Each requested chaos indicator (:mod:`lieint.sweeps.indicators`), ``(members,)``.
    """

    index: int
    start: int
    stop: int
    t: np.ndarray
    states: dict[str, np.ndarray]
    series: dict[str, np.ndarray]
    drifts: dict[str, np.ndarray]
    meta: dict = field(default_factory=dict)
    indicators: dict[str, np.ndarray] = field(default_factory=dict)


def _groups(plan: SweepPlan, start: int, stop: int) -> list[tuple[int, int, int]]:
    """``(point, e0, e1)``: the chunk's members point by point."""
    E = plan.ensemble
    out = []
    for p in range(start // E, (stop - 1) // E + 1):
        e0, e1 = max(start - p * E, 0), min(stop - p * E, E)
        out.append((p, e0, e1))
    return out


def _worker_name() -> str:
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return "local"


def _run(plan: SweepPlan, system, y0: dict, backend: str):
    from ..ivp import LieStepWarning, integrate

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LieStepWarning)
        sol = integrate(system, y0, plan.t_span, backend=backend, **plan.options)
    notes = sorted({str(w.message) for w in caught if issubclass(w.category, LieStepWarning)})
    return sol, notes


def _name_the_member(exc, plan: SweepPlan, system, y: dict, first_member: int):
    """The error of a batch refused its step, naming the sweep's member that refuses it."""
    from ..scenes.engine import fastest_member

    which = fastest_member(system, y, float(plan.t_span[0]), float(plan.options["h"]))
    if which is None:
        index, radius = 0, None
    else:
        index, radius = which
    member = first_member + index
    point = member // plan.ensemble
    values = ", ".join(f"{v.key.text} = {x:g}" for v, x in zip(plan.variations, plan.point_values(point), strict=True))
    step = f": its first step has ‖h ξ‖ = {radius:.3g}" if radius is not None else ""
    return DexpinvRangeError(
        f"{exc} The member that refuses it is member {member} (point {point}{', ' + values if values else ''}, "
        f"ensemble member {member % plan.ensemble}){step}."
    )


def compute_chunk(plan: SweepPlan, index: int, backend: str = "auto") -> ChunkResult:
    """Integrate the members of chunk ``index`` (see the module docstring).

    Parameters
    ----------
    plan : SweepPlan
    index : int
        The chunk.
    backend : {"auto", "numpy", "numba"}
        As for :func:`lieint.integrate`.

    Returns
    -------
    ChunkResult
    """
    from ..systems.stacked import stack_systems
    from .indicators import compute_indicators

    started = time.time()
    wall0, cpu0 = time.perf_counter(), time.process_time()
    start, stop = plan.chunk_range(index)
    built = [(plan.build_point(p), e0, e1) for p, e0, e1 in _groups(plan, start, stop)]
    runs = []  # (system, y0) batches, in member order
    systems = [s for (s, _), _, _ in built]
    stacked = None
    if len(built) > 1 and (systems[0].compiled() is None or backend == "numpy"):
        stacked = stack_systems(systems, counts=[e1 - e0 for _, e0, e1 in built])
    if stacked is not None:
        y = {k: np.concatenate([y0[k][e0:e1] for (_, y0), e0, e1 in built]) for k in systems[0].fields}
        runs.append((stacked, y))
    else:
        runs.extend((s, {k: v[e0:e1] for k, v in y0.items()}) for (s, y0), e0, e1 in built)

    t = None
    parts: list[tuple[dict, dict, dict, dict]] = []
    backends, reasons, notes = [], [], []
    nsteps, success, messages = 0, True, []
    cpu_steps = wall_steps = 0.0
    first_member = start
    for system, y in runs:
        if system.fields != systems[0].fields:
            raise SweepError(
                f"every member of a sweep must have the same state fields; the scene builds {type(system).__name__} "
                f"with {list(system.fields)} at some points and {type(systems[0]).__name__} with "
                f"{list(systems[0].fields)} at others (e.g. a centre of mass that becomes zero changes a heavy top "
                "into an Euler top)"
            )
        try:
            sol, caught = _run(plan, system, y, backend)
        except DexpinvRangeError as exc:
            raise _name_the_member(exc, plan, system, y, first_member) from None
        indicators = {}
        if plan.indicators:
            indicators, failed = compute_indicators(plan, system, y, first_member, stacked=system is stacked)
            notes.extend(failed)
        first_member += system.batch_shape(y)[0] if system.batch_shape(y) else 1
        if t is None:
            t = sol.t
        elif not np.array_equal(t, sol.t):  # pragma: no cover - fixed-step grids are shared
            raise SweepError("the members of a chunk saved at different times")
        states = {k: np.swapaxes(v, 0, 1) for k, v in sol.states.items()}
        names = list(plan.outputs)
        series = {k: np.swapaxes(np.asarray(v), 0, 1) for k, v in sol.outputs(names).items()}
        drifts = {k: np.asarray(sol.drift(k), dtype=float).reshape(-1) for k in names if k in system.invariants}
        parts.append((states, series, drifts, indicators))
        backends.append(sol.stats.backend)
        reasons.append(sol.stats.backend_reason)
        if plan.indicators:
            from ..tangent.flow import tangent_backend

            tangent = tangent_backend(system, plan.options.get("method", "rkmk4"), plan.options.get("coordinates"))
            reasons.append(f"{', '.join(plan.indicators)}: {tangent}")
        notes.extend(caught)
        nsteps = max(nsteps, sol.stats.nsteps)
        cpu_steps += sol.stats.cpu_time
        wall_steps += sol.stats.wall_time
        if not sol.success:
            success = False
            messages.append(sol.message)

    def cat(i):
        return {k: np.concatenate([part[i][k] for part in parts]) for k in parts[0][i]}

    meta = {
        "method": str(plan.options.get("method")),
        "backend": "+".join(sorted(set(backends))),
        "backend_reason": "; ".join(sorted({r for r in reasons if r})),
        "batches": len(runs),
        "stacked": stacked is not None,
        "nsteps": int(nsteps),
        "cpu_time": time.process_time() - cpu0,
        "wall_time": time.perf_counter() - wall0,
        "step_cpu_time": cpu_steps,
        "step_wall_time": wall_steps,
        "started": started,
        "finished": time.time(),
        "worker": _worker_name(),
        "host": socket.gethostname(),
        "pid": os.getpid(),
        "success": success,
        "message": "; ".join(messages) if messages else "ok",
        "warnings": "; ".join(sorted(set(notes))),
    }
    return ChunkResult(index, start, stop, np.asarray(t), cat(0), cat(1), cat(2), meta, cat(3))
