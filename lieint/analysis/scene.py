"""``lieint analyze``: the count toward integrability and the holonomy verdict of a scene's system
at its initial state."""

from __future__ import annotations

import numpy as np

from .holonomy import constraint_of, is_holonomic
from .integrability import integrability_count

__all__ = ["analyze", "analyze_scene", "scene_indicators"]


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


def scene_indicators(
    scene,
    *,
    lyapunov: bool = False,
    megno: bool = False,
    max_error_estimate: float | None = None,
    t_end: float | None = None,
) -> dict:
    """Chaos indicators of a scene's motion on the exact tangent map of its method and step.

    Parameters
    ----------
    scene : Scene
        The scene; its [integrator] gives the method, its coordinates, the step and the span.
    lyapunov, megno : bool
        Which indicators to compute (:func:`lieint.lyapunov`: the whole spectrum;
        :func:`lieint.megno`).
    max_error_estimate : float, optional
        Also estimate the run's global error (:func:`lieint.trust_horizon`) and report when it
        exceeds this tolerance.
    t_end : float, optional
        The end of the run instead of the scene's ``t_end`` (the indicators converge slowly).

    Returns
    -------
    dict
        ``"lyapunov"``: exponents per member (list of lists) and ``"pairing"`` (max |λ_i + λ_{k+1-i}|),
        ``"megno"``: ⟨Y⟩ per member; ``"trust_horizon"``: per member the time the error estimate
        exceeds ``"max_error_estimate"`` (None: not by ``t_end``) and ``"error_estimate"``, the
        estimate at the end; with ``"t_end"``, ``"h"``, ``"method"``, ``"backend_reason"``.

    Raises
    ------
    ValueError
        The scene's method has no tangent map.

    Notes
    -----
    The run takes fixed steps of the scene's ``step``, an embedded pair its propagated solution
    (the tangent map of an adaptive run needs its accepted steps, :func:`lieint.tangent_flow`).
    """
    from ..scenes.engine import build_system
    from .chaos import lyapunov as lyapunov_of
    from .chaos import megno as megno_of

    system, y0 = build_system(scene)
    t1 = scene.t_end if t_end is None else float(t_end)
    out: dict = {"t_end": t1, "h": scene.step, "method": scene.method}
    span, common = (scene.t_start, t1), {"method": scene.method, "coordinates": scene.coordinates}
    if lyapunov:
        spec = lyapunov_of(system, y0, span, scene.step, **common)
        out["lyapunov"] = np.atleast_2d(spec.exponents).tolist()
        out["pairing"] = np.atleast_1d(spec.pairing_defect()).tolist()
        out["labels"] = spec.chart.labels()
        out["backend_reason"] = spec.backend_reason
    if megno:
        m = megno_of(
            system, y0, span, scene.step, save_every=max(1, int((t1 - scene.t_start) / scene.step) // 100), **common
        )
        out["megno"] = np.atleast_1d(m.mean).tolist()
        out["backend_reason"] = m.backend_reason
    if max_error_estimate is not None:
        from ..tangent.horizon import trust_horizon

        run = trust_horizon(system, y0, span, scene.step, tolerance=max_error_estimate, **common)
        horizon = np.atleast_1d(run.horizon)
        out["max_error_estimate"] = float(max_error_estimate)
        out["trust_horizon"] = [None if np.isinf(v) else float(v) for v in horizon]
        out["error_estimate"] = np.atleast_1d(run.estimate[-1]).tolist()
        out["backend_reason"] = run.backend_reason
    return out


def format_indicators(result: dict) -> str:
    """The printed form of :func:`scene_indicators` (chaos indicators, trust horizon)."""
    lines = [f"on the tangent map: {result['method']}, h = {result['h']:g}, t_end = {result['t_end']:g} "
             f"fixed steps (exact tangent map; {result['backend_reason']})"]  # fmt: skip
    if "megno" in result:
        values = ", ".join(f"{v:.3f}" for v in result["megno"])
        lines.append(f"MEGNO <Y> = {values}  (-> 2 regular/quasi-periodic, grows like lambda t/2 if chaotic)")
    if "trust_horizon" in result:
        tol = result["max_error_estimate"]
        for i, (t, e) in enumerate(zip(result["trust_horizon"], result["error_estimate"], strict=True)):
            member = f"member {i}: " if len(result["trust_horizon"]) > 1 else ""
            if t is None:
                lines.append(f"trust horizon {member}not reached: the error estimate is {e:.2e} <= {tol:g} at the end")
            else:
                lines.append(f"trust horizon {member}t = {t:g}: the estimated global error exceeds {tol:g} there")
    if "lyapunov" in result:
        for i, (exps, pair) in enumerate(zip(result["lyapunov"], result["pairing"], strict=True)):
            member = f"member {i}: " if len(result["lyapunov"]) > 1 else ""
            lines.append(
                f"Lyapunov exponents {member}" + " ".join(f"{v:.4g}" for v in exps) + f"  (pairs sum to {pair:.1e})"
            )
    return "\n".join(lines)


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
    if "indicators" in result:
        lines.append(format_indicators(result["indicators"]))
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
    } | ({"indicators": result["indicators"]} if "indicators" in result else {})
