"""How far a run can be trusted: its global error estimated by propagating local errors.

The global error of a one-step method is the sum of its local errors, each carried to the end
by the tangent map of the steps after it (Lady Windermere's fan, Hairer, Nørsett & Wanner 1993, §II.3):
``e_N ≈ Σ_k DΦ_{N←k+1} l_k``, i.e. ``E_{k+1} = DΦ_h(y_k) E_k + l_k`` with ``E_0 = 0``. Here

* ``l_k``, the local error of the step, is estimated by step doubling (Richardson): with ``p``
  the method's order, ``l_k ≈ (Φ_h(y_k) − Φ_{h/2}(Φ_{h/2}(y_k))) · 2ᵖ/(2ᵖ − 1)``, read in the
  tangent coordinates at ``y_{k+1}`` (:mod:`lieint.tangent.coordinates`);
* ``DΦ_h(y_k) E_k`` is the exact derivative of the method's step along ``E_k`` (the complex
  step, :class:`TangentStepper`), whose real part is the step ``y_{k+1}`` itself.

Each step costs one complex step and two real half steps. The estimate is first order in the
error: it is trustworthy while it is small against the motion (which is what a tolerance of,
say, 1e-3 asks), and it says when that ends — a separatrix run whose energy stays at round-off
while its phase is lost, for instance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..methods.base import Method
from ..systems.base import LieGroupSystem
from .coordinates import TangentChart
from .flow import BACKEND_REASON, TangentStepper, step_schedule

__all__ = ["ErrorPropagator", "TrustHorizon", "check_tolerance", "trust_horizon"]


@dataclass(frozen=True)
class TrustHorizon:
    """A run with the estimate of its global error over time.

    Attributes
    ----------
    t : ndarray, shape (m,)
        The times of the grid (``t0`` and the end of every step).
    estimate : ndarray, shape (m, ...)
        The largest component of the propagated error estimate ``E(t)`` in tangent coordinates.
    tolerance : float
        The threshold asked for.
    horizon : ndarray, shape b
        The first grid time at which ``estimate`` exceeds ``tolerance`` (``inf``: never, up to
        the end of the run); a float for one body.
    y : dict of ndarray
        The final state.
    error : ndarray, shape (..., dim)
        The final error estimate ``E(T)`` (estimated ``y_h(T) − y(T)``, tangent coordinates).
    chart : TangentChart
        The tangent coordinates.
    nsteps : int
        Steps taken.
    backend_reason : str
        Why the run is not compiled.
    """

    t: np.ndarray
    estimate: np.ndarray
    tolerance: float
    horizon: np.ndarray | float
    y: dict
    error: np.ndarray
    chart: TangentChart
    nsteps: int
    backend_reason: str = BACKEND_REASON


def check_tolerance(tolerance) -> float:
    """``tolerance`` as a float, or :class:`ValueError` naming it (a finite positive number)."""
    number = isinstance(tolerance, (int, float, np.floating, np.integer)) and not isinstance(tolerance, bool)
    if not (number and np.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"`tolerance` must be a finite positive number; got {tolerance!r}.")
    return float(tolerance)


class ErrorPropagator:
    """The recursion ``E_{k+1} = DΦ_h(y_k) E_k + l_k`` of the module docstring, one step at a time.

    :func:`trust_horizon` steps it through a whole run; a streamed run (:func:`lieint.run`) steps
    it beside its own segments.

    Parameters
    ----------
    system : LieGroupSystem
        The system.
    y0 : dict of array_like
        The state to start from (any batch of bodies), with ``E = 0`` there.
    method : str or Method, default "rkmk4"
        A method of known order with a tangent map.
    coordinates : {"exp", "cayley"}, optional
        The coordinate map of a Lie-group method.

    Attributes
    ----------
    y : dict of ndarray
        The state reached.
    E : ndarray, shape (..., dim)
        The error estimate there (tangent coordinates).
    chart : TangentChart
        The tangent coordinates.
    batch : tuple of int
        The batch shape of the bodies.

    Raises
    ------
    ValueError, TypeError
        A method without an order or a tangent map; a bad state.
    """

    def __init__(
        self,
        system: LieGroupSystem,
        y0: dict[str, ArrayLike],
        method: str | Method = "rkmk4",
        *,
        coordinates: str | None = None,
    ):
        self.stepper = TangentStepper(system, method, coordinates)
        p = self.stepper.method.order
        if not isinstance(p, int) or p < 1:
            raise ValueError(
                f"`method` {self.stepper.method.name!r} has no fixed order (got {p!r}); step doubling needs one."
            )
        self.system = system
        self.richardson = 2.0**p / (2.0**p - 1.0)
        self.y = system.validate_state(y0)
        self.chart: TangentChart = self.stepper.chart
        self.batch: tuple[int, ...] = system.batch_shape(self.y)
        self.E = np.zeros(self.batch + (self.chart.dim,))
        self._state = None
        self._started = False

    def restore(self, y: dict[str, ArrayLike], E: ArrayLike) -> None:
        """Continue from a state and error estimate saved earlier (a resumed run).

        Parameters
        ----------
        y : dict of array_like
            The state reached.
        E : array_like, shape (..., dim)
            The error estimate there.
        """
        self.y = self.system.validate_state(y)
        self.E = np.array(E, dtype=float)
        self._started = False  # the method's state is rebuilt at the next step

    def step(self, t: float, h: float, tolerance: float | None = None) -> np.ndarray:
        """One step from ``t`` of size ``h``: the state and the error estimate move on.

        Parameters
        ----------
        t : float
            The time at the start of the step.
        h : float
            The step.
        tolerance : float, optional
            Named in the message when the estimate becomes non-finite.

        Returns
        -------
        ndarray, shape b
            The largest component of the error estimate after the step.

        Raises
        ------
        FloatingPointError
            The estimate became non-finite.
        """
        stepper, system, method_, chart, y = self.stepper, self.system, self.stepper.method, self.chart, self.y
        with np.errstate(over="ignore", invalid="ignore"):
            size = np.max(np.abs(self.E), axis=-1, keepdims=True)
            size = np.where(size > 0, size, 1.0)
            z = stepper.seed(y, (self.E / size)[None])
            if not self._started:
                self._state = stepper.init(t, z, h)
                self._started = True
            z, self._state = stepper.step(t, z, h, self._state)
            y1, carried = stepper.split(z)
            half = method_.step(system, t, y, 0.5 * h, method_.init(system, t, y, 0.5 * h)).y
            half = method_.step(system, t + 0.5 * h, half, 0.5 * h, method_.init(system, t, half, 0.5 * h)).y
            local = chart.read(y1, {name: (y1[name] - half[name])[None] for name in chart.names})[0]
            E = carried[0] * size + self.richardson * local
        self.y, self.E = y1, E
        if not np.all(np.isfinite(E)):
            where = f"the tolerance {tolerance:g}" if tolerance is not None else "any tolerance"
            raise FloatingPointError(
                f"the error estimate became non-finite by t = {t + h:g}; the run has long left {where} "
                "(reduce the step or the horizon)."
            )
        return np.max(np.abs(E), axis=-1)


def trust_horizon(
    system: LieGroupSystem,
    y0: dict[str, ArrayLike],
    t_span: tuple[float, float],
    h: float | None = None,
    method: str | Method = "rkmk4",
    *,
    tolerance: float = 1e-3,
    coordinates: str | None = None,
    steps: ArrayLike | None = None,
    stop: bool = False,
) -> TrustHorizon:
    """Estimate a run's global error over time and the time at which it exceeds ``tolerance``.

    Parameters
    ----------
    system : LieGroupSystem
        The system.
    y0 : dict of array_like
        The initial state (any batch of bodies).
    t_span : tuple of float
        ``(t0, t1)``.
    h : float, optional
        The fixed step (the grid of :func:`lieint.integrate`); or give ``steps``.
    method : str or Method, default "rkmk4"
        A method of known order with a tangent map (not one of
        :data:`lieint.tangent.flow.REFUSED`).
    tolerance : float, default 1e-3
        The error (largest tangent coordinate: momenta, body-frame angles, vector entries) at
        which the run stops being trusted.
    coordinates : {"exp", "cayley"}, optional
        The coordinate map of a Lie-group method.
    steps : array_like of float, optional
        Step sizes to take instead of ``h``.
    stop : bool, default False
        Stop the run once every body has passed its horizon.

    Returns
    -------
    TrustHorizon
        The estimate over time and the horizon.

    Raises
    ------
    ValueError, TypeError
        A bad argument, named; a method without an order or a tangent map.

    Examples
    --------
    >>> import lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    >>> run = lieint.trust_horizon(top, y0, (0.0, 5.0), h=0.1, tolerance=1e-3)
    >>> run.horizon, bool(run.estimate[-1] < 1e-3)
    (inf, True)
    """
    propagator = ErrorPropagator(system, y0, method, coordinates=coordinates)
    tolerance = check_tolerance(tolerance)
    if not isinstance(stop, (bool, np.bool_)):
        raise TypeError(f"`stop` must be True or False; got {stop!r}.")
    t0, _, starts, sizes = step_schedule(t_span, h, steps)
    times, estimates = [t0], [np.zeros(propagator.batch)]
    for tk, hk in zip(starts, sizes, strict=True):
        estimates.append(propagator.step(float(tk), float(hk), tolerance))
        times.append(float(tk) + float(hk))
        if stop and np.all(np.max(estimates, axis=0) > tolerance):
            break
    y, E, chart = propagator.y, propagator.E, propagator.chart
    t = np.array(times)
    estimate = np.stack(estimates)
    above = estimate > tolerance
    first = np.argmax(above, axis=0)
    horizon = np.where(np.any(above, axis=0), t[first], np.inf)
    return TrustHorizon(
        t, estimate, float(tolerance), float(horizon) if horizon.ndim == 0 else horizon, y, E, chart, len(t) - 1
    )
