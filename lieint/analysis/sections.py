"""Poincaré sections on the group: the crossings of a surface ``g(t, y) = 0`` by a run.

The run is :func:`lieint.integrate` with ``g`` as a non-terminal event (Brent's method on each
step's interpolant on the group, :mod:`lieint.events`, to ``1e-12`` in time); each crossing is
then refined by the secant method on the same interpolant until the time stops changing
(``|Δt| ≤ 4ε·|t|``): the section point is the dense output at a root of ``g`` to round-off, and
lies on the group with it (R orthogonal, the state moved by the group action). A regular
(quasi-periodic) motion draws curves in the section, a chaotic one scatters points (Hénon 1982).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..ivp import integrate
from ..methods.base import Method
from ..systems.base import LieGroupSystem

__all__ = ["PoincareSection", "poincare"]

_EPS = np.finfo(float).eps
_SECANT_ITERATIONS = 20


@dataclass(frozen=True)
class PoincareSection:
    """The crossings of a section by a run.

    Attributes
    ----------
    t : ndarray, shape (k,)
        Crossing times.
    y : dict of ndarray
        The states at the crossings, ``(k, ...)`` per field.
    residual : ndarray, shape (k,)
        ``g(t, y)`` at each crossing (round-off of g's scale).
    solution : Solution
        The run (with its dense output).
    """

    t: np.ndarray
    y: dict
    residual: np.ndarray
    solution: object = field(repr=False)

    def __len__(self) -> int:
        return int(self.t.size)


def poincare(
    system: LieGroupSystem,
    y0: Mapping[str, ArrayLike],
    t_span: tuple[float, float],
    section: Callable[[float, dict], float],
    h: float | None = None,
    method: str | Method = "rkmk4",
    *,
    direction: float = 1.0,
    **options: Any,
) -> PoincareSection:
    """The crossings of the surface ``section(t, y) = 0`` by a run, located to round-off.

    Parameters
    ----------
    system : LieGroupSystem
        The system (one body: events need a single state).
    y0 : dict of array_like
        The initial state.
    t_span : tuple of float
        ``(t0, t1)``.
    section : callable
        ``g(t, y) -> float``, the surface ``g = 0`` (e.g. ``lambda t, y: y["A"][0, 1]``).
    h : float, optional
        The step (fixed-step methods; adaptive ones take ``rtol``/``atol`` in ``options``).
    method : str or Method, default "rkmk4"
        Any method :func:`lieint.integrate` takes.
    direction : float, default 1.0
        > 0: crossings where g increases; < 0: where it decreases; 0: both.
    **options
        Further keywords of :func:`lieint.integrate` (``coordinates``, ``rtol``, ``atol``, …).

    Returns
    -------
    PoincareSection
        The crossing times and states, their residuals and the run.

    Raises
    ------
    TypeError, ValueError
        ``section`` not callable, ``direction`` not a number, or what :func:`lieint.integrate`
        refuses.

    Examples
    --------
    >>> import lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0], orientation=False)
    >>> y0 = top.initial_state(angular_velocity=[1.0, 0.3, 0.2])
    >>> cut = lieint.poincare(top, y0, (0.0, 50.0), lambda t, y: y["A"][0, 1], h=0.01)
    >>> len(cut) > 3, bool(abs(cut.residual).max() < 1e-14)
    (True, True)
    """
    if not callable(section):
        raise TypeError(f"`section` must be a function g(t, y) -> float; got {type(section).__name__}.")
    if isinstance(direction, bool) or not isinstance(direction, (int, float, np.integer, np.floating)):
        raise TypeError(f"`direction` must be a number (> 0, < 0 or 0); got {direction!r}.")
    for reserved in ("events", "dense_output"):
        if reserved in options:
            raise ValueError(f"`{reserved}` is set by poincare (the section is the event, on the dense output).")

    def event(t, y):
        return section(t, y)

    event.terminal = False
    event.direction = float(direction)
    sol = integrate(system, y0, t_span, h=h, method=method, events=event, dense_output=True, **options)
    if not sol.success:
        raise RuntimeError(f"the run for the section failed: {sol.message}")
    times = np.asarray(sol.t_events[0], dtype=float)
    refined = np.array([_refine(section, sol.sol, t, sol.t[0], sol.t[-1]) for t in times])
    names = list(system.fields)
    if refined.size:
        states = [sol.sol(t) for t in refined]
        y = {name: np.stack([s[name] for s in states]) for name in names}
        residual = np.array([float(section(t, s)) for t, s in zip(refined, states, strict=True)])
    else:
        y = {name: np.empty((0, *shape)) for name, shape in system.fields.items()}
        residual = np.empty(0)
    return PoincareSection(refined, y, residual, sol)


def _refine(section, dense, t: float, lo: float, hi: float) -> float:
    """The secant method on ``g(t, dense(t))`` from Brent's root ``t``, until ``t`` stops moving."""

    def g(s):
        return float(section(s, dense(s)))

    a, fa = t, g(t)
    if fa == 0.0:
        return t
    b = min(max(t + 1e-9 * max(1.0, abs(t)), lo), hi)
    fb = g(b)
    for _ in range(_SECANT_ITERATIONS):
        if fb == fa:
            break
        c = b - fb * (b - a) / (fb - fa)
        if not (np.isfinite(c) and lo <= c <= hi) or abs(c - t) > 1e-6 * max(1.0, abs(t)):
            return t  # the secant left the neighbourhood of Brent's root: keep the root
        a, fa, b = b, fb, c
        fb = g(b)
        if fb == 0.0 or abs(b - a) <= 4.0 * _EPS * max(1.0, abs(b)):
            break
    return b if abs(fb) <= abs(g(t)) else t
