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

from .limits import check

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
        if type(t0) is float and type(t1) is float and type(h) is float:
            ratio = (t1 - t0) / h  # Python floats overflow to inf without a warning
        else:
            with np.errstate(over="ignore"):
                ratio = (t1 - t0) / h
        check("LIEINT_MAX_STEPS", float(ratio), lambda: f"the number of steps (t1 - t0)/`h` = ({t1:g} - {t0:g})/{h:g}")
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

    def times(self, steps: np.ndarray, first: float | None = None) -> np.ndarray:
        """``t_k`` of an array of steps (:meth:`time` elementwise, the same floating-point result),
        after ``first`` when it is given (a segment's starting time, before its saved rows)."""
        if type(steps) is np.ndarray and steps.ndim == 1 and steps.size <= 16:
            # a few saved steps (a short run's): Python floats, the same products and sums as
            # numpy's, in a third of its calls' time
            t0, h, t1, last = self.t0, self.h, self.t1, self.nsteps
            times = [t1 if k == last else t0 + k * h for k in steps.tolist()]
            return np.array(times if first is None else [first, *times], dtype=float)
        if first is not None:
            return np.concatenate([[first], self.times(steps)])
        steps = np.asarray(steps, dtype=np.int64)
        # int64 · float converts the steps to float64 first: the products of astype(float64) · h
        t = self.t0 + steps * self.h
        if t.ndim == 0:
            return np.where(steps == self.nsteps, self.t1, t)
        t[steps == self.nsteps] = self.t1  # np.where costs more than a masked assignment
        return t

    def save_steps(self, save_every: int) -> np.ndarray:
        """Every ``save_every``-th step and the last one, step 0 included (refused beyond
        ``LIEINT_MAX_MEMORY``: streamed runs use :meth:`saves_between` instead)."""
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
    """Integral (I) step-size control on an embedded error estimate — scipy's ``RungeKutta``
    controller, constant for constant.

    The error of a step ``y₀ → y₁`` is measured on the state the user integrates, every field
    (the body momentum A *and* the attitude R of a top), componentwise against the tolerances::

        err = RMS_i( e_i / (atol + rtol·max(|y₀,i|, |y₁,i|)) ),        e = y₁ − ŷ₁,

    the RMS over all components of all fields (scipy's ``_estimate_error_norm`` on the vector
    it integrates). DOP853's 8(5,3) pair combines its two estimates e₅, e₃ (each scaled as
    above, ‖·‖ the RMS norm) as ``err = ‖e₅‖² / √(‖e₅‖² + 0.01‖e₃‖²)``.

    A step with ``err ≥ 1`` is rejected and retried with ``h·max(factor_min, safety·err^{−1/(q+1)})``;
    an accepted one proposes ``h·min(factor_max, safety·err^{−1/(q+1)})``, capped at ``h`` right
    after a rejection, with q the order of the error estimate (2, 4 and 7 for the 3(2), 5(4) and
    8(5,3) pairs, scipy's ``error_estimator_order``). The order-p solution is propagated (local
    extrapolation). The first trial step is scipy's (Hairer's) :meth:`initial_step`.

    Parameters
    ----------
    rtol, atol : float
        Relative and absolute tolerances on every state component.
    safety, factor_min, factor_max : float
        scipy's safeguards (0.9, 0.2, 10).
    """

    rtol: float
    atol: float
    safety: float = 0.9
    factor_min: float = 0.2
    factor_max: float = 10.0

    def _scaled(self, y0: dict, y1: dict, error: dict) -> tuple[float, int]:
        """``Σ_i (e_i/sc_i)²`` and the number of components."""
        total, count = 0.0, 0
        for name, e in error.items():
            scale = self.atol + self.rtol * np.maximum(np.abs(y0[name]), np.abs(y1[name]))
            r = e / scale
            total += float(np.sum(r * r))
            count += r.size
        return total, max(count, 1)

    def error_norm(self, y0: dict, y1: dict, error) -> float:
        """RMS over every state component of ``|e| / (atol + rtol·max(|y₀|, |y₁|))``; for a pair
        ``(e₅, e₃)`` (DOP853) ``‖e₅‖² / √(‖e₅‖² + 0.01‖e₃‖²)`` in that norm."""
        if isinstance(error, tuple):
            s5, n = self._scaled(y0, y1, error[0])
            s3, _ = self._scaled(y0, y1, error[1])
            if s5 == 0.0 and s3 == 0.0:
                return 0.0
            # scipy: |h|·‖E5 K/sc‖² / √((‖E5 K/sc‖² + 0.01‖E3 K/sc‖²)·N), with e = h·E K
            return float(s5 / math.sqrt((s5 + 0.01 * s3) * n))
        total, count = self._scaled(y0, y1, error)
        return float(np.sqrt(total / count))

    def initial_step(self, system, t0: float, y0: dict, t1: float, error_order: int) -> float:
        """scipy's first trial step (Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.4).

        With ``sc = atol + rtol·|y₀|`` and RMS norms ``d₀ = ‖y₀/sc‖``, ``d₁ = ‖f₀/sc‖``
        (f the vector field of the state): ``h₀ = 0.01 d₀/d₁`` (1e-6 when either is below 1e-5),
        one explicit Euler step gives ``d₂ = ‖(f(y₀ + h₀f₀) − f₀)/sc‖/h₀``, and the step is
        ``min(100 h₀, (0.01/max(d₁, d₂))^{1/(q+1)}, |t₁ − t₀|)`` — a size: the Euler step goes
        towards ``t1``, backward in time when ``t1 < t0`` (the caller gives the step its sign).
        """
        span, direction = abs(t1 - t0), (1.0 if t1 >= t0 else -1.0)
        f0 = system.vector_field(t0, y0)
        names = list(y0)
        # every field flattened into one vector (in the order of y0): one scale, one norm per
        # call instead of a few numpy calls per field — a fixed cost of every adaptive run
        flat_y0 = _flat(y0, names)
        scale = self.atol + self.rtol * np.abs(flat_y0)

        def rms(flat: np.ndarray) -> float:
            ratios = flat / scale
            count = max(ratios.size, 1)
            with np.errstate(over="ignore"):
                total = float(np.dot(ratios, ratios))
            if math.isfinite(total):
                return math.sqrt(total / count)
            # the squares overflowed (a tiny atol, 1e-200): scale by the largest ratio first
            top = float(np.max(np.abs(ratios)))
            if not math.isfinite(top):
                return top
            ratios = ratios / top
            return top * math.sqrt(float(np.dot(ratios, ratios)) / count)

        flat_f0 = _flat(f0, names)
        d0, d1 = rms(flat_y0), rms(flat_f0)
        h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
        h0 = min(h0, span)
        with np.errstate(over="ignore", invalid="ignore"):
            step = direction * h0
            f1 = system.vector_field(t0 + step, {k: y0[k] + step * f0[k] for k in y0})
            d2 = rms(_flat(f1, names) - flat_f0) / h0
        if not math.isfinite(d2):
            return h0
        if d1 <= 1e-15 and d2 <= 1e-15:
            h1 = max(1e-6, h0 * 1e-3)
        else:
            h1 = (0.01 / max(d1, d2)) ** (1.0 / (error_order + 1))
        return min(100 * h0, h1, span)

    def factor(self, err: float, error_order: int, after_rejection: bool = False) -> float:
        """The step factor after a step with error norm ``err`` (rejected when ``err ≥ 1``;
        an accepted step right after a rejection does not grow)."""
        if not math.isfinite(err):
            return self.factor_min
        if err >= 1.0:
            return max(self.factor_min, self.safety * err ** (-1.0 / (error_order + 1)))
        grow = self.factor_max if err == 0.0 else min(self.factor_max, self.safety * err ** (-1.0 / (error_order + 1)))
        return min(1.0, grow) if after_rejection else grow


def _flat(fields: dict, names: list) -> np.ndarray:
    """The fields ``names`` of a state (or of its derivative) as one float vector."""
    return np.concatenate([np.asarray(fields[k], dtype=float).ravel() for k in names])
