"""CPU time at equal achieved global error: the default adaptive method against scipy's DOP853 on a
lean right-hand side, side by side in one run.

The default adaptive method is ``rkmk853+energy`` (compiled on every built-in system); the
baseline ``solve_ivp(DOP853)`` on the equations written out in numpy
(``benchmarks/lean_rhs.py``, checked against ``system.vector_field`` first), R projected onto
SO(n) at the end as a user would. The problems of ``benchmarks/adaptive_systems.py``: the free top
near its unstable axis (the default scene's motion, with R, T = 100; exact solution), the fast
heavy top (T = 10), the offset and the Chaplygin ball (T = 10) and the 4D top (T = 20; reference
DOP853 at rtol 1e-14). The error of a run is its global error at T
over the whole state, ``‖y(T) − y_ref(T)‖₂ / ‖y_ref(T)‖₂``. Each series is swept over rtol
(atol = 1e-3·rtol, half decades from 1e-3 to 1e-14); for each target error the loosest rtol of each series that
reaches it is timed — process CPU time of the whole call, the minimum over repeats.

    OPENBLAS_NUM_THREADS=1 python benchmarks/adaptive_lean.py [--hog] [--quick] [--problems "heavy top,4D top"]

``--hog`` keeps one busy-looping process running meanwhile (the machine busy); the load average
is printed.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

import adaptive_systems
import lean_rhs
import numpy as np
from scipy.integrate import solve_ivp

import lieint
from lieint.groups import project_to_so

TARGETS = (1e-6, 1e-8, 1e-10)
METHOD = "rkmk853+energy"
PROBLEMS = ("free top", "heavy top", "offset ball", "Chaplygin ball", "4D top")


def cpu_min(fn, repeats: int, budget: float = 0.25) -> float:
    """The least CPU time of ``repeats`` calls, or of as many more as fit in ``budget`` seconds
    (at most 400): a short call's least time keeps falling with the repeats on a shared machine."""
    best = float("inf")
    spent, done = 0.0, 0
    while done < repeats or (spent < budget and done < 400):
        t0 = time.process_time()
        fn()
        took = time.process_time() - t0
        best = min(best, took)
        spent += took
        done += 1
    return best


def problem_runs(label):
    system, y0, T = adaptive_systems.problems()[label]
    truth = adaptive_systems.Truth(system, y0, T)
    end = truth.flow(y0, T)
    rhs = lean_rhs.lean_rhs(system)
    z0 = lean_rhs.flatten(system, y0)
    slices = {}
    start = 0
    for name, shape in system.fields.items():
        slices[name] = slice(start, start + int(np.prod(shape)))
        start += int(np.prod(shape))

    def error(z):
        return float(np.linalg.norm(z - end) / np.linalg.norm(end))

    def lie(rtol):
        sol = lieint.integrate(system, y0, (0.0, T), method=METHOD, rtol=rtol, atol=1e-3 * rtol)
        return error(lean_rhs.flatten(system, {k: v[-1] for k, v in sol.states.items()})), sol.nsteps, sol

    def dop(rtol):
        sol = solve_ivp(rhs, (0.0, T), z0, method="DOP853", rtol=rtol, atol=1e-3 * rtol)
        z = sol.y[:, -1].copy()
        if "R" in slices:  # onto SO(n), as a user would
            n = system.n
            z[slices["R"]] = project_to_so(z[slices["R"]].reshape(n, n)).ravel()
        return error(z), sol.t.size - 1, sol

    return system, T, lie, dop


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hog", action="store_true", help="a CPU-bound process running meanwhile")
    parser.add_argument("--quick", action="store_true", help="fewer settings and repeats")
    parser.add_argument("--problems", default=",".join(PROBLEMS), help="comma-separated problem names")
    args = parser.parse_args()
    labels = [label.strip() for label in args.problems.split(",") if label.strip()]
    unknown = sorted(set(labels) - set(PROBLEMS))
    if unknown:
        parser.error(f"--problems: unknown {unknown}; choose from {list(PROBLEMS)}")
    hog = subprocess.Popen([sys.executable, "-c", "while True: pass"]) if args.hog else None
    try:
        run(args.quick, args.hog, labels)
    finally:
        if hog is not None:
            hog.kill()
            hog.wait()


def run(quick: bool, hogging: bool, labels=PROBLEMS) -> None:
    rtols = [10.0 ** (-k / 2) for k in range(6, 29)]  # 1e-3 … 1e-14
    if quick:
        rtols = rtols[::2]
    # the least of 25 calls: a call of 0.2 ms still got cheaper past 7 (the 4D top's lieint run:
    # 0.257 / 0.206 / 0.205 ms at 7 / 50 / 200 repeats; DOP853's 1.05 / 1.02 / 1.02 ms)
    reps = 3 if quick else 25
    for label in labels:
        _, T, lie, dop = problem_runs(label)
        first = lie(1e-8)[2]  # compiles (or loads) the kernels; says which path runs
        lie_rows = [(rtol, *lie(rtol)[:2]) for rtol in rtols]
        dop_rows = [(rtol, *dop(rtol)[:2]) for rtol in rtols]
        time.sleep(0.5)
        load = os.getloadavg()[0]
        beside = "with a busy-looping process" if hogging else "no busy-looping process"
        print(f"\n{label}, T = {T:g} ({beside}; load average {load:.2f})")
        print(f"{METHOD}: {first.stats.backend_reason}")
        print("| target | series | rtol | steps | error at T | CPU [ms] | × DOP853 |")
        print("|---|---|---|---|---|---|---|")
        for target in TARGETS:
            picks = []
            for name, rows, fn in ((METHOD, lie_rows, lie), ("scipy DOP853 (lean rhs)", dop_rows, dop)):
                ok = [r for r in rows if r[1] <= target]
                if not ok:
                    picks.append((name, None))
                    continue
                rtol, err, steps = max(ok, key=lambda r: r[0])
                picks.append((name, (rtol, steps, err, cpu_min(lambda fn=fn, rtol=rtol: fn(rtol), reps))))
            base = picks[1][1][3] if picks[1][1] else None
            for name, row in picks:
                if row is None:
                    print(f"| {target:.0e} | {name} | — | — | not reached | — | — |")
                    continue
                rtol, steps, err, cpu = row
                ratio = f"{cpu / base:.3f}" if base else "—"
                print(f"| {target:.0e} | {name} | {rtol:.1e} | {steps} | {err:.2e} | {1e3 * cpu:.2f} | {ratio} |")


if __name__ == "__main__":
    main()
