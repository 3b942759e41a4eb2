"""Tolerance proportionality of the adaptive pairs: global error / rtol, lieint's pairs beside scipy's.

The 3D Euler top, I = (1, 2, 3), atol = 1e-3·rtol; error = max over the accepted steps of
|A − A_exact|_F / |A₀|_F (Jacobi elliptic solution). Two cases: a generic motion
(ω₀ = (0.3, 0.5, 1), T = 100) and the Dzhanibekov top near the separatrix
(ω₀ = (0.01, 1, 0.01), T = 60). Each row prints error/rtol and the accepted steps of every pair.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/adaptive_rtol.py [--quick]

``--quick`` runs rtol 1e-4 … 1e-8 only (the rkmk23 rows at 1e-9 and 1e-10 take ~10⁵ steps).
"""

from __future__ import annotations

import sys

import numpy as np

import lieint

PAIRS = [("rkmk23", "scipy:RK23"), ("rkmk45", "scipy:RK45"), ("rkmk853", "scipy:DOP853")]
CASES = {
    "generic (0.3, 0.5, 1), T = 100": ([0.3, 0.5, 1.0], 100.0),
    "separatrix (0.01, 1, 0.01), T = 60": ([0.01, 1.0, 0.01], 60.0),
}


def ratio(top, y0, T, method, rtol):
    sol = lieint.integrate(top, y0, (0.0, T), method=method, rtol=rtol, atol=1e-3 * rtol)
    exact = top.exact_solution(sol.t, y0)["A"]
    err = np.max(np.linalg.norm(sol.states["A"] - exact, axis=(-2, -1))) / np.linalg.norm(y0["A"])
    return err / rtol, sol.stats.nsteps


def main(quick: bool) -> None:
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    rtols = [10.0**-k for k in range(4, 9 if quick else 11)]
    for label, (w0, T) in CASES.items():
        y0 = top.initial_state(angular_velocity=w0)
        print(f"\n{label}: global error / rtol (accepted steps)")
        print("rtol    " + "".join(f"{m:>22}" for pair in PAIRS for m in pair))
        for rtol in rtols:
            cells = []
            for pair in PAIRS:
                for m in pair:
                    r, n = ratio(top, y0, T, m, rtol)
                    cells.append(f"{r:>13.3g} ({n:>6})")
            print(f"{rtol:<8.0e}" + "".join(cells), flush=True)


if __name__ == "__main__":
    main("--quick" in sys.argv)
