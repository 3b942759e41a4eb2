"""Figures of a study, drawn to be read by a numerical analyst.

* :func:`plot_work_precision` — error over the whole state against the median CPU time, log–log,
  one line per series: the legend names the method, scipy's variant and the back end that ran
  (a fallback is its own series, drawn dotted with crosses). The reference's floor is drawn and
  the band below ``RESOLVED × floor`` shaded; a point inside the band is not plotted as a value
  but as an upper bound (a ▽ at the band's edge).
* :func:`plot_long_run` — the drift of each integral invariant against time over a multiple of
  the scene's span, for the scene's own method and classical RK4 *at the scene's step* and
  scipy's DOP853 at the scene's tolerance (stated in the legend), so the figure shows the
  integrators at the step the scene was written for.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from .reference import RESOLVED

__all__ = ["plot_long_run", "plot_work_precision"]

_FAMILY_STYLE = {"rkmk": "-", "rk": "--", "rkmk-embedded": "-.", "scipy": ":"}
_MARKERS = "osD^<>phP*d"  # "v" marks upper bounds, "x" fallbacks


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_work_precision(study, path=None, title: str | None = None):
    """Draw the work–precision figure of ``study`` into ``path`` (PNG or SVG by its suffix) and
    return the path; without ``path``, return the matplotlib figure (left open)."""
    plt = _pyplot() if path is not None else __import__("matplotlib.pyplot").pyplot
    fig, ax = plt.subplots(figsize=(10.5, 6.0))
    colors = plt.get_cmap("tab20").colors
    ref = study.reference
    limit = RESOLVED * ref.floor
    series: dict[str, list] = {}
    for row in study.rows:
        if row.success and np.isfinite(row.error):
            series.setdefault(row.series, []).append(row)
    methods = list(dict.fromkeys(r.method for r in study.rows))
    for label, rows in series.items():
        # in sweep order (coarse or loose to fine or tight), not sorted by time: timing noise then
        # shows as noise, not as a reordered curve
        m = methods.index(rows[0].method)
        color = colors[(2 * m) % 20 if m < 10 else (2 * m + 1) % 20]
        projected_scipy = rows[0].family == "scipy" and rows[0].projection
        style = ":" if rows[0].fallback else _FAMILY_STYLE.get(rows[0].family, "-")
        marker = "x" if rows[0].fallback else _MARKERS[m % len(_MARKERS)]
        x = np.array([1e3 * r.cpu_median for r in rows])
        y = np.array([r.error for r in rows])
        ok = np.array([r.resolved for r in rows])
        ax.loglog(
            x,
            np.where(ok, y, np.nan),
            style,
            marker=marker,
            ms=5,
            color=color,
            mfc="none" if projected_scipy else color,
            label=label,
        )
        if not ok.all():
            ax.loglog(x[~ok], np.full((~ok).sum(), limit), "v", ms=6, color=color, mfc="none")
    ax.axhline(ref.floor, color="k", lw=0.8, ls=(0, (1, 2)))
    ax.axhspan(ax.get_ylim()[0] if ax.get_ylim()[0] < ref.floor else ref.floor / 10, limit, color="0.9", zorder=0)
    ax.plot([], [], "v", color="0.3", mfc="none", label=f"error below {RESOLVED:g}× the reference floor (upper bound)")
    ax.plot([], [], color="k", lw=0.8, ls=(0, (1, 2)), label=f"reference floor {ref.floor:.1e}")
    ax.set_xlabel("CPU time per run [ms] (median of timed calls after a warm-up)")
    ax.set_ylabel(r"global error  $\max_t \|y(t) - y_{ref}(t)\| / \|y(0)\|$  (whole state)")
    meta = study.metadata.get("machine", {})
    ax.set_title(
        (title or f"{study.scene.name}: work–precision, T = {study.span:g}")
        + f"\nreference: {ref.kind}\n{meta.get('processor', '?')}, numba threads "
        f"{study.metadata.get('numba_threads')}, {study.metadata.get('sweep')} sweep",
        fontsize=9,
    )
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5), title="method [back end]", title_fontsize=8)
    fig.tight_layout()
    if path is None:
        return fig
    path = Path(path)
    fig.savefig(path, dpi=150)
    plt.close(fig)
    return path


def long_run_methods(scene) -> list[tuple[str, dict]]:
    """``(label, integrate keywords)`` of the long-run figure: the scene's method and RK4 at the
    scene's step, DOP853 at the scene's tolerance (its saved copies projected when the scene
    projects)."""
    from ..methods.registry import method_specs

    h = scene.step
    runs = []
    for name in dict.fromkeys((scene.method, "rk4")):
        spec = method_specs()[name]
        if spec.adaptive:
            runs.append((f"{name}, rtol {scene.rtol:g}", {"method": name, "rtol": scene.rtol, "atol": scene.atol}))
        else:
            runs.append((f"{name}, h = {h:g} (the scene's step)", {"method": name, "h": h}))
    if "scipy:DOP853" not in (scene.method, "rk4"):
        dop = {"method": "scipy:DOP853", "rtol": scene.rtol, "atol": scene.atol}
        runs.append((f"scipy:DOP853, rtol {scene.rtol:g}", dop))
    return runs


def plot_long_run(scene, path, factor: float = 10.0) -> Path:
    """Drift of the integral invariants over ``factor`` × the scene's span (see the module
    docstring); returns the path written."""
    from ..drift import deviation
    from ..groups.base import DexpinvRangeError
    from ..ivp import integrate
    from ..scenes import build_system

    plt = _pyplot()
    system, y0 = build_system(replace(scene, outputs=tuple(dict.fromkeys((*scene.outputs, "energy")))))
    span = (scene.t_start, scene.t_start + factor * (scene.t_end - scene.t_start))
    grid = np.linspace(*span, 501)
    names = [n for n, inv in system.invariants.items() if inv.kind == "integral"][:3]
    fig, axes = plt.subplots(1, len(names), figsize=(5.5 * len(names), 4.2), squeeze=False)
    for label, kwargs in long_run_methods(scene):
        if "h" in kwargs:
            nsteps = round((span[1] - span[0]) / kwargs["h"])
            extra = {"save_every": max(1, nsteps // 500)}
        elif kwargs["method"].startswith("scipy:"):
            extra = {"t_eval": grid}
        else:
            extra = {"save_every": 10}
        try:
            sol = integrate(system, y0, span, project=scene.project, **kwargs, **extra)
        except (DexpinvRangeError, np.linalg.LinAlgError) as exc:  # said in the legend, not hidden
            for ax in axes[0]:
                ax.plot([], [], label=f"{label} (raised: {str(exc)[:50]})")
            continue
        keep = sol.t > sol.t[0]
        for ax, name in zip(axes[0], names, strict=True):
            d = deviation(sol.invariants[name], sol.invariants[name][0], "integral", 0)
            shown = label if sol.success else f"{label} (failed: {sol.message[:40]})"
            ax.loglog(sol.t[keep] - sol.t[0], np.maximum(d[keep], 1e-17), label=shown)
    for ax, name in zip(axes[0], names, strict=True):
        ax.set_xlabel("t − t₀")
        ax.set_ylabel(f"relative {name} error  ‖I(t) − I(0)‖ / ‖I(0)‖")
        ax.set_title(f"{scene.name}: {name} over {factor:g}× the scene's span", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=150)
    plt.close(fig)
    return path
