"""The 3D-top ensemble kernel against the floating-point ceiling of this machine, in one run.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/flop_ceiling.py`` (about half a minute; also
printed by ``benchmarks/systems_speed.py --ensembles``).

Three rates in GFLOP per CPU-second (process time of all threads, numba's default thread count),
measured in fifteen interleaved rounds (one call of each per round, so that a neighbour's load
on a shared machine falls on all three alike), the best of the rounds printed with the median of
the rounds' ratios. Every call does the same work, the ensemble's flops (about 30 ms here): the
best of short calls is the best of more, shorter windows of a noisy host, and a 6 ms loop against
a 30 ms ensemble — the sizes before — made the ceiling look higher by a tenth or more per
CPU-second (its threads' start-up counted less; measured side by side, 11 rounds, 2 runs: FMA
loop best 54.0 and 43.8 GFLOP per CPU-second short, 40.8 and 40.0 at the ensemble's size):

* **FMA ceiling**: a numba loop ``x ← a x + b`` over independent lanes (rows of 64 doubles,
  four threads' worth per thread, resident in L1; four updates per load and store, the variant
  of 1, 4 and 8 that ran fastest here), compiled with contraction allowed
  (``fastmath={"contract"}``), so each update is one fused multiply-add: 2 flops per instruction;
* **strict ceiling**: the same loop under strict IEEE arithmetic (no contraction): a multiply
  and an add, 2 flops in 2 instructions;
* **3D top ensemble**: ``lieint.integrate`` of 4,096 tops with orientation × 1,000 RKMK4 steps
  in one batched call (the SIMD-lanes kernel; the whole call, its checks and conversions
  included), body-steps per CPU-second × the flops of a step; and the same kernel alone on
  prepared arrays (``lieint.fast.lanes.run_lanes``), to show what the call's Python adds.

The 404 flops of one RKMK4 step of one body are counted by hand in ``lieint/fast/lanes.py``
(a multiply, add or subtract is one flop, a fused multiply-add two; sign flips are not counted):

* each of the three stages after the first: ``u = w K_j`` 3, ``θ²`` 5, the two Rodrigues
  coefficients (Horner, degree 5 in θ²) 20, ``exp(−û)Π`` 30, ``I⁻¹Π`` 3, the two dexp⁻¹ terms
  ``c₁(−u)×ξ + c₂(−u)×((−u)×ξ)`` 30: 91, so 273;
* the first stage ``I⁻¹Π``: 3;
* the update: ``U = h Σ b_j K_j`` 21, ``θ²`` 5, coefficients 20, ``Π ← exp(−Û)Π`` 30,
  ``cos(θ/2)``, ``sin(θ/2)/θ`` 21, ``q ← q ⊗ (cos(θ/2), sin(θ/2) U/θ)`` 31: 128.

The kernel writes its multiply-adds as explicit fused multiply-adds (``lieint.fast.fused.fma``,
correctly rounded, so every lane rounds alike), which the FMA ceiling's loop also uses.
"""

from __future__ import annotations

import os
import time

import numpy as np
from numba import get_num_threads, njit, prange

#: flops of one RKMK4 step of one 3D top in the lanes kernel (see the module docstring)
FLOPS_PER_RKMK4_STEP = 3 * (3 + 5 + 20 + 30 + 3 + 30) + 3 + (21 + 5 + 20 + 30 + 21 + 31)
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


def _rate(call, flops: float) -> tuple[float, float]:
    """GFLOP per CPU-second and per wall-second of one call."""
    c0, w0 = time.process_time(), time.perf_counter()
    call()
    return flops / (time.process_time() - c0) / 1e9, flops / (time.perf_counter() - w0) / 1e9


def _ceiling_calls(work: float) -> dict:
    """The fused and strict loops as ``(call, flops)``, each about ``work`` flops."""
    rows = 4 * get_num_threads()
    x = np.ones((rows, LANES))
    reps = max(1, round(work / (2.0 * rows * LANES * UPDATES)))
    flops = 2.0 * rows * LANES * UPDATES * reps
    return {
        "fma": (lambda: _fused(x, 0.999999, 1e-6, reps), flops),
        "strict": (lambda: _strict(x, 0.999999, 1e-6, reps), flops),
    }


def _ensemble_call(bodies: int = 4096, steps: int = 1000):
    """The 3D top ensemble as ``(call, flops)`` and its back end."""
    import lieint

    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    rng = np.random.default_rng(3)
    w = np.array([0.3, 1.0, 0.4]) + 0.01 * rng.normal(size=(bodies, 3))
    y0 = top.initial_state(angular_velocity=w)
    h = 0.01

    def call():
        return lieint.integrate(top, y0, (0.0, steps * h), h=h, method="rkmk4", save_every=steps)

    return (call, float(FLOPS_PER_RKMK4_STEP) * bodies * steps), call().stats.backend_reason


def _kernel_call(bodies: int = 4096, steps: int = 1000):
    """The lanes kernel alone on the same ensemble, its arrays prepared: ``(call, flops)``."""
    from lieint.fast import use_threads
    from lieint.fast.lanes import _BLOCK, run_lanes
    from lieint.groups.base import bernoulli_dexpinv_coefficients
    from lieint.methods.registry import get_method

    rng = np.random.default_rng(3)
    w = np.array([0.3, 1.0, 0.4]) + 0.01 * rng.normal(size=(bodies, 3))
    moments = np.array([1.0, 2.0, 3.0])
    pi0 = np.ascontiguousarray((w * moments).T)
    q0 = np.zeros((4, bodies))
    q0[0] = 1.0
    tab = get_method("rkmk4").compiled()
    coeffs = np.array(bernoulli_dexpinv_coefficients(tab["dexpinv_degree"]), dtype=float)
    save = np.array([steps], dtype=np.int64)
    # the rows the call keeps, the starting state's and the last, in the user's frame
    out_A, out_R = np.empty((2, bodies, 3, 3)), np.empty((2, bodies, 3, 3))
    parallel = use_threads(-(-bodies // _BLOCK))[0]

    A, b, c = (np.asarray(tab[key], dtype=float) for key in ("A", "b", "c"))

    def call():
        run_lanes(
            pi0.copy(), q0.copy(), 1.0 / moments, A, b, c, coeffs, 0.01, 0.01, 0, steps, steps, save, False,
            np.eye(3), True, 1, out_A, out_R, parallel,
        )  # fmt: skip

    return call, float(FLOPS_PER_RKMK4_STEP) * bodies * steps


def measure(rounds: int = 15) -> tuple[dict, str]:
    """Per-round rates ``{name: [(cpu, wall), …]}`` of the two loops and the ensemble, interleaved."""
    ensemble, backend = _ensemble_call()
    calls = _ceiling_calls(work=ensemble[1])
    calls["ensemble"] = ensemble
    calls["kernel"] = _kernel_call()
    for call, _ in calls.values():
        call()  # compile / warm up
    rates = {name: [] for name in calls}
    for _ in range(rounds):
        for name, (call, flops) in calls.items():
            rates[name].append(_rate(call, flops))
    return rates, backend


def report() -> None:
    """Print the three rates and the ensemble's share of each ceiling."""
    print(
        f"\nFloating-point ceiling ({get_num_threads()} numba threads, {os.cpu_count()} cores, "
        f"load average {os.getloadavg()[0]:.2f}); GFLOP per CPU-second / per wall-second, "
        "best of 15 interleaved rounds of equal work"
    )
    rates, backend = measure()
    best = {name: (max(r[0] for r in rs), max(r[1] for r in rs)) for name, rs in rates.items()}
    print(f"  FMA loop (contraction allowed)         {best['fma'][0]:7.1f} {best['fma'][1]:7.1f}")
    print(f"  strict loop (multiply, then add)       {best['strict'][0]:7.1f} {best['strict'][1]:7.1f}")
    print(
        f"  3D top ensemble, {FLOPS_PER_RKMK4_STEP} flops per step   "
        f"{best['ensemble'][0]:7.1f} {best['ensemble'][1]:7.1f}   ({backend})"
    )
    print(f"    its kernel alone (run_lanes, arrays prepared) {best['kernel'][0]:7.1f} {best['kernel'][1]:7.1f}")
    for name, label in (("ensemble", "ensemble (the whole call)"), ("kernel", "kernel alone")):
        # per CPU-second, and per wall-second: on a virtual machine whose processor time is
        # partly stolen by the host, process time can under-count, the wall clock cannot
        cpu = [e[0] / f[0] for e, f in zip(rates[name], rates["fma"], strict=True)]
        wall = [e[1] / f[1] for e, f in zip(rates[name], rates["fma"], strict=True)]
        print(
            f"  {label} / FMA ceiling: {100 * best[name][0] / best['fma'][0]:.0f} % per CPU-second "
            f"(best / best; median of the rounds' ratios {100 * float(np.median(cpu)):.0f} %), "
            f"{100 * best[name][1] / best['fma'][1]:.0f} % per wall-second "
            f"(median {100 * float(np.median(wall)):.0f} %); / strict ceiling "
            f"{100 * best[name][0] / best['strict'][0]:.0f} % per CPU-second"
        )


if __name__ == "__main__":
    report()
