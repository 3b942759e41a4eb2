"""Figures of a study, drawn to be read by a numerical analyst.

* :func:`plot_work_precision` — the overview: error over the whole state against the median
  CPU time, log–log, for about eight representative series (:data:`REPRESENTATIVE`: what a user
  compares first — the fixed-step workhorse RKMK4 and the high-order RKMK6, the adaptive 8(5)
  pair and its energy-keeping form, the order-8 modified Moser–Veselov method and a splitting
  for long runs, classical RK4 on the same compiled loops, and scipy's DOP853), so that the
  figure can be read at a glance;
* :func:`plot_work_precision_families` — one figure per method family (:data:`FAMILY_GROUPS`:
  fixed-step Lie-group methods, adaptive Lie-group pairs, long-time methods, classical RK and
  scipy's solvers) with every series of the study, on the same axes limits as each other, so
  that nothing of the table is left undrawn;
* :func:`plot_long_run` — the drift of the integral invariants against time over a multiple of
  the scene's span, for the scene's own method and classical RK4 *at the scene's step* and
  scipy's DOP853 at the scene's tolerance (stated in the legend).

Every series has a colour and a marker of its own (:func:`lieint._plotting.series_styles`);
the legend sits below the axes inside the figure, never clipped; a series whose err/rtol is far
above 1 is marked with the number of a note (:mod:`.notes`) printed under the legend. The
reference's floor is drawn and the band below ``RESOLVED × floor`` shaded; a point inside the
band is drawn as an upper bound (a ▽ at the band's edge), and a fallback to the generic path is
a series of its own, dotted with crosses.
"""

from __future__ import annotations

import math
import textwrap
from dataclasses import replace
from pathlib import Path

import numpy as np

from .._plotting import log_floor, pyplot, series_styles
from .notes import rtol_notes, series_note_numbers
from .reference import RESOLVED

__all__ = [
    "FAMILY_GROUPS",
    "REPRESENTATIVE",
    "long_run_invariants",
    "plot_long_run",
    "plot_work_precision",
    "plot_work_precision_families",
]

#: (file key, title, registry families) of the per-family figures; a family not listed gets a
#: figure of its own
FAMILY_GROUPS = (
    ("fixed_lie", "fixed-step Lie-group methods", ("rkmk", "cf", "cg", "magnus")),
    ("adaptive", "adaptive Lie-group pairs (plain and energy-keeping)", ("rkmk-embedded", "rkmk-energy")),
    ("long_time", "long-time methods", ("moser-veselov", "splitting", "midpoint", "exact", "symplectic")),
    ("classical", "classical RK and scipy's solvers", ("rk", "scipy")),
)
#: the overview's methods, in the order drawn (those the scene's system accepts)
REPRESENTATIVE = (
    "rkmk4", "rkmk6", "rkmk853", "rkmk853+energy", "moser_veselov8", "splitting4", "rk4", "scipy:DOP853",
)  # fmt: skip
#: series per figure: beyond this a family's figure is split (markers would repeat)
MAX_SERIES = 13
_LINE = {"rkmk-embedded": "--", "rkmk-energy": "--", "scipy": ":"}
_NOTE_WIDTH = 150  # characters per footnote line at 7 pt across the figure


def _series(rows) -> dict[str, list]:
    out: dict[str, list] = {}
    for row in rows:
        if row.success and np.isfinite(row.error):
            out.setdefault(row.series, []).append(row)
    return out


def _limits(study):
    """Axes limits that hold every point of the study (the family figures share them)."""
    rows = [r for r in study.rows if r.success and np.isfinite(r.error) and np.isfinite(r.cpu_median)]
    if not rows:
        return None
    x = np.array([1e3 * r.cpu_median for r in rows])
    y = np.array([max(r.error, RESOLVED * study.reference.floor) for r in rows])
    floor = study.reference.floor
    return (x.min() / 1.6, x.max() * 1.6), (min(y.min(), floor) / 10, y.max() * 10)


def _draw(study, rows, title: str, limits=None):
    """The figure of ``rows`` (a subset of the study's rows); returns it, open."""
    plt = pyplot()
    series = _series(rows)
    numbers = series_note_numbers(rtol_notes(study))
    notes = [n for n in rtol_notes(study) if any(label in series for label in n.series)]
    n_entries = len(series) + 2
    ncol = 2
    legend_rows = math.ceil(n_entries / ncol)
    note_lines = [
        line
        for note in notes
        for line in textwrap.wrap(f"[{note.number}] {note.text}", _NOTE_WIDTH, subsequent_indent="     ")
    ]
    plot_h, legend_h, notes_h = 5.0, 0.24 * legend_rows + 0.15, 0.17 * len(note_lines) + (0.1 if notes else 0)
    # constrained layout keeps the axes' labels clear of the legend's and the notes' rows below
    fig = plt.figure(figsize=(10.5, plot_h + legend_h + notes_h + 0.6), layout="constrained")
    grid = fig.add_gridspec(3, 1, height_ratios=[plot_h, legend_h, max(notes_h, 1e-3)])
    ax = fig.add_subplot(grid[0])
    ref = study.reference
    limit = RESOLVED * ref.floor
    styles = series_styles(len(series))
    for (label, srows), (color, marker) in zip(series.items(), styles, strict=True):
        # in sweep order (coarse or loose to fine or tight), not sorted by time: timing noise then
        # shows as noise, not as a reordered curve
        first = srows[0]
        style = ":" if first.fallback else _LINE.get(first.family, "-")
        shown_marker = "x" if first.fallback else marker
        hollow = first.family == "scipy" and first.projection
        x = np.array([1e3 * r.cpu_median for r in srows])
        y = np.array([r.error for r in srows])
        ok = np.array([r.resolved for r in srows])
        number = numbers.get(label)
        ax.loglog(
            x,
            np.where(ok, y, np.nan),
            style,
            marker=shown_marker,
            ms=6,
            color=color,
            mfc="white" if hollow else color,
            label=label + (f"  — note [{number}]" if number else ""),
        )
        if not ok.all():
            ax.loglog(x[~ok], np.full((~ok).sum(), limit), "v", ms=7, color=color, mfc="none")
    if limits is not None:
        ax.set_xlim(*limits[0])
        ax.set_ylim(*limits[1])
    ax.axhline(ref.floor, color="k", lw=0.8, ls=(0, (1, 2)))
    bottom = ax.get_ylim()[0]
    ax.axhspan(min(bottom, ref.floor / 10), limit, color="0.92", zorder=0)
    ax.plot([], [], "v", color="0.3", mfc="none", label=f"error below {RESOLVED:g}× the reference floor (upper bound)")
    ax.plot([], [], color="k", lw=0.8, ls=(0, (1, 2)), label=f"reference floor {ref.floor:.1e}")
    ax.set_xlabel("CPU time per run [ms] (median of the timed calls after a warm-up)")
    ax.set_ylabel(r"global error  $\max_t \|y(t) - y_{ref}(t)\| / \|y(0)\|$")
    meta = study.metadata.get("machine", {})
    ax.set_title(
        f"{study.scene.name}: {title}, T = {study.span:g}\nreference: {ref.kind}; "
        f"{meta.get('processor', '?')}, numba threads {study.metadata.get('numba_threads')}, "
        f"{study.metadata.get('sweep')} sweep",
        fontsize=9,
    )
    ax.grid(True, which="both", alpha=0.3)
    lax = fig.add_subplot(grid[1])
    lax.axis("off")
    handles, labels = ax.get_legend_handles_labels()
    lax.legend(handles, labels, loc="upper center", ncol=ncol, fontsize=8, frameon=False, title="method [back end]",
               title_fontsize=8)  # fmt: skip
    nax = fig.add_subplot(grid[2])
    nax.axis("off")
    if note_lines:
        nax.text(0.0, 1.0, "\n".join(note_lines), transform=nax.transAxes, va="top", ha="left", fontsize=7)
    return fig


def _save(fig, path) -> Path:
    plt = pyplot()
    path = Path(path)
    try:
        fig.savefig(path, dpi=150)
    finally:
        plt.close(fig)
    return path


def representative_rows(study) -> list:
    """The rows of the overview: the :data:`REPRESENTATIVE` methods the study has (scipy's in the
    variant that matches the scene's ``project`` flag), in that order; a study that has fewer than
    four of them shows the first series of each family instead."""
    wanted = [m for m in REPRESENTATIVE if any(r.method == m for r in study.rows)]
    if len(wanted) < 4:
        wanted = list(dict.fromkeys(r.method for r in study.rows))
        seen, picked = set(), []
        for m in wanted:
            fam = next(r.family for r in study.rows if r.method == m)
            if fam not in seen:
                seen.add(fam)
                picked.append(m)
        wanted = picked[:8]
    project = bool(study.scene.project)
    rows = []
    for m in wanted:
        for r in study.rows:
            if r.method == m and (r.family != "scipy" or r.projection == project):
                rows.append(r)
    return rows


def plot_work_precision(study, path=None, title: str | None = None):
    """Draw the overview figure of ``study`` (the representative series) into ``path`` (PNG or SVG
    by its suffix) and return the path; without ``path``, return the matplotlib figure (left
    open)."""
    fig = _draw(study, representative_rows(study), title or "work–precision (representative methods)")
    return fig if path is None else _save(fig, path)


def family_groups(study) -> list[tuple[str, str, list]]:
    """``(file key, title, rows)`` of each family figure with at least one row (split into parts of
    at most :data:`MAX_SERIES` series)."""
    known = {fam: (key, title) for key, title, fams in FAMILY_GROUPS for fam in fams}
    groups: dict[str, tuple[str, list]] = {}
    for row in study.rows:
        key, title = known.get(row.family, (row.family.replace("-", "_"), f"{row.family} methods"))
        groups.setdefault(key, (title, []))[1].append(row)
    order = [key for key, _, _ in FAMILY_GROUPS]
    out = []
    for key in sorted(groups, key=lambda k: (order.index(k) if k in order else len(order), k)):
        title, rows = groups[key]
        labels = list(dict.fromkeys(r.series for r in rows))
        parts = [labels[i : i + MAX_SERIES] for i in range(0, len(labels), MAX_SERIES)]
        for i, part in enumerate(parts):
            suffix = f"_{i + 1}" if len(parts) > 1 else ""
            out.append((key + suffix, title, [r for r in rows if r.series in part]))
    return out


def plot_work_precision_families(study, out_dir) -> list[Path]:
    """Write ``work_precision_<family>.png`` for each family group into ``out_dir`` (see the
    module docstring); returns the paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    limits = _limits(study)
    return [
        _save(_draw(study, rows, title, limits), out_dir / f"work_precision_{key}.png")
        for key, title, rows in family_groups(study)
    ]


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


def long_run_invariants(system, limit: int = 3) -> list[str]:
    """The integral invariants the long-run figure draws, at most ``limit``: the system's own
    order, leaving out what is not a further integral of this body — the Manakov integrals of a 3D
    top are functions of its energy and Casimir."""
    names = [n for n, inv in system.invariants.items() if inv.kind == "integral"]
    if getattr(system, "n", None) == 3:
        names = [n for n in names if n != "manakov"]
    return names[:limit]


#: drifts below this are drawn at it on the log axes, with a marker saying so
DRIFT_FLOOR = 1e-17


def plot_long_run(scene, path, factor: float = 10.0) -> Path:
    """Drift of the integral invariants over ``factor`` × the scene's span (see the module
    docstring); returns the path written."""
    from ..drift import deviation
    from ..groups.base import DexpinvRangeError
    from ..ivp import integrate
    from ..scenes import build_system

    plt = pyplot()
    system, y0 = build_system(replace(scene, outputs=tuple(dict.fromkeys((*scene.outputs, "energy")))))
    span = (scene.t_start, scene.t_start + factor * (scene.t_end - scene.t_start))
    grid = np.linspace(*span, 501)
    names = long_run_invariants(system)
    fig, axes = plt.subplots(1, len(names), figsize=(5.5 * len(names), 4.6), squeeze=False)
    runs = long_run_methods(scene)
    any_clamped = False
    for (label, kwargs), (color, _) in zip(runs, series_styles(len(runs)), strict=True):
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
                ax.plot([], [], color=color, label=f"{label} (raised: {str(exc)[:50]})")
            continue
        keep = sol.t > sol.t[0]
        for ax, name in zip(axes[0], names, strict=True):
            d = deviation(sol.invariants[name], sol.invariants[name][0], "integral", 0)
            shown_label = label if sol.success else f"{label} (failed: {sol.message[:40]})"
            shown, clamped = log_floor(d[keep], DRIFT_FLOOR)
            t = sol.t[keep] - sol.t[0]
            ax.loglog(t, shown, color=color, lw=1.0, label=shown_label)
            if clamped.any():
                any_clamped = True
                ax.loglog(t[clamped], shown[clamped], "v", ms=3, color=color, mfc="none", ls="none")
    for ax, name in zip(axes[0], names, strict=True):
        if any_clamped:
            ax.plot([], [], "v", ms=3, color="0.3", mfc="none", ls="none",
                    label=f"below {DRIFT_FLOOR:g} (exact zeros included), drawn at {DRIFT_FLOOR:g}")  # fmt: skip
        ax.set_xlabel("t − t₀")
        ax.set_ylabel(f"relative {name} error  ‖I(t) − I(0)‖ / ‖I(0)‖")
        ax.set_title(f"{scene.name}: {name} over {factor:g}× the scene's span", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 4), fontsize=8, frameon=False)
    fig.set_layout_engine("constrained")
    path = Path(path)
    fig.savefig(path, dpi=150)
    plt.close(fig)
    return path
