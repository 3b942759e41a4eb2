"""Adaptive rkmk853 compiled against its generic path, fixed steps and scipy's DOP853.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/adaptive_speed.py`` (about a minute; ``--quick``
for a smoke run, ``--compile`` adds the first call in a fresh process with an empty numba cache
and with the cache filled).

On the default scene (the 3D top near its unstable axis, with its attitude R, T = 100) each
series is swept — rkmk853 over rtol (atol = rtol·1e-3, every accepted step saved), rkmk4,
rkmk6 and RK4 with projection over the step (compiled, 200 saves), ``solve_ivp(DOP853)`` over
rtol (atol = rtol·1e-3, 201 ``t_eval`` saves, R projected onto SO(3) as a user would; on the
equations written out in plain float arithmetic, ``benchmarks/lean_rhs.py``, with a reference
row on lieint's own vector field) — and
the R error of a run is
``max_t ‖R(t) − R_exact(t)‖_F`` over its saves against the exact solution
(``top.exact_solution``: Jacobi elliptic functions and the elliptic integral of the attitude).
For each target error the cheapest setting of each series that reaches it is timed: process CPU
time of the whole call, the minimum over repeats, all series side by side in this one run. The
ratios are against the compiled rkmk853.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

import lean_rhs
import numpy as np
from scipy.integrate import solve_ivp

import lieint
from lieint.compare import default_scene
from lieint.groups import project_to_so
from lieint.scenes import build_system

TARGETS = (1e-6, 1e-10)


def cpu_min(fn, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return best


def main(quick: bool, compile_times: bool) -> None:
    scene = default_scene()
    top, y0 = build_system(scene)
    T = scene.t_end

    def r_error(t, R):
        exact = top.exact_solution(t, y0)["R"]
        return float(np.max(np.linalg.norm(R - exact, axis=(-2, -1))))

    def adaptive(rtol, backend):
        return lieint.integrate(top, y0, (0.0, T), method="rkmk853", rtol=rtol, atol=rtol * 1e-3, backend=backend)

    def fixed(method, n):
        project = method == "rk4"  # classical RK4 leaves SO(3): projected, as a user would
        return lieint.integrate(top, y0, (0.0, T), h=T / n, method=method, save_every=n // 200, project=project)

    t_save = np.linspace(0.0, T, 201)

    lean_rhs.check(top, y0)  # the lean equations are the top's, pointwise
    lean = lean_rhs.lean_rhs(top)

    def field_rhs(t, z):  # lieint's own vector field: a reference row only
        return lean_rhs.flatten(top, top.vector_field(t, lean_rhs.unflatten(top, z)))

    z0 = lean_rhs.flatten(top, y0)

    def scipy_run(rtol, rhs=lean):
        sol = solve_ivp(rhs, (0.0, T), z0, method="DOP853", t_eval=t_save, rtol=rtol, atol=rtol * 1e-3)
        return sol.t, project_to_so(sol.y[9:].T.reshape(-1, 3, 3)), sol

    # 1e-5 … 1e-15 in half decades: near the separatrix rkmk853's R error is ~1e5·rtol, so the
    # target 1e-10 needs rtol 1e-15 (scipy clamps rtol at 100 eps = 2.2e-14 for DOP853)
    rtols = [10.0 ** (-k / 2) for k in range(10, 31)]
    counts = [10 * round(20 * 2 ** (k / 4)) for k in range(0, 29)]  # 200 … 25,600 steps, ratio 2^(1/4)
    if quick:
        rtols, counts = rtols[::3], counts[::3]
    # errors of every setting (one call each; it is also the warm-up)
    series: dict[str, list] = {"rkmk853": [], "rkmk4": [], "rkmk6": [], "rk4": [], "DOP853": []}
    for rtol in rtols:
        sol = adaptive(rtol, "numba")
        series["rkmk853"].append((r_error(sol.t, sol.states["R"]), rtol, sol.nsteps, sol.stats.nrejected))
    for method in ("rkmk4", "rkmk6", "rk4"):
        for n in counts:
            sol = fixed(method, n)
            series[method].append((r_error(sol.t, sol.states["R"]), n, n, 0))
    for rtol in rtols:
        t, R, sol = scipy_run(rtol)
        series["DOP853"].append((r_error(t, R), rtol, int(sol.t.size), 0))

    print("sweeps (R error per setting):")
    for name, rows in series.items():
        setting = "rtol" if name in ("rkmk853", "DOP853") else "steps"
        print(f"  {name:8s} " + ", ".join(f"{setting} {r[1]:.0e}: {r[0]:.1e}" if setting == "rtol" else
                                          f"{r[1]}: {r[0]:.1e}" for r in rows))  # fmt: skip

    def cheapest(name, target):
        ok = [row for row in series[name] if row[0] <= target]
        if not ok:
            return None
        # loosest tolerance / fewest steps reaching the target
        return max(ok, key=lambda r: r[1]) if name in ("rkmk853", "DOP853") else min(ok, key=lambda r: r[1])

    reps = 3 if quick else 7
    load = os.getloadavg()[0]
    print(f"Default scene (3D top near its unstable axis, with R, T = {T:g}); load average {load:.2f}")
    print(f"R error = max over saves of ||R - R_exact||_F; CPU time of the call, min of {reps} repeats")
    header = f"{'target':>7s} {'series':<26s} {'setting':>16s} {'steps':>6s} {'rej':>4s} {'R error':>9s}"
    print(header + f" {'CPU [ms]':>9s} {'us/step':>8s} {'x compiled':>10s}")
    for target in TARGETS:
        rows = []
        best = cheapest("rkmk853", target)
        if best is not None:
            err, rtol, steps, rej = best
            c = cpu_min(lambda rtol=rtol: adaptive(rtol, "numba"), reps)
            g = cpu_min(lambda rtol=rtol: adaptive(rtol, "numpy"), max(1, reps // 3))
            g_sol = adaptive(rtol, "numpy")
            g_err = r_error(g_sol.t, g_sol.states["R"])
            rows.append(("rkmk853 compiled", f"rtol {rtol:.1e}", steps, rej, err, c))
            rows.append(("rkmk853 generic (numpy)", f"rtol {rtol:.1e}", g_sol.nsteps, g_sol.stats.nrejected, g_err, g))
        fixed_best = None
        for method in ("rkmk4", "rkmk6", "rk4"):
            row = cheapest(method, target)
            if row is not None:
                cpu = cpu_min(lambda m=method, n=row[1]: fixed(m, n), reps)
                if fixed_best is None or cpu < fixed_best[-1]:
                    fixed_best = (f"{method} compiled (best fixed)", f"h = T/{row[1]}", row[2], 0, row[0], cpu)
        if fixed_best is not None:
            rows.append(fixed_best)
        row = cheapest("DOP853", target)
        if row is not None:
            cpu = cpu_min(lambda rtol=row[1]: scipy_run(rtol), max(1, reps // 2))
            rows.append(("scipy DOP853 + projection", f"rtol {row[1]:.1e}", row[2], 0, row[0], cpu))
            cpu = cpu_min(lambda rtol=row[1]: scipy_run(rtol, field_rhs), max(1, reps // 2))
            rows.append(("(DOP853 on lieint's field)", f"rtol {row[1]:.1e}", row[2], 0, row[0], cpu))
        base = rows[0][-1] if rows and rows[0][0] == "rkmk853 compiled" else None
        for name, setting, steps, rej, err, cpu in rows:
            per = 1e6 * cpu / max(steps, 1) if "DOP853" not in name else float("nan")
            ratio = f"{cpu / base:10.2f}" if base else "         -"
            print(
                f"{target:7.0e} {name:<26s} {setting:>16s} {steps:6d} {rej:4d} {err:9.2e} {1e3 * cpu:9.3f}"
                f" {per:8.2f} {ratio}"
            )
        if not rows:
            print(f"{target:7.0e} not reached by any series")
    print(
        "(steps of DOP853: its t_eval saves, not its steps; x compiled: CPU time / rkmk853 compiled's; DOP853 runs on "
        "a lean right-hand side, benchmarks/lean_rhs.py; the row in parentheses, for reference only, on lieint's own "
        "vector field)"
    )
    if compile_times:
        compile_report()


def compile_report() -> None:
    """First adaptive compiled call in a fresh process: empty numba cache, then a filled one."""
    code = (
        "import time, lieint; top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0]); "
        "y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4]); t0 = time.perf_counter(); "
        "s = lieint.integrate(top, y0, (0, 1), method='rkmk853', rtol=1e-8, backend='numba'); "
        "print(time.perf_counter() - t0)"
    )
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        times = []
        for _ in range(2):
            out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
            times.append(float(out.stdout))
    print(f"first compiled adaptive call, fresh process: empty numba cache {times[0]:.2f} s, filled {times[1]:.2f} s")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a smoke run: fewer settings and repeats")
    parser.add_argument("--compile", action="store_true", help="also time the first call with an empty numba cache")
    args = parser.parse_args()
    main(args.quick, args.compile)
