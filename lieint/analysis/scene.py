"""``lieint analyze``: the count toward integrability and the holonomy verdict of a scene's system
at its initial state."""

from __future__ import annotations

import numpy as np

from .holonomy import constraint_of, is_holonomic
from .integrability import integrability_count

__all__ = ["analyze", "analyze_scene"]


def analyze(system, state: dict, *, integrals: str = "momentum") -> dict:
    """The count and the holonomy verdict of a system at one state.

    Returns a dict with ``"count"`` (:class:`~lieint.analysis.IntegrabilityCount` or None) and
    ``"count_error"`` (why there is none), ``"holonomy"`` (:class:`~lieint.analysis.HolonomyResult`
    or None) and ``"holonomy_error"``. A batched state is analysed at its first member.
    """
    one = {k: np.asarray(v)[(0,) * (np.ndim(v) - len(system.fields[k]))] for k, v in state.items()}
    out: dict = {"count": None, "count_error": None, "holonomy": None, "holonomy_error": None}
    try:
        out["count"] = integrability_count(system, one, integrals=integrals, verbose=False)
    except ValueError as exc:
        out["count_error"] = str(exc)
    try:
        out["holonomy"] = is_holonomic(constraint_of(system, one))
    except ValueError as exc:
        out["holonomy_error"] = str(exc)
    return out


def analyze_scene(scene, *, integrals: str = "momentum") -> dict:
    """:func:`analyze` for a scene's system at its initial state (nothing is integrated)."""
    from ..scenes.engine import build_system

    system, y0 = build_system(scene)
    result = analyze(system, y0, integrals=integrals)
    result["scene"] = scene.name
    result["system"] = repr(system)
    return result


def format_analysis(result: dict) -> str:
    """The printed form of :func:`analyze_scene`."""
    lines = [f"{result['scene']} — {result['system']}"]
    if result["count"] is not None:
        lines.append(result["count"].report())
    else:
        lines.append(f"count toward integrability: not available ({result['count_error']})")
    if result["holonomy"] is not None:
        lines.append(result["holonomy"].report())
    else:
        lines.append(f"holonomy: not available ({result['holonomy_error']})")
    return "\n".join(lines)


def analysis_json(result: dict) -> dict:
    """The JSON form of :func:`analyze_scene`."""
    return {
        "scene": result["scene"],
        "system": result["system"],
        "count": None if result["count"] is None else result["count"].to_dict(),
        "count_error": result["count_error"],
        "holonomy": None if result["holonomy"] is None else result["holonomy"].to_dict(),
        "holonomy_error": result["holonomy_error"],
    }
