"""Speed of lieint against scipy, measured side by side in one run.

Run: ``python benchmarks/speed.py`` (about three minutes; ``--quick`` for a smoke run,
``--items 3`` for item 3 alone).

1. Work–precision on the default scene (3D top near its unstable axis, with orientation,
   T = 100): for each target error 1e-4 … 1e-10 (max over 201 saved times of
   ``‖A − A_exact‖/‖A₀‖``, against the Jacobi-elliptic solution), the cheapest step of each
   lieint method and the loosest tolerance of ``solve_ivp(DOP853)`` (plus projection of R) that
   reach it, each timed as the median of repeats; the ratio is scipy / lieint-fastest. DOP853
   integrates the equations written out in plain float arithmetic (``benchmarks/lean_rhs.py``,
   checked against the top's vector field first); beside it, for reference only, DOP853 at the
   same rtol on lieint's own vector field. lielab integrates the transposed attitude, whose
   equation is the left one its homogeneous systems take (see :func:`lielab_sweep`).
2. Ensemble: 10,000 tops × 1,000 RKMK4 steps in one batched call, against looping
   single-trajectory calls (lieint's own, generic and compiled) and looping scipy, as
   throughput (body-steps per second); the loops are timed on a sample of bodies.
3. The n-dimensional top, n = 8, 16, 32, 64: one RKMK4 step, compiled (``lieint.fast.topn``) and
   generic (numpy), against one ``scipy.linalg.expm`` of an n × n matrix, as ratios.
4. ``import lieint`` and the first compiled call, each in a fresh process.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from functools import partial

import lean_rhs
import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import expm

import lieint
from lieint.compare import default_scene
from lieint.groups import project_to_so
from lieint.scenes import build_system

TARGETS = [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10]


def median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def work_precision(repeats: int, quick: bool):
    scene = default_scene()
    top, y0 = build_system(scene)
    T = scene.t_end
    t_save = np.linspace(0.0, T, 201)
    exact = top.exact_solution(t_save, y0)["A"]
    scale = np.linalg.norm(y0["A"])

    def error(A):
        return float(np.max(np.linalg.norm(A - exact, axis=(-2, -1))) / scale)

    def lieint_run(method, h):
        nsteps = round(T / h)
        return lieint.integrate(top, y0, (0.0, T), h=T / nsteps, method=method, project=True, save_every=nsteps // 200)

    lean_rhs.check(top, y0)  # the lean equations are the top's, pointwise
    lean = lean_rhs.lean_rhs(top)

    def field_rhs(t, z):  # lieint's own vector field: the second column only
        return lean_rhs.flatten(top, top.vector_field(t, lean_rhs.unflatten(top, z)))

    def scipy_run(rtol, rhs=lean):
        sol = solve_ivp(
            rhs,
            (0.0, T),
            np.concatenate([y0["A"].ravel(), y0["R"].ravel()]),
            method="DOP853",
            t_eval=t_save,
            rtol=rtol,
            atol=rtol * 1e-3,
        )
        A = sol.y[:9].T.reshape(-1, 3, 3)
        project_to_so(sol.y[9:].T.reshape(-1, 3, 3))  # the projection a user would apply
        return A

    # step sweeps: steps counts dividing 200 saves evenly
    sweeps = {
        "rkmk4": [200 * k for k in (5, 10, 20, 40, 80, 160, 320)],
        "rkmk6": [200 * k for k in (2, 4, 8, 16, 32, 64)],
        "rk4": [200 * k for k in (5, 10, 20, 40, 80, 160, 320)],
    }
    if quick:
        sweeps = {k: v[:3] for k, v in sweeps.items()}
    lieint_runs = {}
    for method, counts in sweeps.items():
        lieint_run(method, T / counts[0])  # compile / warm up
        for n in counts:
            h = T / n
            err = error(lieint_run(method, h).states["A"])
            lieint_runs.setdefault(method, []).append((err, median_time(partial(lieint_run, method, h), repeats), n))
    lielab = lielab_sweep(top, y0, T, repeats, quick)
    scipy_runs = []
    for rtol in [1e-5, 1e-7, 1e-9] if quick else [1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13]:
        err = error(scipy_run(rtol))
        t_lean = median_time(partial(scipy_run, rtol), max(1, repeats // 2))
        t_field = median_time(partial(scipy_run, rtol, field_rhs), max(1, repeats // 2))
        scipy_runs.append((err, t_lean, rtol, t_field))

    print("1. Work-precision, default scene (3D top near its unstable axis, with R, T = 100)")
    print(
        f"{'target':>8s} {'lieint best':>22s} {'time [ms]':>10s} {'DOP853 lean':>14s} {'time [ms]':>10s} {'ratio':>7s}"
        f" {'field [ms]':>10s} {'x field':>7s} {'lielab':>14s} {'time [ms]':>10s} {'ratio':>7s}"
    )
    for target in TARGETS:
        best = None
        for method, runs in lieint_runs.items():
            ok = [r for r in runs if r[0] <= target]
            if ok:
                t = min(r[1] for r in ok)
                n = next(r[2] for r in ok if r[1] == t)
                if best is None or t < best[1]:
                    best = (method, t, n)
        ok = [r for r in scipy_runs if r[0] <= target]
        sp = min(ok, key=lambda r: r[1]) if ok else None
        lie_txt = f"{best[0]} ({best[2]} steps)" if best else "not reached"
        sp_txt = f"rtol {sp[2]:.0e}" if sp else "not reached"
        ratio = f"{sp[1] / best[1]:7.1f}" if best and sp else "      -"
        ll = [r for r in lielab if r[0] <= target]
        ll = min(ll, key=lambda r: r[1]) if ll else None
        ll_txt = f"reltol {ll[2]:.0e}" if ll else ("not installed" if not lielab else "not reached")
        ll_ratio = f"{ll[1] / best[1]:7.1f}" if best and ll else "      -"
        field_ratio = f"{sp[3] / best[1]:7.1f}" if best and sp else "      -"
        print(
            f"{target:8.0e} {lie_txt:>22s} {best[1] * 1e3 if best else float('nan'):10.2f} {sp_txt:>14s} "
            f"{sp[1] * 1e3 if sp else float('nan'):10.2f} {ratio} {sp[3] * 1e3 if sp else float('nan'):10.2f} "
            f"{field_ratio} {ll_txt:>14s} {ll[1] * 1e3 if ll else float('nan'):10.2f} {ll_ratio}"
        )
    print(
        "   ratio: DOP853's time on a lean right-hand side (benchmarks/lean_rhs.py) / lieint's; field, x field: "
        "DOP853 at the same rtol on lieint's own vector field (reference only)"
    )
    return lieint_runs, scipy_runs


def lielab_sweep(top, y0, T, repeats, quick):
    """The peer library lielab (optional: ``pip install lielab``): its default Munthe-Kaas flow
    with adaptive steps on SO(3) × R³, the error measured on A = −(Iw)^ at its output times
    against the exact solution.

    lielab's homogeneous systems act on the left, ``ẏ = ξ(t, y) y``. The top's attitude moves
    on the right, ``Ṙ = R ŵ``, so lielab is given ``Q = Rᵀ``, whose equation is the left one
    ``Q̇ = −ŵ Q`` (``ξ = −ŵ``), with the body angular velocity w on R³,
    ``ẇ = I⁻¹ (Iw × w)``; R = Qᵀ is checked against the exact attitude at the tightest tolerance.
    """
    try:
        from lielab.domain import RN, SO, CompositeAlgebra, CompositeManifold, rn, so
        from lielab.integrate import HomogeneousIVPSystem, IVPOptions
        from lielab.integrate import solve_ivp as lielab_solve
    except ImportError:
        return []
    from lieint.systems.euler_top_exact import euler_top_angular_velocity

    moments = top.principal_moments
    w0 = -np.array([y0["A"][2, 1], y0["A"][0, 2], y0["A"][1, 0]]) / moments

    def generator(t, y):
        w = np.asarray(y[1].serialize())
        return CompositeAlgebra([so.from_vector(-w), rn.from_vector(np.cross(moments * w, w) / moments)])

    system = HomogeneousIVPSystem(generator)
    start = CompositeManifold([SO(np.ascontiguousarray(y0["R"].T)), RN.from_vector(w0)])
    runs = []
    reltols = [1e-5, 1e-8] if quick else [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13]
    for reltol in reltols:
        opts = IVPOptions()
        opts.reltol, opts.abstol = reltol, reltol * 1e-2

        run = partial(lielab_solve, system, [0.0, T], start, opts)

        sol = run()
        w = np.asarray(sol.ybar)[:, -3:]
        exact = euler_top_angular_velocity(moments, w0, np.asarray(sol.t))
        err = float(np.max(np.linalg.norm(moments * (w - exact), axis=1)) / np.linalg.norm(moments * w0))
        runs.append((err, median_time(run, max(1, repeats // 2)), reltol))
        if reltol == reltols[-1]:
            R = np.swapaxes(np.asarray(sol.ybar)[:, :9].reshape(-1, 3, 3), -1, -2)
            R_exact = top.exact_solution(np.asarray(sol.t), y0)["R"]
            print(
                f"   lielab at reltol {reltol:.0e}: attitude error max |R - R_exact| = {np.abs(R - R_exact).max():.1e}"
            )
    return runs


def ensemble(quick: bool):
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    N, steps, h = (2000 if quick else 10_000), 1000, 0.01
    rng = np.random.default_rng(1)
    w = rng.normal(size=(N, 3))
    y0 = top.initial_state(angular_velocity=w)
    lieint.integrate(top, top.initial_state(angular_velocity=w[:2]), (0, 0.1), h=h)  # warm up
    t_batch = median_time(lambda: lieint.integrate(top, y0, (0.0, steps * h), h=h, method="rkmk4", save_every=steps), 3)
    rate_batch = N * steps / t_batch

    def loop(k, backend):
        for i in range(k):
            lieint.integrate(
                top,
                top.initial_state(angular_velocity=w[i]),
                (0.0, steps * h),
                h=h,
                method="rkmk4",
                save_every=steps,
                backend=backend,
            )

    k_fast, k_slow = 200, 3
    rate_fast = k_fast * steps / median_time(lambda: loop(k_fast, "auto"), 3)
    rate_numpy = k_slow * steps / median_time(lambda: loop(k_slow, "numpy"), 1)

    lean = lean_rhs.lean_rhs(top)

    def scipy_loop(k):
        for i in range(k):
            y = top.initial_state(angular_velocity=w[i])

            solve_ivp(
                lean,
                (0.0, steps * h),
                np.concatenate([y["A"].ravel(), y["R"].ravel()]),
                method="DOP853",
                rtol=1e-9,
                atol=1e-12,
            )

    rate_scipy = k_slow * steps / median_time(lambda: scipy_loop(k_slow), 1)
    print(f"\n2. Ensemble: {N} tops x {steps} RKMK4 steps (h = {h}), throughput in body-steps/s")
    print(f"   batched lieint call               {rate_batch:12.3e}   (total {t_batch:.2f} s)")
    print(f"   loop of single calls, compiled    {rate_fast:12.3e}   ratio batched/loop {rate_batch / rate_fast:8.1f}")
    print(
        f"   loop of single calls, generic     {rate_numpy:12.3e}   ratio batched/loop {rate_batch / rate_numpy:8.1f}"
    )
    print(
        f"   loop of scipy DOP853 (rtol 1e-9)  {rate_scipy:12.3e}   ratio batched/loop {rate_batch / rate_scipy:8.1f}"
    )


def _block_time(fn, calls: int) -> float:
    """Wall time of one call of ``fn``, from one block of ``calls`` calls."""
    t0 = time.perf_counter()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - t0) / calls


def large_n(quick: bool):
    """One RKMK4 step of the n-dimensional top against one ``scipy.linalg.expm`` (n = 8 … 64).

    The compiled step is the marginal cost of a step inside one ``integrate`` call (a run of N
    steps minus a run of N/10, over 0.9 N: the per-call overhead of about 0.1 ms is left out),
    the generic step one ``method.step`` call on the numpy path. Each contender is timed in
    blocks of about the same length (30 ms: a long block and a short one would not
    be preempted alike on a busy machine), in interleaved rounds, and each figure is the median
    over the rounds.
    """
    block = 0.03
    rng = np.random.default_rng(2)
    method = lieint.get_method("rkmk4")
    rounds = 5 if quick else 11
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(
        "\n3. n-dimensional top: one RKMK4 step (h = 0.01) against one expm of an n x n matrix (target <= 6; "
        f"load average {load})"
    )
    print("      n    expm [us]   compiled [us]   ratio   generic [us]   ratio")
    for n in (8, 16, 32, 64):
        top = lieint.EulerTop(np.diag(rng.uniform(0.5, 2.0, n)))
        X = rng.normal(size=(n, n))
        X = 0.05 * (X - X.T)
        y = top.initial_state(Omega=X, R=expm(X))

        def run(steps, top=top, y=y):
            lieint.integrate(top, y, (0.0, steps * 0.01), h=0.01, method="rkmk4", backend="numba", save_every=steps)

        def expm_call(X=X):
            expm(X)

        def generic_step(top=top, y=y):
            method.step(top, 0.0, y, 0.01, None)

        run(10)  # load the compiled kernel, then size the blocks from one timing of each
        N = max(int(block / max(_block_time(lambda run=run: run(1000), 1) / 1000, 1e-7)), 20)
        M = N // 10
        k_exp = max(int(block / _block_time(expm_call, 20)), 1)
        k_gen = max(int(block / _block_time(generic_step, 3)), 1)
        t_exp, t_fast, t_gen = [], [], []
        for _ in range(rounds):
            t_exp.append(_block_time(expm_call, k_exp))
            long, short = _block_time(lambda N=N, run=run: run(N), 1), _block_time(lambda M=M, run=run: run(M), 1)
            t_fast.append((long - short) / (N - M))
            t_gen.append(_block_time(generic_step, k_gen))
        e, f, g = (statistics.median(t) for t in (t_exp, t_fast, t_gen))
        print(f"   {n:4d}   {e * 1e6:10.1f}   {f * 1e6:13.1f}   {f / e:5.2f}   {g * 1e6:12.1f}   {g / e:5.1f}")


def startup():
    code_import = "import time; t = time.perf_counter(); import lieint; print(time.perf_counter() - t)"
    code_first = (
        "import time, lieint; top = lieint.EulerTop.from_principal_moments([1, 2, 3]); "
        "y = top.initial_state(angular_velocity=[0.1, 1, 0.1]); t = time.perf_counter(); "
        "lieint.integrate(top, y, (0, 1), h=0.01); print(time.perf_counter() - t)"
    )
    imp = [float(subprocess.check_output([sys.executable, "-c", code_import])) for _ in range(5)]
    first = [float(subprocess.check_output([sys.executable, "-c", code_first])) for _ in range(3)]
    print(
        f"\n4. import lieint: median {statistics.median(imp):.3f} s (target < 0.3 s); first compiled call in a "
        f"fresh process (compiled code loaded from the disk cache): median {statistics.median(first):.3f} s"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller sweeps and ensembles")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--items", default="1234", help="which items to run, e.g. 3 (default: 1234)")
    args = parser.parse_args()
    if "1" in args.items:
        work_precision(args.repeats if not args.quick else 1, args.quick)
    if "2" in args.items:
        ensemble(args.quick)
    if "3" in args.items:
        large_n(args.quick)
    if "4" in args.items:
        startup()


if __name__ == "__main__":
    main()
