"""What the tangent map costs: a run with k tangent vectors against the plain run, side by side.

``OPENBLAS_NUM_THREADS=1 python benchmarks/tangent_cost.py [--steps 2000] [--hog]`` times, one
body each, CPU time of whole calls (the least of several, alternating between the series):

* the plain run, ``lieint.integrate`` (compiled);
* ``lieint.tangent_flow`` with k = 1, 3 and the whole dimension of tangent vectors, on the path
  it takes by itself (``backend="auto"``: compiled where the method's tangent steps are, the
  generic path's complex step elsewhere), and the ratio to the plain run beside the issue's
  bound ``2 (1 + k)``;
* ``lieint.lyapunov`` (every exponent, a QR every 10 steps) and ``lieint.megno`` likewise.

The cases: the free 3D top with ``moser_veselov``, ``splitting2`` and ``rkmk4``, the heavy top
with and without attitude, the Chaplygin ball, the 4D top and the rolling ball with an offset
centre of mass (gravity along the normal, and on an incline) with ``rkmk4``, all with compiled
tangent steps; the last column says where each ran. ``--hog`` keeps one busy-looping
process running meanwhile (the machine busy); the load average is printed.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from functools import partial

import numpy as np

import lieint


def _cpu_min(fns, repeats: int) -> list[float]:
    """The least CPU time of each call over ``repeats`` rounds, the calls alternating."""
    best = [np.inf] * len(fns)
    for _ in range(repeats):
        for i, fn in enumerate(fns):
            start = time.process_time()
            fn()
            best[i] = min(best[i], time.process_time() - start)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--hog", action="store_true", help="a CPU-bound process running meanwhile")
    args = parser.parse_args()
    hog = subprocess.Popen([sys.executable, "-c", "while True: pass"]) if args.hog else None
    try:
        run(args.steps, args.hog)
    finally:
        if hog is not None:
            hog.kill()
            hog.wait()


def _calls(system, y0, method, span, h):
    """(run, k, call) of every series timed for one case: the plain run first."""
    dim = lieint.tangent.chart_of(system).dim
    out = [("integrate", 0, partial(lieint.integrate, system, y0, span, h=h, method=method))]
    for k in sorted({1, 3, dim}):
        out.append(("tangent_flow", k, partial(lieint.tangent_flow, system, y0, span, h=h, method=method,
                                               vectors=np.eye(dim)[:k])))  # fmt: skip
    out.append(("lyapunov", dim, partial(lieint.lyapunov, system, y0, span, h, method)))
    out.append(("megno", 1, partial(lieint.megno, system, y0, span, h, method, save_every=100)))
    return out


def run(steps: int, hogging: bool) -> None:
    h = 0.01
    T = steps * h
    heavy = lieint.HeavyTop(lieint.EulerTop.from_principal_moments([1.0, 1.5, 2.0]).B, 1.0, [0.1, 0.05, 0.08],
                            [0.0, 0.0, -9.81])  # fmt: skip
    flat = lieint.HeavyTop(lieint.EulerTop.from_principal_moments([1.0, 1.5, 2.0]).B, 1.0, [0.1, 0.05, 0.08],
                           [0.0, 0.0, -9.81], orientation=False)  # fmt: skip
    ball = lieint.ChaplyginBall(np.diag([0.08, 0.12, 0.16]), 1.0, 1.0)
    top4 = lieint.EulerTop(np.diag([0.6, 0.8, 1.0, 1.3]))
    W = np.arange(16.0).reshape(4, 4) / 15.0
    rolling = lieint.RollingBall(np.diag([0.1, 0.15, 0.2]), 1.0, 1.0, [0.0, 0.1, -0.2], [0.0, 0.0, -9.81])
    tilted = 9.81 * np.array([np.sin(0.3), 0.0, -np.cos(0.3)])
    incline = lieint.RollingBall(np.diag([0.1, 0.15, 0.2]), 1.0, 1.0, [0.0, 0.1, -0.2], tilted)
    free = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    cases = [
        ("free top", free, free.initial_state(angular_velocity=[1.0, 0.3, 0.2]), "moser_veselov"),
        ("free top", free, free.initial_state(angular_velocity=[1.0, 0.3, 0.2]), "splitting2"),
        ("free top", free, free.initial_state(angular_velocity=[1.0, 0.3, 0.2]), "rkmk4"),
        ("heavy top", heavy, heavy.initial_state(angular_velocity=[1.0, 2.0, 1.5]), "rkmk4"),
        ("heavy top, no R", flat, flat.initial_state(angular_velocity=[1.0, 2.0, 1.5]), "rkmk4"),
        ("Chaplygin ball", ball, ball.initial_state(angular_velocity=[0.3, 1.0, 0.4]), "rkmk4"),
        ("4D top", top4, top4.initial_state(Omega=0.3 * (W - W.T)), "rkmk4"),
        ("offset ball", rolling, rolling.initial_state(angular_velocity=[0.3, 1.0, 0.4]), "rkmk4"),
        ("offset ball on an incline", incline, incline.initial_state(angular_velocity=[0.3, 1.0, 0.4]), "rkmk4"),
    ]
    time.sleep(0.5)
    beside = "with a busy-looping process" if hogging else "no busy-looping process"
    load = os.getloadavg()[0]
    print(f"{steps} steps of h = {h:g}; CPU time, least of the repeats ({beside}; load average {load:.2f})")
    print("| system | method | run | k | CPU [ms] | × plain | bound 2(1+k) | tangent steps on |")
    print("|---|---|---|---|---|---|---|---|")
    for label, system, y0, method in cases:
        calls = _calls(system, y0, method, (0.0, T), h)
        results = [fn() for _, _, fn in calls]  # compiles (or loads) every kernel first
        compiled = lieint.tangent.flow.tangent_backend(system, method).startswith("compiled")
        # the generic path's calls take seconds: once each (the plain run always 7 times)
        times = _cpu_min([fn for _, _, fn in calls], 7 if compiled else 1)
        times[0] = min(times[0], _cpu_min([calls[0][2]], 7)[0])
        base = times[0]
        for (kind, k, _), cpu, result in zip(calls, times, results, strict=True):
            if kind == "integrate":
                print(f"| {label} | {method} | integrate | — | {1e3 * cpu:.2f} | 1 | — | {result.stats.backend} |")
                continue
            where = "compiled" if result.backend_reason.startswith("compiled") else "generic (complex step)"
            ratio = cpu / base
            print(f"| {label} | {method} | {kind} | {k} | {1e3 * cpu:.2f} | {ratio:.1f} | {2 * (1 + k)} | {where} |")


if __name__ == "__main__":
    main()
