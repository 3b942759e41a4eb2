"""Step-size control: the fixed grid of fixed-step methods and the controller of adaptive ones.

* :class:`Plan` — the global grid ``t_k = t0 + k h`` ending exactly on ``t1``. A run split into
  segments anywhere (checkpoints, an interruption and a resume) steps the same grid, which is
  what makes a resumed run equal to an uninterrupted one bit for bit.
* :class:`StepSizeController` — accepts or rejects a step of an adaptive method from its error
  estimate and proposes the next step, for every method whose ``step`` returns an estimate
  (the RKMK pairs and any later method with one). The error is measured on the state,
  componentwise ``|e| / (atol + rtol·max(|y₀|, |y₁|))`` in the RMS norm over every field, as
  scipy does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Plan", "StepSizeController"]


@dataclass(frozen=True)
class Plan:
    """The global step grid ``t_k = t0 + k h`` (k < nsteps) ending exactly at ``t1``."""

    t0: float
    t1: float
    h: float
    nsteps: int

    @classmethod
    def make(cls, t0: float, t1: float, h: float) -> Plan:
        """The grid of step ``h`` over ``[t0, t1]``; refused (:class:`lieint.limits.LimitError`)
        when it has more steps than ``LIEINT_MAX_STEPS``, before anything is allocated."""
        from .limits import check

        with np.errstate(over="ignore"):
            ratio = (t1 - t0) / h
        check("LIEINT_MAX_STEPS", float(ratio), f"the number of steps (t1 - t0)/`h` = ({t1:g} - {t0:g})/{h:g}")
        nearest = round(ratio)
        # a ratio within round-off of an integer is that integer (no sliver of a last step)
        n = int(nearest) if abs(ratio - nearest) <= 1e-9 * max(1.0, ratio) else math.ceil(ratio)
        return cls(t0, t1, h, max(1, n))

    def time(self, k: int) -> float:
        return self.t1 if k == self.nsteps else self.t0 + k * self.h

    def step_size(self, k: int) -> float:
        """Size of step k (from t_k to t_{k+1})."""
        return self.h if k < self.nsteps - 1 else self.last_step

    @property
    def last_step(self) -> float:
        """Size of the last step, ``t1 − t_{n−1}`` (h unless (t1 − t0)/h is not an integer)."""
        return self.t1 - (self.t0 + (self.nsteps - 1) * self.h)

    def saves_between(self, save_every: int, k_from: int, k_to: int) -> np.ndarray:
        """The saved steps s with ``k_from < s <= k_to`` (:meth:`save_steps` restricted to a
        segment, computed without the whole run's array, so memory stays flat)."""
        first = (k_from // save_every + 1) * save_every
        steps = np.arange(first, k_to + 1, save_every, dtype=np.int64)
        if k_from < self.nsteps <= k_to and (steps.size == 0 or steps[-1] != self.nsteps):
            steps = np.append(steps, np.int64(self.nsteps))
        return steps

    def times(self, steps: np.ndarray) -> np.ndarray:
        """``t_k`` of an array of steps (:meth:`time` elementwise, the same floating-point result)."""
        steps = np.asarray(steps, dtype=np.int64)
        return np.where(steps == self.nsteps, self.t1, self.t0 + steps.astype(np.float64) * self.h)

    def save_steps(self, save_every: int) -> np.ndarray:
        """Every ``save_every``-th step and the last one, step 0 included (refused beyond
        ``LIEINT_MAX_MEMORY``: streamed runs use :meth:`saves_between` instead)."""
        from .limits import check

        check(
            "LIEINT_MAX_MEMORY",
            float(8 * (self.nsteps // save_every + 2)),
            f"the memory of the {self.nsteps // save_every + 2} save times of `h` = {self.h:g}, "
            f"`save_every` = {save_every} (bytes)",
            "raise save_every",
        )
        steps = np.arange(0, self.nsteps + 1, save_every, dtype=np.int64)
        if steps[-1] != self.nsteps:
            steps = np.append(steps, np.int64(self.nsteps))
        return steps


@dataclass(frozen=True)
class StepSizeController:
    """Integral (I) step-size control on an embedded error estimate.

    A step with error norm ``err > 1`` is rejected and retried with a smaller step; an accepted
    one proposes ``h·min(factor_max, max(factor_min, safety·err^{−1/(q+1)}))`` with q the order of
    the error estimate.

    Parameters
    ----------
    rtol, atol : float
        Relative and absolute tolerances on every state component.
    safety, factor_min, factor_max : float
        The usual safeguards.
    """

    rtol: float
    atol: float
    safety: float = 0.9
    factor_min: float = 0.2
    factor_max: float = 5.0

    def error_norm(self, y0: dict, y1: dict, error: dict) -> float:
        """RMS over every state component of ``|e| / (atol + rtol·max(|y₀|, |y₁|))``."""
        total, count = 0.0, 0
        for name, e in error.items():
            scale = self.atol + self.rtol * np.maximum(np.abs(y0[name]), np.abs(y1[name]))
            r = e / scale
            total += float(np.sum(r * r))
            count += r.size
        return float(np.sqrt(total / max(count, 1)))

    def initial_step(self, system, t0: float, y0: dict, t1: float) -> float:
        """A first trial step ``0.01‖y₀‖/‖ẏ₀‖`` (the controller corrects it at once)."""
        f = system.vector_field(t0, y0)
        d0 = math.sqrt(sum(float(np.sum(v * v)) for v in y0.values()))
        d1 = math.sqrt(sum(float(np.sum(v * v)) for v in f.values()))
        h = 0.01 * d0 / d1 if d1 > 0 and d0 > 0 else 1e-6 * max(1.0, abs(t1 - t0))
        return min(h, t1 - t0) if math.isfinite(h) else 1e-6 * max(1.0, abs(t1 - t0))

    def factor(self, err: float, error_order: int) -> float:
        """The step factor after a step with error norm ``err``."""
        if not math.isfinite(err):
            return self.factor_min
        if err == 0.0:
            return self.factor_max
        return min(self.factor_max, max(self.factor_min, self.safety * err ** (-1.0 / (error_order + 1))))
