"""Long-time behaviour of the energy-preserving methods against RKMK4, over 10⁶ steps.

Run: ``python benchmarks/long_time.py`` (10⁶ steps per run: long, tens of minutes on a busy
machine; ``--steps 100000`` for a shorter study, ``--quick`` for a smoke run of 10⁴ steps).

For each body — the 3D top (moments 1, 2, 3), the 4D top (``b = 0.5, 0.9, 1.3, 2.0``), the
3D heavy top — and each method it applies to, one run of N steps saves every state; printed:

* the relative energy error ``e(t) = max_{s ≤ t} |H(s) − H(0)|/|H(0)|`` (s over every step) at
  the end and its *growth exponent*: the least-squares slope of ``log e`` against ``log t``
  over the last three decades of the run (``t ≥ t_N/1000``). Bounded errors give ≈ 0, a linear
  drift 1, a random walk of round-off 0.5 — the last is what methods that keep the energy
  exactly show (their error stays at 1e-13 … 1e-12, far below the others). Beside it, the
  same fit on 2000 evenly spaced states only ("sparse"): the maximum of a bounded oscillation
  over a sample that grows with t keeps rising as more samples fall near its peaks, so the
  sparse fit reads a positive exponent from a bounded error — on the chaotic heavy top, whose
  peaks come at irregular times, splitting2 gives 0.14 sparse against 0.01 every step;
* the Casimir drift (rotation angles of A, heavy top its Casimirs of se(3)*), and for the
  Moser–Veselov runs in n = 4 and 6 the Manakov integrals;
* the split comparison of the 3D top (Fassò 2003): ``splitting2`` with each order of the axes;
* the run time of each (one run each, side by side: ratios only within this run);
* first, the Moser–Veselov methods with modified moments (orders 4, 6, 8) against plain MV
  at equal steps (``--equal-cost-only`` prints just that table).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import lieint


def growth_exponent(t: np.ndarray, err: np.ndarray, decades: float = 3.0) -> float:
    """Slope of ``log max_{s≤t} err(s)`` against ``log t`` over the last ``decades`` of t.

    The running maximum is over the samples given: pass every step, since on a sparse sample
    the maximum of a bounded oscillation still climbs as samples accumulate near its peaks.
    """
    running = np.maximum.accumulate(np.abs(err))
    keep = (t >= t[-1] / 10.0**decades) & (running > 0) & (t > 0)
    return float(np.polyfit(np.log(t[keep]), np.log(running[keep]), 1)[0])


def bodies():
    top3 = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    top4 = lieint.EulerTop(np.diag([0.5, 0.9, 1.3, 2.0]))
    heavy = lieint.HeavyTop(np.diag([0.5, 1.0, 1.5]), 1.0, [0.0, 0.1, 0.3], [0.0, 0.0, -9.81])
    X = np.array([[0, 0.4, -0.3, 0.2], [0, 0, 0.7, -0.5], [0, 0, 0, 0.6], [0, 0, 0, 0]])
    return {
        "top3": (top3, top3.initial_state(angular_velocity=[0.3, 1.0, 0.4]), 0.05),
        "top4": (top4, top4.initial_state(Omega=X - X.T), 0.05),
        "heavy3": (heavy, heavy.initial_state(angular_velocity=[0.3, 1.0, 0.4]), 0.01),
    }


METHODS = ["rkmk4", "lie_midpoint", "moser_veselov", "splitting2", "splitting4"]


def run(system, y0, h, method, steps):
    """One run saving every step (the energy error's maximum is over all of them)."""
    t0 = time.perf_counter()
    sol = lieint.integrate(system, y0, (0.0, steps * h), h=h, method=method)
    seconds = time.perf_counter() - t0
    H = system.evaluate_invariants(sol.t, sol.states, ["energy"])["energy"]
    err = (H - H[0]) / abs(H[0])
    return sol, err, seconds


def sparse(steps: int) -> slice:
    """The 2000 evenly spaced states an earlier version of this study saved."""
    return slice(None, None, max(steps // 2000, 1))


def equal_cost():
    """MV against the modified-moment MV of orders 4, 6, 8, 10 (McLachlan–Zanna, Hairer–Vilmart) at
    equal steps: error of (A, R) at T = 20 against the exact flow, solver iterations, seconds."""
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    T = 20.0
    exact = top.exact_solution([T], y0)
    print("Moser–Veselov at equal cost: max error of A and R at T = 20 (3D top), Newton iterations, seconds")
    names = ("moser_veselov", "moser_veselov4", "moser_veselov6", "moser_veselov8", "moser_veselov10")
    print(f"{'h':>7s} " + " ".join(f"{n:>26s}" for n in names))
    for h in (0.2, 0.1, 0.05):
        cells = []
        for name in names:
            t0 = time.perf_counter()
            sol = lieint.integrate(top, y0, (0.0, T), h=h, method=name)
            seconds = time.perf_counter() - t0
            err = max(float(np.max(np.abs(sol.states[k][-1] - exact[k][-1]))) for k in ("A", "R"))
            cells.append(f"{err:9.1e} {sol.stats.nfev:6d} it {seconds:5.2f} s")
        print(f"{h:7.3g} " + " ".join(f"{c:>26s}" for c in cells), flush=True)
    print()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1_000_000)
    parser.add_argument("--quick", action="store_true", help="10⁴ steps")
    parser.add_argument("--bodies", nargs="*", default=None, help="top3 top4 heavy3")
    parser.add_argument("--methods", nargs="*", default=None)
    parser.add_argument("--manakov-steps", type=int, default=None, help="steps of the n = 4, 6 runs (default: --steps)")
    parser.add_argument("--equal-cost-only", action="store_true", help="only the Moser–Veselov equal-cost table")
    args = parser.parse_args(argv)
    equal_cost()
    if args.equal_cost_only:
        return
    steps = 10_000 if args.quick else args.steps
    print(f"{steps:,} steps per run\n")
    print(
        f"{'body':7s} {'method':22s} {'h':>6s} {'energy err':>11s} {'growth':>7s} {'sparse':>7s} "
        f"{'Casimirs':>9s} {'s':>8s}"
    )
    for name, (system, y0, h) in bodies().items():
        if args.bodies and name not in args.bodies:
            continue
        for method in args.methods or METHODS:
            try:
                lieint.get_method(method).check_system(system)
            except ValueError:
                continue
            sol, err, seconds = run(system, y0, h, method, steps)
            cas = float(np.max(sol.drift("casimirs")))
            every = sparse(steps)
            line = (
                f"{name:7s} {method:22s} {h:6.3g} {np.max(np.abs(err)):11.2e} "
                f"{growth_exponent(sol.t, err):7.2f} {growth_exponent(sol.t[every], err[every]):7.2f} "
                f"{cas:9.1e} {seconds:8.1f}"
            )
            if "manakov" in system.invariants and method.startswith("moser_veselov"):
                line += f"   Manakov {float(np.max(sol.drift('manakov'))):.1e}"
            print(line, flush=True)
    if (args.methods is None or "splitting2" in args.methods) and (not args.bodies or "top3" in args.bodies):
        print("\nsplit comparison (Fassò): splitting2 on the 3D top, energy error by the order of the axes")
        system, y0, h = bodies()["top3"]
        for split in ("123", "132", "213", "231", "312", "321"):
            method = lieint.get_method("splitting2", split=split)
            _, err, _ = run(system, y0, h, method, min(steps, 20_000))
            print(f"  split {split}: max energy error {np.max(np.abs(err)):.2e}")
    if not args.bodies or "top4" in args.bodies:
        manakov_steps = args.manakov_steps or steps
        print(f"\n{manakov_steps:,} steps: Moser–Veselov, Manakov integrals tr((A − λB²)^k) in n = 4 and 6")
        rng = np.random.default_rng(6)
        for n in (4, 6):
            top = lieint.EulerTop(np.diag(np.linspace(0.5, 2.0, n)))
            X = rng.normal(size=(n, n)) * 0.5
            y0 = top.initial_state(Omega=X - X.T)
            sol, err, seconds = run(top, y0, 0.05, "moser_veselov", manakov_steps)
            manakov = float(np.max(sol.drift("manakov")))
            print(
                f"  n = {n}: Manakov drift {manakov:.1e}, energy {np.max(np.abs(err)):.1e}, "
                f"Casimirs {float(np.max(sol.drift('casimirs'))):.1e}  ({seconds:.0f} s)",
                flush=True,
            )


if __name__ == "__main__":
    main()
