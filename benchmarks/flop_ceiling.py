"""The 3D-top ensemble kernel against the floating-point ceiling of this machine, in one run.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/flop_ceiling.py`` (about half a minute; also
printed by ``benchmarks/systems_speed.py --ensembles``).

Three rates in GFLOP per CPU-second (process time of all threads, numba's default thread count),
each the best of five calls, side by side:

* **FMA ceiling**: a numba loop ``x ← a x + b`` over independent lanes (rows of 64 doubles,
  four threads' worth per thread, resident in L1; four updates per load and store, the variant
  of 1, 4 and 8 that ran fastest here), compiled with contraction allowed
  (``fastmath={"contract"}``), so each update is one fused multiply-add: 2 flops per instruction;
* **strict ceiling**: the same loop under strict IEEE arithmetic (no contraction): a multiply
  and an add, 2 flops in 2 instructions — what the lanes kernel, compiled strict on purpose
  (:mod:`lieint.fast.lanes`: bit-identical ensembles whatever the chunking), can at most reach;
* **3D top ensemble**: ``lieint.integrate`` of 4,096 tops with orientation × 1,000 RKMK4 steps
  in one batched call (the SIMD-lanes kernel), body-steps per CPU-second × 416 flops.

The 416 flops of one RKMK4 step of one body are counted by hand in ``lieint/fast/lanes.py``
(a multiply, add or subtract is one flop; sign flips are not counted):

* each of the three stages after the first: ``u += w K_j`` 6, ``θ²`` 5, the two Rodrigues
  coefficients (Horner, degree 5 in θ²) 20, ``exp(−û)Π`` 30, ``I⁻¹Π`` 3, the two dexp⁻¹ terms
  ``c₁(−u)×ξ + c₂(−u)×((−u)×ξ)`` 30: 94, so 282;
* the first stage ``I⁻¹Π``: 3;
* the update: ``U = h Σ b_j K_j`` 24, ``θ²`` 5, coefficients 20, ``Π ← exp(−Û)Π`` 30,
  ``cos(θ/2)``, ``sin(θ/2)/θ`` 21, ``q ← q ⊗ (cos(θ/2), sin(θ/2) U/θ)`` 31: 131.
"""

from __future__ import annotations

import os
import time

import numpy as np
from numba import get_num_threads, njit, prange

#: flops of one RKMK4 step of one 3D top in the lanes kernel (see the module docstring)
FLOPS_PER_RKMK4_STEP = 3 * (6 + 5 + 20 + 30 + 3 + 30) + 3 + (24 + 5 + 20 + 30 + 21 + 31)
LANES = 64
#: updates of a lane per load and store (fewer: the loop waits on memory; more: on latency)
UPDATES = 4


def _update_loop(fastmath):
    """The loop ``x ← a x + b`` over the rows of x, compiled with ``fastmath`` (contraction into
    fused multiply-adds, or strict IEEE)."""

    @njit(parallel=True, fastmath=fastmath)
    def loop(x, a, b, reps):
        for r in prange(x.shape[0]):
            row = x[r]
            for _ in range(reps):
                for lane in range(LANES):
                    v = row[lane]
                    for _k in range(UPDATES):
                        v = a * v + b
                    row[lane] = v

    return loop


_fused = _update_loop({"contract"})
_strict = _update_loop(False)


def _best_rate(call, flops: float, repeats: int = 5) -> tuple[float, float]:
    """GFLOP per CPU-second and per wall-second, best of ``repeats`` calls."""
    call()  # compile / warm up
    cpu, wall = float("inf"), float("inf")
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        call()
        cpu, wall = min(cpu, time.process_time() - c0), min(wall, time.perf_counter() - w0)
    return flops / cpu / 1e9, flops / wall / 1e9


def ceilings(reps: int = 100_000) -> dict[str, tuple[float, float]]:
    """The fused and strict loops' GFLOP per CPU-second and per wall-second."""
    rows = 4 * get_num_threads()
    x = np.ones((rows, LANES))
    flops = 2.0 * rows * LANES * UPDATES * reps
    return {
        "fma": _best_rate(lambda: _fused(x, 0.999999, 1e-6, reps), flops),
        "strict": _best_rate(lambda: _strict(x, 0.999999, 1e-6, reps), flops),
    }


def ensemble_rate(bodies: int = 4096, steps: int = 1000) -> tuple[float, float, str]:
    """The 3D top ensemble's GFLOP per CPU-second and per wall-second, and its back end."""
    import lieint

    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    rng = np.random.default_rng(3)
    w = np.array([0.3, 1.0, 0.4]) + 0.01 * rng.normal(size=(bodies, 3))
    y0 = top.initial_state(angular_velocity=w)
    h = 0.01
    run = lieint.integrate(top, y0, (0.0, steps * h), h=h, method="rkmk4", save_every=steps)
    flops = float(FLOPS_PER_RKMK4_STEP) * bodies * steps

    def call():
        lieint.integrate(top, y0, (0.0, steps * h), h=h, method="rkmk4", save_every=steps)

    cpu, wall = _best_rate(call, flops)
    return cpu, wall, run.stats.backend_reason


def report() -> None:
    """Print the three rates and the ensemble's share of each ceiling."""
    print(
        f"\nFloating-point ceiling ({get_num_threads()} numba threads, {os.cpu_count()} cores, "
        f"load average {os.getloadavg()[0]:.2f}); GFLOP per CPU-second / per wall-second, best of 5"
    )
    ceil = ceilings()
    cpu, wall, backend = ensemble_rate()
    print(f"  FMA loop (contraction allowed)         {ceil['fma'][0]:7.1f} {ceil['fma'][1]:7.1f}")
    print(f"  strict loop (multiply, then add)       {ceil['strict'][0]:7.1f} {ceil['strict'][1]:7.1f}")
    print(f"  3D top ensemble, {FLOPS_PER_RKMK4_STEP} flops per step   {cpu:7.1f} {wall:7.1f}   ({backend})")
    print(
        f"  ensemble / FMA ceiling {100 * cpu / ceil['fma'][0]:.0f} %, "
        f"/ strict ceiling {100 * cpu / ceil['strict'][0]:.0f} % (per CPU-second)"
    )


if __name__ == "__main__":
    report()
