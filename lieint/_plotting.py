"""Small drawing functions shared by the figures of ``lieint compare`` and ``lieint plot``.

* :func:`series_styles` — a colour and a marker for each of n series, no two alike;
* :func:`envelope` — thin a long series to a min/max envelope a figure can show;
* :func:`log_floor` — values for a log axis, with the ones clamped to a floor marked;
* :func:`pyplot` — matplotlib's pyplot on the non-interactive Agg back end.

Nothing here imports matplotlib at import time (``import lieint`` stays light).
"""

from __future__ import annotations

import numpy as np

__all__ = ["MARKERS", "PALETTE", "envelope", "log_floor", "pyplot", "series_styles"]

#: 20 colours: matplotlib's tab10, then tab20's lighter partner of each
PALETTE = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
    "#aec7e8", "#ffbb78", "#98df8a", "#ff9896", "#c5b0d5", "#c49c94", "#f7b6d2", "#c7c7c7", "#dbdb8d", "#9edae5",
)  # fmt: skip
#: 13 marker shapes ("v" and "x" are kept for upper bounds and fallbacks)
MARKERS = ("o", "s", "D", "^", "<", ">", "p", "h", "P", "X", "*", "d", "8")


def series_styles(n: int) -> list[tuple[str, str]]:
    """``(colour, marker)`` for ``n`` series: every colour and every marker differ while
    ``n ≤ 13`` (then markers repeat; colours differ up to 20)."""
    if n < 0:
        raise ValueError(f"`n` must be a non-negative number of series; got {n!r}.")
    return [(PALETTE[i % len(PALETTE)], MARKERS[i % len(MARKERS)]) for i in range(n)]


def envelope(x: np.ndarray, y: np.ndarray, bins: int = 600, log: bool = False):
    """Thin ``y(x)`` to at most ``bins`` bins of consecutive rows: ``(x_mid, lo, hi, thinned)``.

    The bins are equal in x, or in log x when ``log`` is True (for a logarithmic x axis; x must
    then be positive and increasing).

    ``lo`` and ``hi`` are the minimum and maximum of each bin (NaNs ignored; a bin of NaNs stays
    NaN), so the envelope contains every value — a fast oscillation shows as a band of its true
    amplitude instead of as an aliased stride sample. ``x_mid`` is the bin's middle row's x.
    With no more than ``2 * bins`` rows nothing is thinned: ``lo = hi = y`` and ``thinned`` is
    False.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.shape[0] != y.shape[0]:
        raise ValueError(f"`x` and `y` need the same number of rows; got {x.shape[0]} and {y.shape[0]}.")
    if bins < 1:
        raise ValueError(f"`bins` must be a positive integer; got {bins!r}.")
    m = x.shape[0]
    if m <= 2 * bins:
        return x, y, y, False
    if log:
        if not (x[0] > 0 and np.all(np.diff(x) >= 0)):
            raise ValueError("`log=True` needs positive, increasing `x`.")
        edges = np.unique(np.searchsorted(x, np.geomspace(x[0], x[-1], bins + 1)[:-1]))
        edges = np.append(edges, m)
    else:
        edges = np.linspace(0, m, bins + 1).astype(int)  # strictly increasing: m > 2 bins
    lo = np.fmin.reduceat(y, edges[:-1], axis=0)  # fmin/fmax skip NaNs
    hi = np.fmax.reduceat(y, edges[:-1], axis=0)
    mid = x[(edges[:-1] + edges[1:] - 1) // 2]
    return mid, lo, hi, True


def log_floor(values: np.ndarray, floor: float):
    """``(shown, clamped)``: ``values`` raised to ``floor`` for a log axis, and the mask of the
    entries that were below it (exact zeros included) — draw those so that the figure says so."""
    values = np.asarray(values, dtype=float)
    clamped = np.isfinite(values) & (values < floor)
    return np.where(clamped, floor, values), clamped


def pyplot():
    """``matplotlib.pyplot`` on the Agg back end (figures are written to files)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
