"""The trust horizon of a streamed run: when its estimated global error first exceeds a tolerance.

``lieint run SCENE --max-error-estimate E`` (``lieint.run(..., max_error_estimate=E)``) carries
the estimate of :func:`lieint.trust_horizon` beside the run: the same
:class:`~lieint.tangent.horizon.ErrorPropagator` stepped on the run's own grid, segment after
segment (a step ahead of the segment's rows: it follows its own copy of the run, the real part of
its complex step), so the horizon found is the one ``lieint.trust_horizon`` gives for the scene. Each
member's first crossing is printed when it happens and recorded in the run file's attribute
``trust_horizon`` (JSON, read by ``lieint info``); the run goes on unless asked to stop there.

The estimate needs a fixed-step method of known order with a tangent map, costs one complex step
and two half steps per step on the generic numpy path, and is carried no further once every
member has crossed. Its state (the state it follows, the estimate, the crossings) is part of
the run's checkpoint, so a resumed run finds the same horizon bit for bit.
"""

from __future__ import annotations

import json

import numpy as np

from ..control import Plan

__all__ = ["RunHorizon", "describe_horizon"]


class RunHorizon:
    """The error estimate of a streamed run, advanced step by step on the run's grid.

    Parameters
    ----------
    system : LieGroupSystem
        The run's system.
    y0 : dict of ndarray
        Its initial state (any batch of members).
    method : Method
        Its method (fixed step, known order, with a tangent map).
    plan : Plan
        Its step grid.
    tolerance : float
        The error at which the run stops being trusted (``max_error_estimate``).

    Attributes
    ----------
    k : int
        Steps the estimate has been carried.
    horizon : ndarray, shape b
        Per member, the first grid time at which the estimate exceeds ``tolerance`` (``inf``:
        not yet).
    largest : ndarray, shape b
        Per member, the largest estimate so far.

    Raises
    ------
    ValueError
        A tolerance that is not a finite positive number, a method that cannot give the
        estimate (named as ``max_error_estimate``).
    """

    def __init__(self, system, y0: dict, method, plan: Plan, tolerance: float):
        from ..tangent.horizon import ErrorPropagator, check_tolerance

        try:
            self.tolerance = check_tolerance(tolerance)
        except ValueError:
            raise ValueError(f"`max_error_estimate` must be a finite positive error; got {tolerance!r}.") from None
        try:
            self.propagator = ErrorPropagator(system, y0, method)
        except (ValueError, TypeError) as exc:
            raise ValueError(f"`max_error_estimate` cannot be estimated for this run: {exc}") from None
        self.plan = plan
        self.k = 0
        batch = self.propagator.batch
        self.horizon = np.full(batch, np.inf)
        self.largest = np.zeros(batch)

    @property
    def done(self) -> bool:
        """Every member has crossed (the estimate is carried no further)."""
        return bool(np.all(np.isfinite(self.horizon)))

    def advance(self, k_to: int) -> list[tuple[int, float]]:
        """Carry the estimate to step ``k_to`` of the grid (no further once :attr:`done`).

        Parameters
        ----------
        k_to : int
            The run's step.

        Returns
        -------
        list of (int, float)
            The members that crossed in these steps (flat index) and when.
        """
        crossed: list[tuple[int, float]] = []
        plan = self.plan
        k_to = min(k_to, plan.nsteps)
        while self.k < k_to and not self.done:
            t, h = plan.t0 + self.k * plan.h, plan.step_size(self.k)  # the grid of lieint.trust_horizon
            try:
                estimate = self.propagator.step(t, h, self.tolerance)
            except FloatingPointError:
                # overflowed: a non-finite estimate is beyond every tolerance (the run goes on)
                estimate = np.max(np.abs(self.propagator.E), axis=-1)
                estimate = np.where(np.isfinite(estimate), estimate, np.inf)
            self.k += 1
            self.largest = np.maximum(self.largest, estimate)
            new = (estimate > self.tolerance) & np.isinf(self.horizon)
            if np.any(new):
                self.horizon = np.where(new, t + h, self.horizon)
                crossed += [(int(i), t + h) for i in np.flatnonzero(np.ravel(new))]
        return crossed

    # -- the run file and its checkpoint -------------------------------------------------------
    def record(self) -> str:
        """The file attribute ``trust_horizon``: JSON with the tolerance, per member the horizon
        (null: not reached) and the largest estimate, and the time the estimate reached."""
        return json.dumps(
            {
                "max_error_estimate": self.tolerance,
                "horizon": [None if np.isinf(v) else float(v) for v in np.ravel(self.horizon)],
                "largest_estimate": [float(v) for v in np.ravel(self.largest)],
                "estimated_to": self._reached(),
                "members_shape": list(np.shape(self.horizon)),
            }
        )

    def _reached(self) -> float:
        """The time the estimate has reached, as :meth:`advance` computes the end of a step."""
        plan, k = self.plan, self.k
        if k == 0:
            return float(plan.t0)
        return plan.t0 + (k - 1) * plan.h + plan.step_size(k - 1)

    def checkpoint(self) -> tuple[dict[str, np.ndarray], dict]:
        """The arrays and attributes a checkpoint keeps of the estimate."""
        p = self.propagator
        arrays = {f"horizon_y:{k}": np.asarray(v) for k, v in p.y.items()}
        arrays.update({"horizon_E": p.E, "horizon_t": self.horizon, "horizon_largest": self.largest})
        return arrays, {"horizon_k": self.k, "horizon_tolerance": self.tolerance}

    def restore(self, arrays: dict, attrs: dict) -> None:
        """Continue from a checkpoint's arrays and attributes (:meth:`checkpoint`).

        Raises
        ------
        ValueError
            The checkpoint holds no estimate (the run was started without
            ``max_error_estimate``) or one of another tolerance.
        """
        if "horizon_k" not in attrs:
            raise ValueError(
                "`max_error_estimate`: this run was started without it, and the estimate is carried from the start "
                "of the run; resume without it, or start again with --overwrite"
            )
        before = float(attrs["horizon_tolerance"])
        if before != self.tolerance:
            raise ValueError(
                f"`max_error_estimate`: this run was started with {before:g}; resume with the same (got "
                f"{self.tolerance:g})"
            )
        y = {k.split(":", 1)[1]: v for k, v in arrays.items() if k.startswith("horizon_y:")}
        self.propagator.restore(y, arrays["horizon_E"])
        self.horizon = np.array(arrays["horizon_t"], dtype=float)
        self.largest = np.array(arrays["horizon_largest"], dtype=float)
        self.k = int(attrs["horizon_k"])


def describe_horizon(record: dict) -> str:
    """The ``trust_horizon`` record of a run (:meth:`RunHorizon.record`) in words, one line per
    member (a summary line for more than four).

    Parameters
    ----------
    record : dict
        The parsed record.

    Returns
    -------
    str
    """
    tol = float(record["max_error_estimate"])
    to = float(record["estimated_to"])
    horizons, largest = record["horizon"], record["largest_estimate"]
    n = len(horizons)

    def one(t, big) -> str:
        if t is None:
            return f"not reached by t = {to:g}: the largest error estimate is {big:.2e} <= {tol:g}"
        return f"t = {t:g}: the estimated global error exceeds {tol:g} there"

    if n == 1:
        return f"trust horizon {one(horizons[0], largest[0])}"
    if n <= 4:
        return "\n".join(
            f"trust horizon member {i}: {one(t, e)}" for i, (t, e) in enumerate(zip(horizons, largest, strict=True))
        )
    reached = [t for t in horizons if t is not None]
    if not reached:
        return f"trust horizon not reached by t = {to:g} by any of {n} members (largest estimate {max(largest):.2e})"
    return (
        f"trust horizon: {len(reached)} of {n} members exceed {tol:g}, the first at t = {min(reached):g}, the last at "
        f"t = {max(reached):g}" + (f" (estimated to t = {to:g})" if len(reached) < n else "")
    )
