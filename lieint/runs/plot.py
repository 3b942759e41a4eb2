"""``lieint plot RUN.h5``: the figures users look at after a long run.

1. Each saved invariant's drift against time on log axes (relative to its first value;
   defects such as ``orthogonality`` as they are); for an ensemble the median over members
   with the 10–90 % band.
2. The motion: the contact path on the plane for a ball, else the body's first axis ``R e₁``
   in space (the Dzhanibekov flips show as jumps of its components).
3. For an ensemble, the spread: how far each member's orientation (angle of ``R_i R₀ᵀ``) or
   contact point is from the first member's, median and 10–90 % band.

Long files are read with a stride (at most ~4000 rows), so plotting stays light.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..text import printable

__all__ = ["PlotError", "plot_run"]

_MAX_POINTS = 4000


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
        series = read_series(path, _MAX_POINTS, timeout=max(0.0, deadline - time.monotonic()), header=header)
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


def _band(ax, t, series, label):
    """Median and 10–90 % band of ``series`` (m, members)."""
    if series.shape[1] == 1:
        ax.plot(t, series[:, 0], label=label)
        return
    lo, med, hi = np.nanpercentile(series, [10, 50, 90], axis=1)
    line = ax.plot(t, med, label=f"{label} (median)")[0]
    ax.fill_between(t, lo, hi, color=line.get_color(), alpha=0.25)


def plot_run(path, out=None, timeout: float = 20.0) -> Path:
    """Draw the figure of a streamed run; returns the figure's path (PNG or SVG by suffix).

    The file is read within ``timeout`` seconds (all stages together); a file that cannot be
    read in that time gives :class:`PlotError` saying so (never a wait without end)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    if not os.path.lexists(path):
        raise PlotError(f"no run file {str(path)!r}")
    out = Path(out) if out else path.with_suffix(".png")
    if out.suffix.lower() not in (".png", ".svg"):
        raise PlotError(f"the figure must be .png or .svg; got {out.name!r}")
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
    fig, axes = plt.subplots(1, ncols, figsize=(5.2 * ncols, 4.2))
    title = f"{attrs.get('scene_name', path.stem)} — {attrs.get('method', '')}, h = {attrs.get('h', '')}"
    if attrs.get("status") != "complete":
        title += f" [{attrs.get('status')}]"
    fig.suptitle(printable(title))  # the file's text, escaped: a name may hold control characters

    ax = axes[0]
    tt = t - t[0]
    keep = tt > 0
    for name, values in inv.items():
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
        _band(ax, tt[keep], np.maximum(d[keep], 1e-17), name)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("t − t₀")
    ax.set_ylabel("relative drift |I(t) − I(0)| / |I(0)|  (defects: size)")
    ax.set_title("invariants")
    if inv:
        ax.legend(fontsize=8)

    ax = axes[1]
    # the motion: a path of points where the run saved one (contact path, centre), else the
    # orientation, else the first state field
    points = [(g, k) for (g, k), m in meta.items() if m.get("kind") == "point" and g in ("outputs", "states")]
    points.sort(key=lambda gk: (gk[1] != "contact_path", gk[0] != "outputs"))
    path_xy = (outputs if points[0][0] == "outputs" else states)[points[0][1]] if points else None
    if path_xy is None:
        path_xy = outputs.get("contact_path", states.get("center"))
    if path_xy is not None:
        p = _members(path_xy, 1)
        for i in range(min(p.shape[1], 5)):
            ax.plot(p[:, i, 0], p[:, i, 1], lw=1)
        ax.set_xlabel("x")
        ax.set_ylabel("y")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title((points[0][1] if points else "centre").replace("_", " "))
    elif "R" in states:
        R = _members(states["R"], 2)
        for c in range(min(3, R.shape[-1])):
            ax.plot(t, R[:, 0, c, 0], label=f"(R e₁)_{c + 1}")
        ax.set_xlabel("t")
        ax.set_title("orientation: body axis e₁ in space" + (" (member 0)" if ensemble else ""))
        ax.legend(fontsize=8)
    else:
        A = _members(states[first], tail("states", first, states[first]))
        ax.plot(t, A[:, 0].reshape(len(t), -1))
        ax.set_xlabel("t")
        ax.set_title(f"{first} (no orientation saved)")

    if ensemble:
        ax = axes[2]
        if "R" in states:
            R = _members(states["R"], 2)
            rel = np.einsum("tmij,tkj->tmik", R, R[:, 0])  # R_i R_0ᵀ
            cos = np.clip((np.trace(rel, axis1=-2, axis2=-1) - (R.shape[-1] - 2)) / 2, -1, 1)
            _band(ax, t, np.arccos(cos), "angle to member 0")
            ax.set_ylabel("rad")
        elif path_xy is not None:
            p = _members(path_xy, 1)
            _band(ax, t, np.linalg.norm(p - p[:, :1], axis=-1), "distance to member 0")
        ax.set_xlabel("t")
        ax.set_title(f"ensemble spread ({members} members)")
        ax.legend(fontsize=8)
    fig.tight_layout()
    try:
        fig.savefig(out, dpi=110)
    except OSError as exc:
        raise PlotError(f"cannot write the figure {str(out)!r}: {exc}") from None
    finally:
        plt.close(fig)
    return out
