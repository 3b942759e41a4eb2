"""Fixed-step integration over a global step grid, in segments.

:func:`lieint.integrate` runs one segment over the whole grid; the streaming runner
(:mod:`lieint.runs`) runs many and checkpoints between them. Both use the same engine, and
an engine's internal state is exact across segment boundaries, so a run split anywhere
(by checkpoints, an interruption and a resume) produces the same bits as one that is not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Plan", "make_engine"]

# How often (in steps) a long stretch between saves is checked for non-finite values.
_FINITE_CHECK_EVERY = 256


@dataclass(frozen=True)
class Plan:
    """The global step grid ``t_k = t0 + k h`` (k < nsteps) ending exactly at ``t1``."""

    t0: float
    t1: float
    h: float
    nsteps: int

    @classmethod
    def make(cls, t0: float, t1: float, h: float) -> Plan:
        ratio = (t1 - t0) / h
        nearest = round(ratio)
        # a ratio within round-off of an integer is that integer (no sliver of a last step)
        n = int(nearest) if abs(ratio - nearest) <= 1e-9 * max(1.0, ratio) else math.ceil(ratio)
        return cls(t0, t1, h, max(1, n))

    def time(self, k: int) -> float:
        return self.t1 if k == self.nsteps else self.t0 + k * self.h

    @property
    def last_step(self) -> float:
        """Size of the last step, ``t1 − t_{n−1}`` (h unless (t1 − t0)/h is not an integer)."""
        return self.t1 - (self.t0 + (self.nsteps - 1) * self.h)

    def save_steps(self, save_every: int) -> np.ndarray:
        """Every ``save_every``-th step and the last one, step 0 included."""
        steps = list(range(0, self.nsteps + 1, save_every))
        if steps[-1] != self.nsteps:
            steps.append(self.nsteps)
        return np.array(steps, dtype=np.int64)


@dataclass
class Segment:
    """What one :meth:`advance` produced: the saved states of the save steps it passed
    (``(m, *batch, ...)`` per field), evaluations, the last completed step, a failure."""

    states: dict
    nfev: int
    done: int
    failure: str | None = None


class NumpyEngine:
    """The generic path: any system, any method; the internal state is the state dict."""

    name = "numpy"

    def __init__(self, system, stepper):
        self.system, self.stepper = system, stepper

    def start(self, y: dict) -> dict:
        return dict(y)

    def user_state(self, internal: dict) -> dict:
        return internal

    def advance(self, internal: dict, k_from: int, k_to: int, plan: Plan, save_steps, project: bool):
        system, stepper = self.system, self.stepper
        save_steps = [int(s) for s in save_steps]
        y = internal
        saved = {name: np.empty((len(save_steps),) + arr.shape) for name, arr in y.items()}
        slot, nfev, done, failure = 0, 0, k_from, None
        # overflow is detected and reported (a failure), not warned about per operation
        with np.errstate(over="ignore", invalid="ignore"):
            for k in range(k_from, k_to):
                tk = plan.t0 + k * plan.h
                hk = plan.h if k < plan.nsteps - 1 else plan.last_step
                try:
                    y_new, evals = stepper.step(system, tk, y, hk)
                except np.linalg.LinAlgError as exc:  # a linear solve met a non-finite stage
                    failure = (
                        f"Step {k + 1} (t = {tk:.6g}) failed in a linear solve ({exc}): the stages became "
                        f"non-finite, the step `h` = {plan.h:g} is far too large for this motion. Reduce `h`."
                    )
                    break
                nfev += evals
                if project:
                    y_new = system.project(y_new)
                saving = slot < len(save_steps) and save_steps[slot] == k + 1
                if (saving or (k + 1) % _FINITE_CHECK_EVERY == 0) and not _all_finite(y_new):
                    failure = (
                        f"The state became non-finite (NaN or inf) by step {k + 1} (t = {plan.time(k + 1):.6g}); "
                        f"the run stopped there. Reduce the step `h` = {plan.h:g} or check the initial state."
                    )
                    break
                y, done = y_new, k + 1
                if saving:
                    for name, arr in y.items():
                        saved[name][slot] = arr
                    slot += 1
        if y is not internal:
            internal.clear()
            internal.update(y)
        return Segment({k: v[:slot] for k, v in saved.items()}, nfev, done, failure)


class KernelEngine:
    """A compiled kernel (see :mod:`lieint.fast`) behind the engine interface."""

    name = "numba"

    def __init__(self, kernel):
        self.kernel = kernel
        self.stepper = kernel.stepper

    def start(self, y: dict) -> dict:
        return self.kernel.start(y)

    def user_state(self, internal: dict) -> dict:
        return self.kernel.user_state(internal)

    def advance(self, internal: dict, k_from: int, k_to: int, plan: Plan, save_steps, project: bool):
        save_steps = np.asarray(save_steps, dtype=np.int64)
        new, states = self.kernel.advance(internal, k_from, k_to, plan, save_steps, project)
        m = save_steps.size
        finite = np.all([np.isfinite(v.reshape(m, -1)).all(axis=1) for v in states.values()], axis=0)
        done, failure = k_to, None
        if not (finite.all() and all(np.isfinite(v).all() for v in new.values())):
            bad = int(np.argmin(finite)) if not finite.all() else save_steps.size
            states = {k: v[:bad] for k, v in states.items()}
            done = int(save_steps[bad - 1]) if bad > 0 else k_from
            failure = (
                f"The state became non-finite (NaN or inf) after step {done} (t = {plan.time(done):.6g}); "
                f"the run stopped there. Reduce the step `h` = {plan.h:g} or check the initial state."
            )
        else:
            internal.clear()
            internal.update(new)
        return Segment(states, self.stepper.stages * (done - k_from), done, failure)


def make_engine(system, stepper, plan: Plan, y, backend: str = "auto"):
    """The compiled engine where a kernel covers system, method and step, else the generic one.

    ``backend="numba"`` raises when no kernel applies; ``"numpy"`` forces the generic path.
    """
    if backend != "numpy":
        from . import fast

        if fast.supports(system, stepper) and fast.within_range(system, stepper, y, plan.h):
            return KernelEngine(fast.Top3Kernel(system, stepper, y))
        if backend == "numba":
            raise ValueError(
                f"`backend='numba'`: no compiled kernel covers {type(system).__name__} "
                f"(n = {getattr(system, 'n', '?')}) with {stepper.name!r} at h = {plan.h:g}; kernels exist for the "
                "3D EulerTop with RKMK in exponential coordinates (truncated dexp⁻¹, stages within the series "
                "radius) or classical RK. Use backend='auto' or 'numpy'."
            )
    return NumpyEngine(system, stepper)


def _all_finite(y: dict) -> bool:
    return all(bool(np.isfinite(arr).all()) for arr in y.values())
