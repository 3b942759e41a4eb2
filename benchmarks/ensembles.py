"""CPU time per body-step of ensembles of 1, 16 and 1,000 bodies, every built-in rigid system.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/ensembles.py`` (about a minute on a warm numba
cache); ``--hog`` measures everything a second time while another CPU-bound process runs and
prints both side by side; ``--only TEXT`` keeps the systems whose label contains TEXT
(``--only heavy``); ``--sizes 1,2,8,16`` other ensemble sizes.

For each system of ``benchmarks/systems_speed.py`` (the Euler top in 3, 4 and 6 dimensions, the
heavy top in 3 and 4, the ball with an offset centre of mass on an incline, the Chaplygin ball in
3 and 4), RKMK4 in exponential coordinates with that file's step (T/2000), fixed steps, one
saved row, numba's default threads: an ensemble of N bodies (the system's initial state, its
momentum spread by 1 %) in one ``lieint.integrate`` call of about 200,000 body-steps (at least
100 steps). The figure is the process CPU time of the whole call (every thread, the Python
around the loop included) divided by the body-steps, the least of three calls, in ns; the
ratios are against one body in the same pass. The issue's target: 16 bodies ≤ 0.6× one body,
1,000 bodies ≤ 0.3×. The back end of each size is printed (``lanes``: an ensemble kernel in SIMD
lanes; ``per body``: the per-body loop, threads over bodies).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

WORK = 200_000  # body-steps per call
MIN_STEPS = 100


def ensemble(system, y0, N: int, rng) -> dict:
    """N copies of ``y0`` with the momentum (``Omega`` or ``A``) spread by 1 % (kept skew)."""
    field = "Omega" if "Omega" in y0 else "A"
    batch = {k: np.broadcast_to(v, (N, *np.shape(v))).copy() for k, v in y0.items()}
    noise = rng.normal(size=batch[field].shape) * 0.01 * np.max(np.abs(y0[field]))
    batch[field] = batch[field] + noise - np.swapaxes(noise, -1, -2)
    return batch


def measure(only: str, sizes: list[int]) -> list[tuple[str, dict]]:
    """``[(label, {N: (ns per body-step, back end)})]`` in this process."""
    from systems_speed import cases

    import lieint

    rng = np.random.default_rng(3)
    out = []
    for label, system, y0, T in cases():
        if only not in label:
            continue
        h = T / 2000
        row = {}
        for N in sizes:
            batch = ensemble(system, y0, N, rng) if N > 1 else y0
            steps = max(MIN_STEPS, WORK // N)

            def call(system=system, batch=batch, h=h, steps=steps):
                return lieint.integrate(system, batch, (0.0, steps * h), h=h, method="rkmk4", save_every=steps)

            reason = call().stats.backend_reason  # compiled and cached outside the timing
            best = float("inf")
            for _ in range(3):
                c0 = time.process_time()
                call()
                best = min(best, time.process_time() - c0)
            kind = "lanes" if "SIMD lanes" in reason else ("per body" if "compiled" in reason else "numpy")
            row[N] = (1e9 * best / (N * steps), kind)
        out.append((label, row))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hog", action="store_true", help="also measure with a CPU-bound process running")
    parser.add_argument("--only", metavar="TEXT", default="", help="only the systems whose label contains TEXT")
    parser.add_argument("--sizes", default="1,16,1000", help="ensemble sizes, comma-separated (default 1,16,1000)")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    import numba

    print(f"numba threads: {numba.get_num_threads()}, cores: {os.cpu_count()}, RKMK4, ~{WORK:,} body-steps a call")
    passes = [("idle", measure(args.only, sizes), os.getloadavg()[0])]
    if args.hog:
        hog = subprocess.Popen([sys.executable, "-c", "while True: pass"])
        try:
            time.sleep(1.0)
            passes.append(("hog", measure(args.only, sizes), os.getloadavg()[0]))
        finally:
            hog.kill()
    for name, _, load in passes:
        print(f"{name}: load average {load:.2f} after the pass")
    head = f"{'system':<27s}"
    for name, _, _ in passes:
        head += "".join(f" {f'{name} N={N}':>12s}" for N in sizes) + "".join(f" {f'{N}/1':>7s}" for N in sizes[1:])
    print("CPU ns per body-step (ratio to one body)")
    print(head + "  back end by size")
    for i, (label, _) in enumerate(passes[0][1]):
        line = f"{label:<27s}"
        for _, rows, _ in passes:
            row = rows[i][1]
            line += "".join(f" {row[N][0]:12.0f}" for N in sizes)
            line += "".join(f" {row[N][0] / row[sizes[0]][0]:7.2f}" for N in sizes[1:])
        kinds = "/".join(passes[0][1][i][1][N][1] for N in sizes)
        print(f"{line}  {kinds}")


if __name__ == "__main__":
    main()
