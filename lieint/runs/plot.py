"""``lieint plot RUN.h5``: the figures users look at after a long run.

1. Each saved invariant's drift against time on log axes (relative to its first value;
   defects such as ``orthogonality`` as they are); for an ensemble the median over members
   with the 10–90 % band. Values below ``DRIFT_FLOOR`` (exact zeros included) are drawn at the
   floor with a ▽, and the legend says so.
2. The motion: the contact path on the plane for a ball, else every component of the body's
   first axis ``R e₁`` in space (the Dzhanibekov flips show as jumps of its components; above
   ``MAX_COMPONENTS`` dimensions the first ones, named in the title).
3. For an ensemble, the spread: how far each member's orientation (angle of ``R_i R₀ᵀ``) or
   contact point is from the first member's, median and 10–90 % band.

Long files are read with a stride down to at most ``READ_ROWS`` rows, and every time series is
then thinned to ``BINS`` bins drawn as their min/max envelope (:func:`lieint._plotting.envelope`):
an oscillation faster than a pixel shows as a band of its true amplitude, not as an aliased
line, and the title says how many rows each bin holds.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..text import printable

__all__ = ["BINS", "DRIFT_FLOOR", "MAX_COMPONENTS", "READ_ROWS", "PlotError", "plot_run", "run_figure"]

#: rows read from the file at most (a stride beyond; 40,001 rows are read whole)
READ_ROWS = 200_000
#: bins of the min/max envelope each time series is drawn with
BINS = 600
#: drifts below this are drawn at it (log axes)
DRIFT_FLOOR = 1e-17
#: components of R e₁ drawn at most
MAX_COMPONENTS = 8


class PlotError(ValueError):
    """A file that cannot be plotted (missing, corrupt, or not a lieint run)."""


def _read(path: Path, timeout: float):
    """The strided series and attributes, read safely (:mod:`lieint.runs.reading`: a truncated or
    damaged file is reported within seconds, never waited for), all within ``timeout`` s."""
    import time

    from .reading import IsolatedError, read_header, read_series

    deadline = time.monotonic() + timeout
    header = read_header(path, timeout=timeout)
    if header.timed_out:
        raise PlotError(f"could not read {str(path)!r} within the deadline of {timeout:g} s; pass a longer --timeout")
    if not header.ok:
        raise PlotError(f"cannot open {str(path)!r} as an HDF5 run file: {header.problem}")
    if "t" not in header.datasets or not any(n.startswith("states/") for n in header.datasets):
        raise PlotError(f"{str(path)!r} is not a lieint run (no /t and /states)")
    try:
        series = read_series(path, READ_ROWS, timeout=max(0.0, deadline - time.monotonic()), header=header)
    except IsolatedError as exc:
        if exc.timed_out:
            raise PlotError(
                f"could not read the rows of {str(path)!r} within the deadline of {timeout:g} s (a busy machine or a "
                "large file); pass a longer --timeout"
            ) from None
        raise PlotError(
            f"cannot read the rows of {str(path)!r}: {exc} (`lieint info {path}` says where it is damaged)"
        ) from None

    def group(name):
        prefix = name + "/"
        return {k[len(prefix) :]: v for k, v in series.items() if k.startswith(prefix)}

    attrs = dict(header.attrs)
    # what each dataset is (written by the run from the system's declarations)
    attrs["_datasets"] = {tuple(k.split("/", 1)): d["attrs"] for k, d in header.datasets.items() if "/" in k}
    return series["t"], group("states"), group("invariants"), group("outputs"), attrs


def _members(values: np.ndarray, tail: int) -> np.ndarray:
    """Reshape ``(m, *batch, *tail)`` to ``(m, members, *tail)``."""
    m = values.shape[0]
    return values.reshape((m, -1) + values.shape[values.ndim - tail :])


def _line(ax, t, y, label, color, log_floor=None):
    """Draw ``y(t)``: as a line, or thinned to its min/max envelope when it has many rows (bins
    equal in log t where ``log_floor`` is given: those axes are log–log). Returns
    ``(colour, thinned, clamped)``."""
    from .._plotting import envelope
    from .._plotting import log_floor as floor_of

    clamped = False
    if log_floor is not None:
        y, mask = floor_of(y, log_floor)
        clamped = bool(mask.any())
    x, lo, hi, thinned = envelope(t, y, BINS, log=log_floor is not None)
    if thinned:
        ax.fill_between(x, lo, hi, color=color, alpha=0.6, lw=0.5, label=label)
    else:
        color = ax.plot(x, y, lw=1.0, color=color, label=label)[0].get_color()
    if clamped:
        xs, ys = (x, lo) if thinned else (x, y)
        at = np.isclose(ys, log_floor)
        ax.plot(xs[at], ys[at], "v", ms=3, color=color, mfc="none", ls="none")
    return color, thinned, clamped


def _band(ax, t, series, label, color, log_floor=None):
    """Median and 10–90 % band of ``series`` (m, members); one member: its line."""
    if series.shape[1] == 1:
        return _line(ax, t, series[:, 0], label, color, log_floor=log_floor)
    from .._plotting import envelope

    lo, med, hi = np.nanpercentile(series, [10, 50, 90], axis=1)
    band_clamped = False
    if log_floor is not None:
        band_clamped = bool(np.any(lo < log_floor))  # the band's edge drawn at the floor: said too
        lo, hi = np.maximum(lo, log_floor), np.maximum(hi, log_floor)
    color, thinned, clamped = _line(ax, t, med, f"{label} (median)", color, log_floor=log_floor)
    clamped = clamped or band_clamped
    x, band_lo, _, _ = envelope(t, lo, BINS, log=log_floor is not None)
    _, _, band_hi, _ = envelope(t, hi, BINS, log=log_floor is not None)
    ax.fill_between(x, band_lo, band_hi, color=color, alpha=0.2, lw=0)
    return color, thinned, clamped


def plot_run(path, out=None, timeout: float = 20.0) -> Path:
    """Draw the figure of a streamed run; returns the figure's path (PNG or SVG by suffix).

    The file is read within ``timeout`` seconds (all stages together); a file that cannot be
    read in that time gives :class:`PlotError` saying so (never a wait without end)."""
    from .._plotting import pyplot

    path = Path(path)
    if not os.path.lexists(path):
        raise PlotError(f"no run file {str(path)!r}")
    out = Path(out) if out else path.with_suffix(".png")
    if out.suffix.lower() not in (".png", ".svg"):
        raise PlotError(f"the figure must be .png or .svg; got {out.name!r}")
    fig = run_figure(path, timeout)
    plt = pyplot()
    try:
        fig.savefig(out, dpi=110)
    except OSError as exc:
        raise PlotError(f"cannot write the figure {str(out)!r}: {exc}") from None
    finally:
        plt.close(fig)
    return out


def run_figure(path, timeout: float = 20.0):
    """The figure of a streamed run (a matplotlib ``Figure``, left open); see the module docstring."""
    from .._plotting import PALETTE, pyplot

    plt = pyplot()
    path = Path(path)
    if not os.path.lexists(path):
        raise PlotError(f"no run file {str(path)!r}")
    t, states, inv, outputs, attrs = _read(path, timeout)
    if t.size < 2:
        raise PlotError(
            f"{str(path)!r} holds {t.size} saved row(s); a plot needs at least two (run longer, or lower save_every)"
        )
    # invariants that measure a defect (zero for the exact flow), as the run recorded them
    defects = set(filter(None, str(attrs.get("defects", "")).split(",")))
    meta = attrs["_datasets"]
    batch_ndim = int(attrs.get("batch_ndim", 0))
    first = next(iter(states))

    def tail(group: str, name: str, values: np.ndarray) -> int:
        """Axes of one body's value: recorded by the run, else what is left after time and batch."""
        recorded = meta.get((group, name), {}).get("trailing_ndim")
        return int(recorded) if recorded is not None else values.ndim - 1 - batch_ndim

    members = _members(states[first], tail("states", first, states[first])).shape[1]
    ensemble = members > 1
    ncols = 3 if ensemble else 2
    fig = plt.figure(figsize=(5.6 * ncols, 4.8), layout="constrained")
    grid = fig.add_gridspec(1, ncols)
    axes = [fig.add_subplot(grid[0])]
    title = f"{attrs.get('scene_name', path.stem)} — {attrs.get('method', '')}, h = {attrs.get('h', '')}"
    if attrs.get("status") != "complete":
        title += f" [{attrs.get('status')}]"
    rows_per_bin = t.size / BINS
    if t.size > 2 * BINS:
        title += f"\n{t.size:,} saved rows drawn as the min/max envelope of {BINS} bins (~{rows_per_bin:.0f} rows each)"
    fig.suptitle(printable(title), fontsize=10)  # the file's text, escaped: a name may hold control characters

    ax = axes[0]
    tt = t - t[0]
    keep = tt > 0
    clamped_any = False
    for i, (name, values) in enumerate(inv.items()):
        v = _members(values, values.ndim - 1 - batch_ndim)
        axes_extra = tuple(range(2, v.ndim))
        if name in defects:
            d = np.sqrt(np.sum(v * v, axis=axes_extra)) if axes_extra else np.abs(v)
        else:
            ref = v[:1]
            scale = np.sqrt(np.sum(ref * ref, axis=axes_extra)) if axes_extra else np.abs(ref)
            diff = v - ref
            d = np.sqrt(np.sum(diff * diff, axis=axes_extra)) if axes_extra else np.abs(diff)
            d = d / np.where(scale > 0, scale, 1.0)
        clamped_any |= _band(ax, tt[keep], d[keep], name, PALETTE[i % len(PALETTE)], log_floor=DRIFT_FLOOR)[2]
    if clamped_any:
        ax.plot([], [], "v", ms=3, color="0.3", mfc="none", ls="none",
                label=f"below {DRIFT_FLOOR:g} (exact zeros too), drawn at {DRIFT_FLOOR:g}")  # fmt: skip
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("t − t₀")
    ax.set_ylabel("relative drift |I(t) − I(0)| / |I(0)|  (defects: size)")
    ax.set_title("invariants")
    if inv:
        ax.legend(fontsize=8)

    # the motion: a path of points where the run saved one (contact path, centre), else the
    # orientation, else the first state field
    points = [(g, k) for (g, k), m in meta.items() if m.get("kind") == "point" and g in ("outputs", "states")]
    points.sort(key=lambda gk: (gk[1] != "contact_path", gk[0] != "outputs"))
    path_xy = (outputs if points[0][0] == "outputs" else states)[points[0][1]] if points else None
    if path_xy is None:
        path_xy = outputs.get("contact_path", states.get("center"))
    if path_xy is not None:
        ax = fig.add_subplot(grid[1])
        p = _members(path_xy, 1)
        for i in range(min(p.shape[1], 5)):
            ax.plot(p[:, i, 0], p[:, i, 1], lw=1)
        ax.set_xlabel("x")
        ax.set_ylabel("y")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title((points[0][1] if points else "centre").replace("_", " ") + " (first two coordinates)")
    elif "R" in states:
        R = _members(states["R"], 2)
        n = R.shape[-1]
        shown = min(n, MAX_COMPONENTS)
        # one strip per component (overlaid envelopes of fast oscillations would hide each other)
        strips = grid[1].subgridspec(shown, 1, hspace=0.0)
        top = None
        for c in range(shown):
            ax = fig.add_subplot(strips[c], sharex=top)
            top = top or ax
            _line(ax, t, R[:, 0, c, 0], None, PALETTE[c])
            ax.set_ylim(-1.08, 1.08)
            ax.set_yticks([-1, 0, 1])
            ax.set_ylabel(f"(R e₁)_{c + 1}", fontsize=8)
            ax.tick_params(labelsize=7, labelbottom=c == shown - 1)
        what = "every component" if shown == n else f"components 1–{shown} of {n}"
        top.set_title(f"body axis e₁ in space, {what}" + (" (member 0)" if ensemble else ""), fontsize=9)
        ax.set_xlabel("t")
    else:
        ax = fig.add_subplot(grid[1])
        A = _members(states[first], tail("states", first, states[first]))
        flat = A[:, 0].reshape(len(t), -1)
        for c in range(min(flat.shape[1], MAX_COMPONENTS)):
            _line(ax, t, flat[:, c], None, PALETTE[c])
        ax.set_xlabel("t")
        ax.set_title(f"{first} (no orientation saved; first {min(flat.shape[1], MAX_COMPONENTS)} entries)", fontsize=9)

    if ensemble:
        ax = fig.add_subplot(grid[2])
        if "R" in states:
            R = _members(states["R"], 2)
            rel = np.einsum("tmij,tkj->tmik", R, R[:, 0])  # R_i R_0ᵀ
            cos = np.clip((np.trace(rel, axis1=-2, axis2=-1) - (R.shape[-1] - 2)) / 2, -1, 1)
            _band(ax, t, np.arccos(cos), "angle to member 0", PALETTE[0])
            ax.set_ylabel("rad")
        elif path_xy is not None:
            p = _members(path_xy, 1)
            _band(ax, t, np.linalg.norm(p - p[:, :1], axis=-1), "distance to member 0", PALETTE[0])
        ax.set_xlabel("t")
        ax.set_title(f"ensemble spread ({members} members)")
        ax.legend(fontsize=8)
    return fig
