"""What dense output, events and ``t_eval`` cost on the compiled engine, against the same run
without them (CPU time, side by side in one process).

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/front_ends.py`` (about a minute on a warm numba
cache; ``--hog`` keeps one busy-looping process running meanwhile, ``--rounds N``).

For the 3D top (RKMK4, h = 0.01, T = 100: 10⁴ steps, the flip times of the Dzhanibekov motion),
the heavy top and the Chaplygin ball (RKMK4, h = 0.01, T = 100), each run once plain and once with

* one event function (the sign of a momentum component; vectorised, as written below, so the
  engine evaluates it on every step's row at once),
* the same event written for one row only (``float(y["A"][0, 2])``: called row by row),
* ``dense_output=True`` (the interpolants are built when asked for: the run keeps its steps),
* ``t_eval`` of 100 times,

the least CPU time over the rounds and its ratio to the plain run. Every run reports its back end
(``compiled`` in every row: none leaves the engine).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

import numpy as np

import lieint


def cases():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    heavy = lieint.HeavyTop(np.diag([1.0, 2.0, 3.0]), 1.0, [0.0, 0.1, 0.3], [0.0, 0.0, -9.81])
    ball = lieint.ChaplyginBall(np.diag([0.1, 0.12, 0.15]), 1.0, 1.0)
    return [
        ("3D top", top, top.initial_state(angular_velocity=[0.01, 1.0, 0.01])),
        ("heavy top", heavy, heavy.initial_state(angular_velocity=[0.3, 1.0, 0.2])),
        ("Chaplygin ball", ball, ball.initial_state(angular_velocity=[0.3, 1.0, 0.2])),
    ]


def vectorised(t, y):
    return y["A"][..., 0, 2]


def one_row(t, y):
    return float(y["A"][0, 2])


def variants(T):
    return {
        "plain": {},
        "event (vectorised)": {"events": vectorised},
        "event (one row)": {"events": one_row},
        "dense output": {"dense_output": True},
        "t_eval (100 times)": {"t_eval": np.linspace(0.0, T, 100)},
    }


def _cpu(fn):
    t0 = time.process_time()
    result = fn()
    return time.process_time() - t0, result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--hog", action="store_true", help="a CPU-bound process running meanwhile")
    args = parser.parse_args()
    T, h = 100.0, 0.01
    hog = subprocess.Popen([sys.executable, "-c", "while True: pass"]) if args.hog else None
    try:
        rows = []
        for label, system, y0 in cases():
            for kw in variants(1.0).values():  # warm-up: compile, first calls
                lieint.integrate(system, y0, (0.0, 1.0), h=h, method="rkmk4", **kw)
            best, backends = {}, {}
            for _ in range(args.rounds):
                for name, kw in variants(T).items():
                    run = lambda kw=kw, s=system, y=y0: lieint.integrate(s, y, (0.0, T), h=h, method="rkmk4", **kw)  # noqa: E731
                    cpu, sol = _cpu(run)
                    best[name] = min(best.get(name, np.inf), cpu)
                    backends[name] = "compiled" if sol.stats.backend == "numba" else sol.stats.backend
            for name in best:
                rows.append((label, name, best[name], best[name] / best["plain"], backends[name]))
    finally:
        if hog is not None:
            hog.kill()
    load = "with a CPU-bound process running" if args.hog else "idle"
    load_now = os.getloadavg()[0]
    print(f"RKMK4, h = {h}, T = {T:g} (10^4 steps), CPU ms, least of {args.rounds} ({load}; load {load_now:.2f})")
    print(f"{'system':16} {'front end':22} {'CPU ms':>9} {'× plain':>8}  back end")
    for label, name, cpu, ratio, backend in rows:
        print(f"{label:16} {name:22} {1e3 * cpu:9.2f} {ratio:8.2f}  {backend}")


if __name__ == "__main__":
    main()
