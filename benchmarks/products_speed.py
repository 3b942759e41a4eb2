"""The commutator-free and Crouch–Grossman methods per step: compiled, on the numpy path, and
against RKMK4 compiled, on the 3D top and the 3D heavy top.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/products_speed.py`` (a few seconds on a warm numba
cache); ``--hog`` keeps one busy-looping process running meanwhile (the ratios should hold on a
busy machine).

For ``cf3``, ``cf4``, ``cg3``, ``cg4a`` (products of exponentials,
:class:`lieint.fast.forms.ExpProductForm`) and ``rkmk4`` (the reference), h = 0.01, one trajectory
with its attitude, the systems of ``benchmarks/systems_speed.py``:

* ``compiled``: the process CPU time of a call of 20,000 steps (one saved row) over the steps,
  the least of five calls;
* ``numpy``: the same for ``backend="numpy"`` and 300 steps, the least of three calls;
* ``numpy / compiled`` and ``÷ rkmk4``: the compiled step's cost over RKMK4's compiled step
  (evaluations per step in the last column: RKMK4 spends four).

The calls alternate within a round, so a neighbour's load falls on all of them alike.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from systems_speed import cases, interleaved_cpu_min

import lieint

SYSTEMS = ("Euler top n=3", "heavy top n=3")
METHODS = ("rkmk4", "cf3", "cf4", "cg3", "cg4a")
H, COMPILED_STEPS, NUMPY_STEPS = 0.01, 20_000, 300


def measure() -> dict[str, dict[str, tuple[float, float, int]]]:
    """``{system: {method: (compiled µs/step, numpy µs/step, evaluations per step)}}``."""
    out: dict[str, dict[str, tuple[float, float, int]]] = {}
    for label, system, y0, _ in cases():
        if label not in SYSTEMS:
            continue
        calls, evals = [], {}
        for method in METHODS:
            for backend, steps in (("numba", COMPILED_STEPS), ("numpy", NUMPY_STEPS)):

                def call(system=system, y0=y0, method=method, backend=backend, steps=steps):
                    return lieint.integrate(
                        system, y0, (0.0, steps * H), h=H, save_every=steps, method=method, backend=backend
                    )

                sol = call()  # compiled (or loaded) once, and checked
                assert sol.stats.backend == backend, (label, method, sol.stats.backend_reason)
                evals[method] = sol.nfev // steps
                calls.append(call)
        best = interleaved_cpu_min(calls, 5)
        out[label] = {
            method: (1e6 * best[2 * i] / COMPILED_STEPS, 1e6 * best[2 * i + 1] / NUMPY_STEPS, evals[method])
            for i, method in enumerate(METHODS)
        }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hog", action="store_true", help="a CPU-bound process running meanwhile")
    args = parser.parse_args()
    hog = subprocess.Popen([sys.executable, "-c", "while True: pass"]) if args.hog else None
    try:
        table = measure()
    finally:
        if hog is not None:
            hog.kill()
    load = "with a CPU-bound process running" if args.hog else "idle"
    print(f"CPU µs per step, least of 5 calls ({load}; load average {os.getloadavg()[0]:.2f})")
    head = ("system", "method", "compiled", "numpy", "numpy/compiled", "÷ rkmk4", "evals")
    print("{:<16s} {:<7s} {:>9s} {:>9s} {:>15s} {:>8s} {:>5s}".format(*head))
    for label, rows in table.items():
        reference = rows["rkmk4"][0]
        for method, (fast, slow, evals) in rows.items():
            ratios = f"{slow / fast:15.0f} {fast / reference:8.2f} {evals:5d}"
            print(f"{label:<16s} {method:<7s} {fast:9.3f} {slow:9.1f} {ratios}")


if __name__ == "__main__":
    main()
