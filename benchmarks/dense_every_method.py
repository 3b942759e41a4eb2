"""Dense output on the group for every method that applies to the 3D top, and the first flip of
the Dzhanibekov top located by events with each of them.

The 3D Euler top, I = (1, 2, 3). For every method of the registry that applies to it, one row:

* ``defect``: max ‖RᵀR − I‖ of ``sol.sol(t)`` at 10⁴ random times on [0, 30] (h = 0.01;
  adaptive methods at rtol 1e-9, atol 1e-12), beside the same for the embedded cubic Hermite
  interpolant of the state arrays (what these methods got before) and the steps' own defect;
* ``order``: the fitted order of the dense error in A between the steps (θ = 0.37 of each step,
  T = 2, h = 0.1, 0.05, 0.025; 0.4, 0.2, 0.1 for order 8) against the Jacobi elliptic solution,
  fixed-step methods only;
* ``flip``: |t − t_exact| of the first flip (ω₀ = (0.01, 1, 0.01)) located by a terminal event,
  h = 0.01 (adaptive: rtol 1e-10, atol 1e-12).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/dense_every_method.py
"""

from __future__ import annotations

import numpy as np

import lieint
from lieint.dense import EmbeddedHermite
from lieint.groups.bivectors import vee
from lieint.methods.registry import method_specs
from lieint.systems.euler_top_exact import euler_top_flip_times

TOP = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
Y0 = TOP.initial_state(angular_velocity=[0.3, 1.0, 0.4])
SPECS = method_specs()


def defect(R):
    return float(np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max())


def options(name, h, rtol):
    method = lieint.get_method(name)
    return {"h": h} if not (SPECS[name].adaptive or method.self_controlled) else {"rtol": rtol, "atol": 1e-12}


def defects(name, times):
    sol = lieint.integrate(TOP, Y0, (0.0, 30.0), method=name, dense_output=True, **options(name, 0.01, 1e-9))
    dense = defect(sol.sol(times)["R"])
    # the embedded cubic Hermite interpolant on the same steps, for comparison
    i = np.clip(np.searchsorted(sol.t, times), 1, sol.t.size - 1)
    worst = 0.0
    for j in np.unique(i)[:2000]:
        y0 = {k: v[j - 1] for k, v in sol.states.items()}
        y1 = {k: v[j] for k, v in sol.states.items()}
        piece = EmbeddedHermite(sol.t[j - 1], sol.t[j], y0, y1, TOP.vector_field(0, y0), TOP.vector_field(0, y1))
        worst = max(worst, defect(piece(times[i == j][0])["R"]))
    return dense, worst, defect(sol.states["R"])


def dense_order(name):
    order = SPECS[name].order
    hs = [0.4, 0.2, 0.1] if order == 8 else [0.1, 0.05, 0.025]
    errors = []
    for h in hs:
        sol = lieint.integrate(TOP, Y0, (0.0, 2.0), h=h, method=name, dense_output=True, backend="numpy")
        times = (np.arange(2, round(2.0 / h)) + 0.37) * h
        errors.append(np.max(np.abs(sol.sol(times)["A"] - TOP.exact_solution(times, Y0)["A"])))
    return float(np.polyfit(np.log(hs), np.log(errors), 1)[0])


def first_flip(name):
    def rate(t, y):
        return vee(TOP.P.T @ TOP.angular_velocity(y["A"]) @ TOP.P)[1]

    rate.terminal = True
    w0 = [0.01, 1.0, 0.01]
    exact = euler_top_flip_times([1.0, 2.0, 3.0], w0, 12.0)[0]
    y0 = TOP.initial_state(angular_velocity=w0)
    sol = lieint.integrate(TOP, y0, (0.0, 12.0), method=name, events=rate, **options(name, 0.01, 1e-10))
    return abs(sol.t_events[0][0] - exact)


def main() -> None:
    times = np.random.default_rng(1).uniform(0.0, 30.0, 10_000)
    print(f"{'method':26s} {'order':>5s} {'defect':>9s} {'embedded':>9s} {'steps':>9s} {'fit':>5s} {'flip err':>9s}")
    for name in lieint.method_names():
        method = lieint.get_method(name)
        try:
            method.check_system(TOP)
        except ValueError:
            continue
        dense, embedded, steps = defects(name, times)
        fixed = not (SPECS[name].adaptive or method.self_controlled)
        fit = f"{dense_order(name):5.2f}" if fixed else "    -"
        order = "-" if SPECS[name].order is None else str(SPECS[name].order)
        print(
            f"{name:26s} {order:>5s} {dense:9.1e} {embedded:9.1e} {steps:9.1e} {fit} {first_flip(name):9.1e}",
            flush=True,
        )


if __name__ == "__main__":
    main()
