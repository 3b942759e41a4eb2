"""The step-size controller's arithmetic, shared by the compiled adaptive loops (numba, cached).

:mod:`lieint.fast.top3_adaptive` (the 3D top) and :mod:`lieint.fast.generic_adaptive` (every
system with compiled pieces) run the whole controller loop in machine code, each with its own
trial step and error measure; what decides a step is the same in both, and the same as the
generic path's :class:`lieint.control.StepSizeController`, operation for operation:

* :func:`error_norm` — scipy's RMS norm ``err = √(s/N)`` of the scaled differences
  ``r_i = (y₁ − ŷ)_i / (atol + rtol·max(|y₀,i|, |y₁,i|))`` (``s = Σ r_i²`` over N components),
  or DOP853's combination of its 5th- and 3rd-order estimates ``err = s₅/√((s₅ + 0.01 s₃)·N)``;
  infinite when the trial step failed (a stage beyond the dexp⁻¹ radius);
* :func:`step_factor` — ``h`` is multiplied by ``max(f_min, safety·err^{−1/(q+1)})`` after a
  rejection (``err ≥ 1`` or not finite), by ``min(f_max, safety·err^{−1/(q+1)})`` after an
  acceptance, capped at 1 right after a rejection;
* :func:`advanced_time` — an accepted step lands on ``t1`` exactly when it ends within
  ``h_min`` of it.
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["advanced_time", "error_norm", "step_factor"]


@njit(cache=True)
def error_norm(ok, s5, s3, has_low, count):
    """The error of a trial step from the sums of squared scaled differences ``s5`` (and ``s3``
    of a lower-order estimate when ``has_low``) over ``count`` components; ``inf`` when the
    trial step failed (``ok`` False)."""
    if not ok:
        return math.inf
    if not has_low:
        return math.sqrt(s5 / count)
    if s5 == 0.0 and s3 == 0.0:
        return 0.0
    return s5 / math.sqrt((s5 + 0.01 * s3) * count)


@njit(cache=True)
def step_factor(err, q, safety, fmin, fmax, after_rejection):
    """:meth:`lieint.control.StepSizeController.factor`, the same operations."""
    if not math.isfinite(err):
        return fmin
    if err >= 1.0:
        return max(fmin, safety * err ** (-1.0 / (q + 1)))
    if err == 0.0:
        grow = fmax
    else:
        grow = min(fmax, safety * err ** (-1.0 / (q + 1)))
    if after_rejection:
        return min(1.0, grow)
    return grow


@njit(cache=True)
def advanced_time(t, h, t1, h_min):
    """The time after an accepted step of size h from t: ``t1`` itself within ``h_min``."""
    return t1 if t1 - (t + h) <= h_min else t + h
