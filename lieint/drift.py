"""The one definition of an invariant's drift, per ensemble member.

* An **integral** I (constant along the exact flow): ``max_t ‖I(t) − I(0)‖ / ‖I(0)‖``, the norm
  taken over the invariant's own axes (a vector or matrix invariant is compared as a whole),
  absolute where ``I(0) = 0``.
* A **defect** D (zero along the exact flow, e.g. ``‖RᵀR − I‖``): ``max_t ‖D(t)‖``.

:meth:`lieint.Solution.drift`, the monitors of streamed runs (``--max-drift``), the plots and the
study all use these functions, so one run reports one number everywhere. A streamed run feeds
its rows in chunks to a :class:`DriftMonitor`, which gives exactly what :func:`drift` gives on
all the rows at once.
"""

from __future__ import annotations

import numpy as np

__all__ = ["DriftMonitor", "deviation", "drift"]


def _norm(values: np.ndarray, lead: int) -> np.ndarray:
    """Euclidean norm over the axes after the first ``lead`` ones."""
    axes = tuple(range(lead, values.ndim))
    return np.sqrt(np.sum(values * values, axis=axes)) if axes else np.abs(values)


def deviation(values: np.ndarray, initial: np.ndarray, kind: str, batch_ndim: int) -> np.ndarray:
    """Per saved row and member: the relative deviation of an integral, or the size of a defect.

    Parameters
    ----------
    values : ndarray, shape (m, *batch, *shape)
        The invariant at m saved times.
    initial : ndarray, shape (*batch, *shape)
        Its value at the initial time (ignored for defects).
    kind : {"integral", "defect"}
    batch_ndim : int
        Number of batch axes.

    Returns
    -------
    ndarray, shape (m, *batch)
    """
    lead = 1 + batch_ndim
    if kind == "defect":
        return _norm(values, lead)
    err = _norm(values - initial[None], lead)
    ref = _norm(initial, batch_ndim)
    return np.where(ref > 0, err / np.where(ref > 0, ref, 1.0), err)


def drift(values: np.ndarray, kind: str, batch_ndim: int) -> np.ndarray | float:
    """The drift of an invariant saved at m times (first row: the initial value), per member.

    Returns a float for one body (``batch_ndim == 0``), else an array of the batch shape.
    """
    values = np.asarray(values, dtype=float)
    d = np.max(deviation(values, values[0], kind, batch_ndim), axis=0)
    return float(d) if batch_ndim == 0 else d


class DriftMonitor:
    """Running per-member maxima of :func:`deviation` over rows fed in chunks.

    Parameters
    ----------
    kinds : dict
        name → "integral" or "defect".
    initial : dict
        name → the invariant's initial value ``(*batch, *shape)``.
    batch_ndim : int
    """

    def __init__(self, kinds: dict[str, str], initial: dict[str, np.ndarray], batch_ndim: int):
        self.kinds, self.initial, self.batch_ndim = dict(kinds), dict(initial), batch_ndim
        self.worst = {name: np.zeros(np.shape(v)[:batch_ndim]) for name, v in self.initial.items()}

    def update(self, rows: dict[str, np.ndarray]) -> None:
        """Fold the rows ``(m, *batch, *shape)`` of each invariant into the maxima."""
        for name, kind in self.kinds.items():
            v = rows.get(name)
            if v is None or v.shape[0] == 0:
                continue
            d = np.max(deviation(v, self.initial[name], kind, self.batch_ndim), axis=0)
            # NaN propagates: a member that blew up shows as NaN, never as 0
            self.worst[name] = np.where(np.isnan(d) | (d > self.worst[name]), d, self.worst[name])

    def largest(self) -> dict[str, float]:
        """The largest drift over members, per invariant (NaN if any member is NaN)."""
        return {name: float(np.max(w)) if np.size(w) else 0.0 for name, w in self.worst.items()}
