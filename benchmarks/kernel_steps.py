"""The compiled kernels' cost per step and per call, for every system but the 3D top.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/kernel_steps.py`` (about a minute on a warm
numba cache); ``--only TEXT`` keeps the systems whose label contains TEXT (``--only "Euler top"``:
the n-dimensional top's kernel, ``--only ball``); ``--against PATH`` measures another checkout
side by side (both in subprocesses with ``PYTHONPATH`` set to each tree, alternating for
``--rounds`` rounds; the table shows the least of each), ``--hog`` keeps one busy-looping process
running meanwhile.

For each system of ``benchmarks/systems_speed.py`` but the 3D top (which has its own kernel and
``benchmarks/single_call.py``) — the Euler top in 4 and 6 dimensions (the n-dimensional top's
kernel, :mod:`lieint.fast.topn`), the heavy top in 3 and 4, the ball with an offset centre of
mass on an incline, the Chaplygin ball in 3 and 4 (the generic kernel,
:mod:`lieint.fast.generic`) — and for RKMK6 in Cayley coordinates and RKMK4 in exponential
coordinates (h = 0.02, a single trajectory):

* ``per step``: the process CPU time of a call of 20,000 steps (one saved row) divided by the
  steps, the least of five calls — the compiled loop's cost, the Python around it spread thin;
* ``1-step call``: the least CPU time of a one-step call (the Python around the loop, its
  arguments and the check of the step), over 7 × 40 calls.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

SYSTEMS = (
    "Euler top n=4",
    "Euler top n=6",
    "heavy top n=3",
    "heavy top n=4",
    "offset ball on incline n=3",
    "Chaplygin ball n=3",
    "Chaplygin ball n=4",
)
METHODS = (("rkmk6", "cayley"), ("rkmk4", "exp"))
STEPS, H = 20_000, 0.02


def measure(only: str = "") -> dict[str, tuple[float, float]]:
    """``{"system method": (µs per step, µs per one-step call)}`` in this process, for the
    systems whose label contains ``only``."""
    sys.path.insert(0, str(Path(__file__).parent))
    from systems_speed import cases

    import lieint

    out = {}
    for label, system, y0, _ in cases():
        if label not in SYSTEMS or only not in label:
            continue
        for method, coordinates in METHODS:

            def call(steps, system=system, y0=y0, method=method, coordinates=coordinates):
                return lieint.integrate(
                    system, y0, (0.0, steps * H), h=H, save_every=steps, method=method, coordinates=coordinates
                )

            call(1)
            long = min(_cpu(lambda: call(STEPS)) for _ in range(5)) / STEPS
            short = min(_cpu(lambda: [call(1) for _ in range(40)]) / 40 for _ in range(7))
            out[f"{label} {method}[{coordinates}]"] = (1e6 * long, 1e6 * short)
    return out


def _cpu(fn) -> float:
    t0 = time.process_time()
    fn()
    return time.process_time() - t0


def _in_tree(tree: Path, only: str) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), OPENBLAS_NUM_THREADS="1")
    run = subprocess.run(
        [sys.executable, __file__, "--json", "--only", only], env=env, capture_output=True, text=True, check=True,
        cwd=tree,
    )  # fmt: skip
    return json.loads(run.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", type=Path, help="another checkout, measured side by side")
    parser.add_argument("--rounds", type=int, default=2, help="alternations with --against (default 2)")
    parser.add_argument("--hog", action="store_true", help="a CPU-bound process running meanwhile")
    parser.add_argument("--only", metavar="TEXT", default="", help="only the systems whose label contains TEXT")
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.json:
        print(json.dumps(measure(args.only)))
        return
    here = Path(__file__).resolve().parents[1]
    trees = [("this tree", here)] + ([(str(args.against), args.against.resolve())] if args.against else [])
    hog = subprocess.Popen([sys.executable, "-c", "while True: pass"]) if args.hog else None
    try:
        best: dict[str, dict] = {name: {} for name, _ in trees}
        for _ in range(args.rounds if args.against else 1):
            for name, tree in trees:
                for key, (step, call) in _in_tree(tree, args.only).items():
                    old = best[name].get(key, (float("inf"), float("inf")))
                    best[name][key] = (min(old[0], step), min(old[1], call))
    finally:
        if hog is not None:
            hog.kill()
    load = "with a CPU-bound process running" if args.hog else "idle"
    print(f"Compiled kernels, CPU µs, least over the rounds ({load}; load average {os.getloadavg()[0]:.2f})")
    head = f"{'system, method':<44s}" + "".join(f" {name[-22:]:>22s} step / call" for name, _ in trees)
    print(head)
    for key in best[trees[0][0]]:
        cells = "".join(f" {best[name][key][0]:22.2f} / {best[name][key][1]:5.0f}" for name, _ in trees)
        print(f"{key:<44s}{cells}")


if __name__ == "__main__":
    main()
