"""The trust horizon of free-top runs near the separatrix against the time their h and h/4 runs part.

For the 3D free top (moments 1, 2, 3) at relative distances δ from the separatrix, a method at
step h (rkmk4; Moser–Veselov, splitting2, the midpoint rule): ``lieint.trust_horizon`` (local
errors by step doubling, carried by the exact tangent map) reports when the estimated global
error exceeds the tolerance; the truth is the first grid time at which two ``lieint.integrate``
runs at h and h/4 differ by more than it (largest entry of A or R). Also the cost of the
estimate against a plain run on the same (generic numpy) path.
``python benchmarks/trust_horizon.py [--tol 1e-3]``. Prints the load average.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import lieint


def near_separatrix(delta, y=1.0, z=0.3):
    """w with ``(G² − 2E I₂)/(2E I₂) ≈ delta`` for I = (1, 2, 3)."""
    x = np.sqrt((3 * z * z - 2 * delta * (2 * y * y + 3 * z * z)) / (1 + 2 * delta))
    return [x, y, z]


CASES = [  # (label, w, method, h, T)
    ("δ = 1e-2", near_separatrix(1e-2), "rkmk4", 0.1, 150.0),
    ("δ = 1e-3", near_separatrix(1e-3), "rkmk4", 0.1, 60.0),
    ("δ = 1e-3", near_separatrix(1e-3), "rkmk4", 0.05, 250.0),
    ("δ = 1e-4", near_separatrix(1e-4), "rkmk4", 0.05, 100.0),
    ("w = (0.3, 1, 0.4)", [0.3, 1.0, 0.4], "rkmk4", 0.1, 200.0),
    ("δ = 1e-3", near_separatrix(1e-3), "moser_veselov", 0.02, 15.0),
    ("δ = 1e-3", near_separatrix(1e-3), "splitting2", 0.02, 8.0),
    ("δ = 1e-3", near_separatrix(1e-3), "lie_midpoint", 0.02, 30.0),
]


def parting(top, y0, T, h, method, tol):
    a = lieint.integrate(top, y0, (0.0, T), h=h, method=method)
    b = lieint.integrate(top, y0, (0.0, T), h=h / 4, method=method, t_eval=a.t)
    d = np.max([np.abs(a.states[k] - b.states[k]).reshape(len(a.t), -1).max(axis=1) for k in ("A", "R")], axis=0)
    return a.t[np.argmax(d > tol)] if d.max() > tol else np.inf


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tol", type=float, default=1e-3)
    args = parser.parse_args()
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    print(f"load average {os.getloadavg()[0]:.2f}; tolerance {args.tol:g}")
    print("| motion | method | h | horizon | h, h/4 runs part | ratio | cost / plain numpy run |")
    print("|---|---|---|---|---|---|---|")
    for label, w, method, h, T in CASES:
        y0 = top.initial_state(angular_velocity=w)
        start = time.perf_counter()
        run = lieint.trust_horizon(top, y0, (0.0, T), h=h, method=method, tolerance=args.tol)
        cost = time.perf_counter() - start
        start = time.perf_counter()
        lieint.integrate(top, y0, (0.0, T), h=h, method=method, backend="numpy")
        plain = time.perf_counter() - start
        truth = parting(top, y0, T, h, method, args.tol)
        ratio = run.horizon / truth
        print(f"| {label} | {method} | {h:g} | {run.horizon:.2f} | {truth:.2f} | {ratio:.2f} | {cost / plain:.1f} |")


if __name__ == "__main__":
    main()
