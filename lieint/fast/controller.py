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
  ``h_min`` of it;
* :func:`first_guess` and :func:`initial_step_from` — scipy's (Hairer's) first trial step
  around the two evaluations of the vector field it needs
  (:meth:`lieint.control.StepSizeController.initial_step`), for the loops whose vector field is
  compiled (:func:`lieint.fast.generic_adaptive.initial_step_lie`): the generic path evaluates the
  field twice in Python, 40–85 µs of an adaptive call on the heavy top and the balls.
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["advanced_time", "error_norm", "first_guess", "initial_step_from", "step_factor"]


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
    """The time after an accepted step h from t (negative backward in time): ``t1`` itself
    within ``h_min``."""
    if h < 0.0:
        return t1 if (t + h) - t1 <= h_min else t + h
    return t1 if t1 - (t + h) <= h_min else t + h


@njit(cache=True)
def _rms(X, Y, rtol, atol):
    """The RMS over every entry of ``X_i / (atol + rtol·|Y_i|)`` (arrays of one shape), as
    :meth:`lieint.control.StepSizeController.initial_step`'s ``rms``: when the squares overflow
    (a tiny atol), the ratios are divided by the largest one first."""
    x, y = X.ravel(), Y.ravel()
    count = max(x.size, 1)
    total = 0.0
    for i in range(x.size):
        r = x[i] / (atol + rtol * abs(y[i]))
        total += r * r
    if math.isfinite(total):
        return math.sqrt(total / count)
    top = 0.0
    for i in range(x.size):
        r = abs(x[i] / (atol + rtol * abs(y[i])))
        if r != r:  # NaN, as np.max gives it
            return r
        if r > top:
            top = r
    if not math.isfinite(top):
        return top
    total = 0.0
    for i in range(x.size):
        r = x[i] / (atol + rtol * abs(y[i])) / top
        total += r * r
    return top * math.sqrt(total / count)


@njit(cache=True)
def first_guess(Y, F0, rtol, atol, span):
    """``(h₀, d₁)``: with ``sc = atol + rtol·|y₀|``, ``d₀ = ‖y₀/sc‖``, ``d₁ = ‖f₀/sc‖`` (RMS),
    ``h₀ = 0.01 d₀/d₁`` (1e-6 when either is below 1e-5), at most ``span`` — Python's
    comparisons, so a NaN goes where the generic path sends it."""
    d0, d1 = _rms(Y, Y, rtol, atol), _rms(F0, Y, rtol, atol)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    if span < h0:  # min(h0, span)
        h0 = span
    return h0, d1


@njit(cache=True)
def initial_step_from(h0, d1, Y, F0, F1, rtol, atol, span, error_order):
    """The first trial step from ``f₁ = f(y₀ + h₀f₀)``: ``d₂ = ‖(f₁ − f₀)/sc‖/h₀`` and
    ``min(100 h₀, (0.01/max(d₁, d₂))^{1/(q+1)}, span)`` (``h₀`` when d₂ is not finite)."""
    D = F1 - F0
    d2 = _rms(D, Y, rtol, atol) / h0
    if not math.isfinite(d2):
        return h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = h0 * 1e-3
        h1 = h1 if h1 > 1e-6 else 1e-6  # max(1e-6, h0·1e-3)
    else:
        h1 = (0.01 / (d2 if d2 > d1 else d1)) ** (1.0 / (error_order + 1))
    best = 100 * h0
    if h1 < best:
        best = h1
    if span < best:
        best = span
    return best
