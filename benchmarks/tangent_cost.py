"""What the tangent map costs: a run with k tangent vectors against the plain run, side by side.

``python benchmarks/tangent_cost.py [--steps 2000]`` times, for the 3D heavy top (rkmk4,
h = 0.01) and the 3D free top (moser_veselov, splitting2), one body:

* the plain run, compiled (``lieint.integrate``, the engine) and generic (``backend="numpy"``);
* ``lieint.tangent_flow`` with k = 1, 3 and the whole dimension of tangent vectors;
* a batch of 12 bodies with k = 1 (``lieint.megno``), per body.

The tangent map runs on the generic path (complex copies; the compiled kernels are real), so
the ratio to the compiled plain run is what a user pays today. Prints the load average.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import lieint


def _best(fn, repeat: int = 3) -> float:
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000)
    args = parser.parse_args()
    h = 0.01
    T = args.steps * h
    heavy = lieint.HeavyTop(lieint.EulerTop.from_principal_moments([1.0, 1.5, 2.0]).B, 1.0, [0.1, 0.05, 0.08],
                            [0.0, 0.0, -9.81])  # fmt: skip
    free = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    cases = [
        ("heavy top, rkmk4", heavy, heavy.initial_state(angular_velocity=[1.0, 2.0, 1.5]), "rkmk4"),
        ("free top, moser_veselov", free, free.initial_state(angular_velocity=[1.0, 0.3, 0.2]), "moser_veselov"),
        ("free top, splitting2", free, free.initial_state(angular_velocity=[1.0, 0.3, 0.2]), "splitting2"),
    ]
    print(f"load average {os.getloadavg()[0]:.2f}; {args.steps} steps of h = {h:g}; best of 3, seconds")
    for name, system, y0, method in cases:
        lieint.integrate(system, y0, (0.0, 10 * h), h=h, method=method)  # compile / warm up
        plain = _best(lambda s=system, y=y0, m=method: lieint.integrate(s, y, (0.0, T), h=h, method=m))
        generic = _best(lambda s=system, y=y0, m=method: lieint.integrate(s, y, (0.0, T), h=h, method=m,
                                                                          backend="numpy"))  # fmt: skip
        dim = lieint.tangent.chart_of(system).dim
        row = f"{name:24s} plain {plain:.3f} (compiled: {plain < generic}), generic {generic:.3f}"
        for k in (1, 3, dim):
            V = np.eye(dim)[:k]
            cost = _best(lambda s=system, y=y0, m=method, V=V: lieint.tangent_flow(s, y, (0.0, T), h=h, method=m,
                                                                                   vectors=V))  # fmt: skip
            row += f" | k={k}: {cost:.2f} s = {cost / plain:.0f}× plain, {cost / generic:.1f}× generic"
        print(row, flush=True)
    bodies = 12
    rng = np.random.default_rng(1)
    batch = heavy.initial_state(angular_velocity=rng.normal(size=(bodies, 3)) * 2.0)
    one = _best(lambda: lieint.megno(heavy, heavy.initial_state(angular_velocity=[1.0, 2.0, 1.5]), (0.0, T), h=h), 1)
    many = _best(lambda: lieint.megno(heavy, batch, (0.0, T), h=h), 1)
    print(f"MEGNO, heavy top: one body {one:.2f} s, {bodies} bodies {many:.2f} s ({many / bodies:.3f} s a body)")


if __name__ == "__main__":
    main()
