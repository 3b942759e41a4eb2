"""CPU time to reach an error, every built-in rigid system: lieint compiled against scipy DOP853.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/systems_speed.py`` (about five minutes, seven
with ``--busy --ensembles``; ``--quick`` for a smoke run; ``--only n=6`` for the systems whose label contains "n=6";
``--busy`` times everything a second time while another CPU-bound process runs, as on a user's
busy laptop; ``--ensembles`` adds the ensemble throughput; ``--markdown PATH`` also writes the
tables to a Markdown page).

For each system — the Euler top in 3, 4 and 6 dimensions, the heavy top in 3 and 4, the ball
with an offset centre of mass on an incline in 3, the Chaplygin ball in 3 and 4 — and each
target error 1e-6 and 1e-10 on the **whole state** at the final time (every field: A or Ω, Γ,
G, R, the centre; max over fields of ``max|y − y_ref| / max(1, max|y_ref|)``):

* lieint with default settings (``lieint.integrate``: the compiled kernel is chosen by itself),
  the cheapest that reaches the target of every method of the registry with a compiled form —
  the fixed-step ones (Lie–Euler, RKMK2, 3, 4, 6, classical RK4) over a sweep of steps, the
  embedded pairs (rkmk23, rkmk45, rkmk853) over rtol (atol = rtol·1e-3) — each in exponential and
  in Cayley coordinates (the method's ``coordinates``; ``[cay]`` in the table); beside it, the
  cheaper adaptive rkmk853 against the cheapest fixed-step series (``853/fixed``) and DOP853
  against rkmk853 (``DOP/853``);
* ``scipy.integrate.solve_ivp(method="DOP853")`` on the same equations written out in plain
  numpy and float arithmetic (``benchmarks/lean_rhs.py``, checked against ``system.vector_field``
  at random states before any timing), the loosest rtol (atol = rtol·1e-3) that reaches the
  target, R projected onto SO(n) at the end as a user would. The ratio is against it; beside it,
  only for reference, DOP853 at the same rtol on lieint's own vector field (``field ms``,
  ``× field``: 2–16× dearer per evaluation, a baseline that flatters lieint).

The settings: step counts from 6 by ratios of √2, rtols from 1e-4 by ratios of √10, each series
until two settings in a row reach the tightest target or one costs more than 2 s CPU (an
embedded pair of low order at rtol 3e-14, its steps collapsing in round-off, once held 24 GB of
rows before the memory limit refused such runs); then, for
every series alike (lieint's and DOP853), three geometric bisections between the cheapest
setting that reaches a target and the next cheaper one that misses it (on the grid alone an
order-6 method's error moves 8× between counts, DOP853's about 3× between rtols, so the grid
favoured DOP853; the bisections bring both to a few per cent of cost).

The reference is DOP853 at rtol 1e-13, atol 1e-15; its own error is estimated by its distance
to compiled rkmk6 with 20,000 steps (printed: it bounds what a target can mean). Times are
process CPU time of the whole call, the minimum over repeats, side by side in this one run:
every series is timed to find the cheapest, then the cheapest and DOP853 alternate for as many
rounds each (a neighbour's load falls on both alike), and the ratio is of those minima. DOP853 on
lieint's own field is timed after that, on its own: alternated as a third call, it ran scipy's
solver just before the lean DOP853 call and left lieint's call to start each round after two
scipy runs, with caches holding only theirs — lieint's calls of a few steps then cost about 1.5×
their time when the two alternate alone (19 rkmk6 steps of the 3D heavy top: 0.20–0.21 against
0.14 ms, DOP853 1.09–1.13 against 1.08 ms), and the ratio of the short systems was set by that
order rather than by the work.

Ensembles (``--ensembles``): 1,000 bodies of each system (initial momenta spread by 1 %), 200
RKMK4 steps in one batched call, compiled, on numba's default threads: body-steps per second of
wall time and per CPU-second (process time, all threads), the best of three calls; then the 3D
top's SIMD-lanes ensemble against an FMA-loop ceiling measured in the same run
(``benchmarks/flop_ceiling.py``).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
import warnings

import lean_rhs
import numpy as np
from scipy.integrate import solve_ivp

import lieint
from lieint.groups import project_to_so
from lieint.limits import LimitError

TARGETS = (1e-6, 1e-10)


#: the fixed-step and the adaptive series, each in both coordinate maps
def _registry_series(adaptive: bool) -> tuple[str, ...]:
    """Every method of the registry with a compiled form, in each of its coordinate maps
    (``"rkmk6[cay]"``: Cayley coordinates): fixed-step methods or embedded pairs."""
    from lieint.methods.registry import get_method, method_specs

    out = []
    for name, spec in method_specs().items():
        for coordinates in spec.coordinates or (None,):
            method = get_method(name, coordinates=coordinates)
            if method.compiled() is not None and method.adaptive == adaptive:
                out.append(name + ("[cay]" if coordinates == "cayley" else ""))
    return tuple(out)


FIXED = _registry_series(adaptive=False)  # the RKMK, commutator-free, Crouch–Grossman, Moser–Veselov … maps
ADAPTIVE = _registry_series(adaptive=True)  # the embedded pairs, plain and energy-keeping
#: the pair compared with the best fixed-step method and with DOP853 on its own
PAIR = ("rkmk853", "rkmk853[cay]")


def _spd(rng, n, lo, hi):
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return Q @ np.diag(rng.uniform(lo, hi, n)) @ Q.T


def _skew(rng, n, scale=1.0):
    X = rng.normal(size=(n, n)) * scale
    return X - X.T


def cases():
    """(label, system, initial state, T); fixed seeds."""
    rng = np.random.default_rng(7)
    out = []
    top3 = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    out.append(("Euler top n=3", top3, top3.initial_state(angular_velocity=[0.3, 1.0, 0.4]), 20.0))
    for n in (4, 6):
        top = lieint.EulerTop(_spd(rng, n, 0.5, 1.5))
        out.append((f"Euler top n={n}", top, top.initial_state(Omega=_skew(rng, n, 0.5)), 10.0))
    for n in (3, 4):
        heavy = lieint.HeavyTop(_spd(rng, n, 0.5, 1.5), 1.0, 0.1 * rng.normal(size=n), -9.81 * np.eye(n)[-1])
        out.append((f"heavy top n={n}", heavy, heavy.initial_state(Omega=_skew(rng, n, 0.7)), 5.0))
    angle = 0.3
    incline = np.array([9.81 * np.sin(angle), 0.0, -9.81 * np.cos(angle)])
    ball = lieint.RollingBall(np.diag([0.1, 0.15, 0.2]), 1.0, 1.0, [0.0, 0.1, -0.2], incline)
    out.append(("offset ball on incline n=3", ball, ball.initial_state(angular_velocity=[0.3, 1.0, 0.4]), 5.0))
    for n in (3, 4):
        chap = lieint.ChaplyginBall(_spd(rng, n, 0.05, 0.2), 1.0, 1.0)
        out.append((f"Chaplygin ball n={n}", chap, chap.initial_state(Omega=_skew(rng, n, 0.7)), 10.0))
    return out


def cpu_min(fn, repeats: int) -> float:
    return interleaved_cpu_min([fn], repeats)[0]


def interleaved_cpu_min(fns, repeats: int) -> list[float]:
    """The least CPU time of each call over ``repeats`` rounds, the calls alternating within a
    round (a neighbour's load on a shared machine falls on all of them alike)."""
    best = [float("inf")] * len(fns)
    for _ in range(repeats):
        for i, fn in enumerate(fns):
            t0 = time.process_time()
            fn()
            best[i] = min(best[i], time.process_time() - t0)
    return best


class Case:
    """One system: its right-hand sides for scipy (lean and lieint's), the reference and the error measure."""

    def __init__(self, system, y0, T):
        self.system, self.y0, self.T = system, y0, T
        self.names = list(system.fields)
        self.shapes = [np.shape(y0[k]) for k in self.names]
        self.sizes = [int(np.prod(s)) for s in self.shapes]
        self.z0 = self.flat(y0)
        lean_rhs.check(system, y0)  # the lean equations are the system's, pointwise
        self.lean = lean_rhs.lean_rhs(system)
        sol = self.scipy(1e-13, 1e-15)
        self.ref = sol
        check = self.lieint("rkmk6", 20_000)
        self.ref_error = self.error(check)

    def flat(self, y):
        return np.concatenate([np.asarray(y[k], dtype=float).ravel() for k in self.names])

    def unflat(self, z):
        out, start = {}, 0
        for name, shape, size in zip(self.names, self.shapes, self.sizes, strict=True):
            out[name] = z[start : start + size].reshape(shape)
            start += size
        return out

    def rhs(self, t, z):
        """lieint's own vector field, flattened (the second DOP853 column only)."""
        return self.flat(self.system.vector_field(t, self.unflat(z)))

    def scipy(self, rtol, atol, field: str = "lean"):
        rhs = self.lean if field == "lean" else self.rhs
        sol = solve_ivp(rhs, (0.0, self.T), self.z0, method="DOP853", rtol=rtol, atol=atol)
        y = self.unflat(sol.y[:, -1].copy())
        if "R" in y:
            y["R"] = project_to_so(y["R"])  # the projection a user would apply
        return y

    def lieint(self, series, n=None, rtol=None):
        """One call of ``lieint.integrate`` for a series name ("rkmk6", "rkmk6[cay]": Cayley
        coordinates): ``n`` fixed steps, or adaptive at ``rtol``."""
        method, cayley = series.removesuffix("[cay]"), series.endswith("[cay]")
        kw = dict(method=method, coordinates="cayley") if cayley else dict(method=method)
        if n is not None:
            run = lieint.integrate(self.system, self.y0, (0.0, self.T), h=self.T / n, save_every=n, **kw)
        else:
            run = lieint.integrate(self.system, self.y0, (0.0, self.T), rtol=rtol, atol=rtol * 1e-3, **kw)
        return {k: v[-1] for k, v in run.states.items()}, run

    def error(self, y):
        y = y[0] if isinstance(y, tuple) else y
        return max(
            float(np.max(np.abs(y[k] - self.ref[k]))) / max(1.0, float(np.max(np.abs(self.ref[k])))) for k in self.names
        )


def sweeps(case: Case, quick: bool):
    """Errors of every setting (one call each, also the warm-up), on the grid and then refined
    near each target (:func:`refine`)."""
    counts = [round(6 * 2 ** (k / 2)) for k in range(0, 26, 2 if quick else 1)]  # 6 … ~35,000
    rtols = [10.0 ** (-k / 2) for k in range(8, 29, 2 if quick else 1)]  # 1e-4 … 1e-14
    fixed = [name for name in FIXED if applies(case, name)]
    adaptive = [name for name in ADAPTIVE if applies(case, name)]
    series = {name: [] for name in (*fixed, *adaptive, "DOP853")}
    for name in fixed:
        for n in counts:
            series[name].append(_timed(lambda n=n, name=name: fixed_error(case, name, n), n))
            if _done(series[name]):
                break
    for name in adaptive:
        for rtol in rtols:
            series[name].append(_timed(lambda r=rtol, name=name: adaptive_error(case, name, r), rtol))
            if _done(series[name]):
                break
    for rtol in rtols:
        series["DOP853"].append(_timed(lambda r=rtol: case.error(case.scipy(r, r * 1e-3)), rtol))
        if _done(series["DOP853"]):
            break
    for rows in series.values():
        rows[:] = [(error, setting) for error, setting, _ in rows]
    refine(case, series, rounds=1 if quick else 3)
    return series


#: a series stops at a setting that costs more CPU time than this (a low-order method at a
#: tight target: its cheapest setting would not be the best of the table anyway)
SWEEP_SECONDS = 2.0


def _timed(fn, setting) -> tuple[float, float, float]:
    t0 = time.process_time()
    error = fn()
    return error, setting, time.process_time() - t0


def _done(rows) -> bool:
    """Whether a series' sweep may stop: two settings in a row reach the tightest target (a
    tighter one would be dearer; two guard against an error that dips by chance), or the last
    setting cost more than :data:`SWEEP_SECONDS`."""
    reached = [error <= min(TARGETS) for error, _, _ in rows[-2:]]
    return (len(reached) == 2 and all(reached)) or rows[-1][2] > SWEEP_SECONDS


def applies(case: Case, name: str) -> bool:
    """Whether the series' method steps the case's system (a Moser–Veselov map, a splitting or
    the exact flow applies to some systems only) on the compiled engine — a series of the numpy
    path is not the best a user would pick."""
    method = lieint.get_method(name.removesuffix("[cay]"), coordinates="cayley" if name.endswith("[cay]") else None)
    try:
        method.check_system(case.system)
    except ValueError:
        return False
    from lieint.fast.engine import engine_for

    engine, _ = engine_for(case.system, method, case.y0, adaptive=method.adaptive, h=case.T / 1000)
    return engine is not None


#: how a fixed-step map reports a step it could not solve (Newton, the midpoint's iteration, the
#: exact flow's quadrature): a coarse setting's failure, the series' error infinite there
UNSOLVED = ("did not converge", "did not reach round-off", "did not settle")


def adaptive_error(case: Case, name: str, rtol: float) -> float:
    """The error of an embedded pair at ``rtol``; infinite when the run is refused at the memory
    limit (tolerances below what round-off lets the error estimate resolve: the steps collapse)."""
    try:
        return case.error(case.lieint(name, rtol=rtol))
    except LimitError:
        return float("inf")


def fixed_error(case: Case, name: str, n: int) -> float:
    """The error of ``n`` fixed steps; infinite when a stage leaves the dexp⁻¹ radius or an
    implicit map's step is not solved (the coarsest settings' step warnings are expected: the
    error says what they cost)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", lieint.LieStepWarning)
            return case.error(case.lieint(name, n))
    except lieint.DexpinvRangeError:
        return float("inf")
    except RuntimeError as error:
        if any(words in str(error) for words in UNSOLVED):
            return float("inf")
        raise


def refine(case: Case, series: dict, rounds: int) -> None:
    """Each series' cheapest setting that reaches each target, found more finely than on the grid
    (a step-count grid of ratio √2 moves an order-6 error 8×, an rtol grid of ratio √10 about 3×):
    ``rounds`` bisections, geometric, between it and the next cheaper setting that missed — fewer
    steps, or a looser rtol — alike for lieint's series and for DOP853."""
    for target in TARGETS:
        for name, rows in series.items():
            fixed = name in FIXED
            for _ in range(rounds):
                ok = [r for r in rows if r[0] <= target]
                if not ok:
                    break
                if fixed:
                    best = min(ok, key=lambda r: r[1])
                    missed = [r for r in rows if r[1] < best[1] and r[0] > target]
                    if not missed:
                        break
                    fail = max(missed, key=lambda r: r[1])
                    mid = round((best[1] * fail[1]) ** 0.5)
                    if mid in (best[1], fail[1]):
                        break
                    rows.append((fixed_error(case, name, mid), mid))
                    continue
                best = max(ok, key=lambda r: r[1])
                missed = [r for r in rows if r[1] > best[1] and r[0] > target]
                if not missed:
                    break
                mid = (best[1] * min(missed, key=lambda r: r[1])[1]) ** 0.5
                if name == "DOP853":
                    rows.append((case.error(case.scipy(mid, mid * 1e-3)), mid))
                else:
                    rows.append((adaptive_error(case, name, mid), mid))


def cheapest(series, name, target):
    """The setting of series ``name`` reaching ``target`` at the least cost (None: it does not,
    or the series was not run on this system)."""
    ok = [row for row in series.get(name, ()) if row[0] <= target]
    if not ok:
        return None
    return max(ok, key=lambda r: r[1]) if name in (*ADAPTIVE, "DOP853") else min(ok, key=lambda r: r[1])


#: the tables as Markdown lines, for ``--markdown``
MARKDOWN: list[str] = []

HEADER = ("system", "target", "lieint best", "error", "CPU ms", "DOP853 (lean)", "error", "CPU ms", "ratio",
          "853/fixed", "DOP/853", "field ms", "× field")  # fmt: skip


def table(all_series, reps: int, label: str) -> None:
    title = f"{label}; load average {os.getloadavg()[0]:.2f}; CPU time, min of {reps} repeats"
    print(f"\n{title}")
    print(
        f"{'system':<27s} {'target':>6s} {'lieint best':>27s} {'error':>8s} {'CPU ms':>8s}"
        f" {'DOP853 lean':>12s} {'error':>8s} {'CPU ms':>8s} {'ratio':>7s} {'853/fixed':>9s} {'DOP/853':>8s}"
        f" {'field ms':>9s} {'x field':>8s}"
    )
    MARKDOWN.extend(["", f"**{title}**", "", "| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)])
    for name, (case, series) in all_series.items():
        for target in TARGETS:
            timed = {}  # method -> (setting, error, cpu)
            for series_name in (*FIXED, *ADAPTIVE):
                row = cheapest(series, series_name, target)
                if row is None:
                    continue
                if series_name in ADAPTIVE:
                    call = lambda c=case, m=series_name, r=row[1]: c.lieint(m, rtol=r)  # noqa: E731
                    setting = f"{series_name} rtol {row[1]:.1e}"
                else:
                    call = lambda c=case, m=series_name, n=row[1]: c.lieint(m, n)  # noqa: E731
                    setting = f"{series_name} {row[1]} steps"
                timed[series_name] = (setting, row[0], cpu_min(call, reps), call)
            best = min(timed.values(), key=lambda r: r[2]) if timed else None
            fixed = [timed[m][2] for m in FIXED if m in timed]
            adaptive = min((timed[m] for m in PAIR if m in timed), key=lambda r: r[2], default=None)
            sp = cheapest(series, "DOP853", target)
            sp_cpu = field_cpu = None
            if sp:
                # DOP853 (lean, and on lieint's field at the same rtol) and the cheapest lieint series
                # once more, alternating, as many rounds each
                dop = lambda c=case, r=sp[1]: c.scipy(r, r * 1e-3)  # noqa: E731
                dop_field = lambda c=case, r=sp[1]: c.scipy(r, r * 1e-3, field="lieint")  # noqa: E731
                # DOP853 on lieint's field after them, not between (module docstring)
                if best:
                    lie_cpu, sp_cpu = interleaved_cpu_min([best[3], dop], reps)
                    best = (best[0], best[1], lie_cpu, best[3])  # the same number of rounds as DOP853
                else:
                    sp_cpu = cpu_min(dop, reps)
                field_cpu = cpu_min(dop_field, reps)
            cells = [name, f"{target:.0e}"]
            cells += [best[0], f"{best[1]:.1e}", f"{1e3 * best[2]:.2f}"] if best else ["not reached", "", ""]
            cells += [f"rtol {sp[1]:.1e}", f"{sp[0]:.1e}", f"{1e3 * sp_cpu:.2f}"] if sp else ["not reached", "", ""]
            cells.append(f"{sp_cpu / best[2]:.1f}" if best and sp else "-")
            cells.append(f"{adaptive[2] / min(fixed):.2f}" if adaptive and fixed else "-")
            cells.append(f"{sp_cpu / adaptive[2]:.1f}" if adaptive and sp else "-")
            cells += [f"{1e3 * field_cpu:.2f}", f"{field_cpu / best[2]:.1f}" if best else "-"] if sp else ["-", "-"]
            widths = (27, 6, 27, 8, 8, 12, 8, 8, 7, 9, 8, 9, 8)
            print(" ".join([f"{cells[0]:<27s}"] + [f"{c:>{w}s}" for c, w in zip(cells[1:], widths[1:], strict=True)]))
            MARKDOWN.append("| " + " | ".join(cells) + " |")


def ensembles(quick: bool) -> None:
    bodies, steps = (200 if quick else 1000), 200
    print(f"\nEnsembles: {bodies} bodies x {steps} RKMK4 steps per call; load average {os.getloadavg()[0]:.2f}")
    print(f"{'system':<27s} {'back end':<60s} {'body-steps/s':>13s} {'per CPU-s':>11s}")
    rng = np.random.default_rng(3)
    for label, system, y0, T in cases():
        field = "Omega" if "Omega" in y0 else "A"
        batch = {k: np.broadcast_to(v, (bodies, *np.shape(v))).copy() for k, v in y0.items()}
        noise = rng.normal(size=batch[field].shape) * 0.01 * np.max(np.abs(y0[field]))
        batch[field] = batch[field] + noise - np.swapaxes(noise, -1, -2)
        h = T / 2000

        def call(system=system, batch=batch, h=h):
            return lieint.integrate(system, batch, (0.0, steps * h), h=h, method="rkmk4", save_every=steps)

        run = call()
        best_wall, best_cpu = float("inf"), float("inf")
        for _ in range(3):
            w0, c0 = time.perf_counter(), time.process_time()
            call()
            best_wall = min(best_wall, time.perf_counter() - w0)
            best_cpu = min(best_cpu, time.process_time() - c0)
        work = bodies * steps
        print(f"{label:<27s} {run.stats.backend_reason[:60]:<60s} {work / best_wall:13.3g} {work / best_cpu:11.3g}")


def write_markdown(path, command: str) -> None:
    """The tables of this run as a Markdown page at ``path``."""
    from pathlib import Path

    head = [
        "---",
        "orphan: true",
        "---",
        "",
        "# lieint against DOP853 on a lean right-hand side, every built-in system",
        "",
        f"Generated by `{command}` (benchmarks/systems_speed.py; its docstring says what is measured).",
        f"{os.cpu_count()} CPUs; numpy {np.__version__}; lieint {lieint.__version__}; {time.strftime('%Y-%m-%d')}.",
        "",
        "CPU time of whole calls on a shared machine: *idle* means no CPU-bound process of the benchmark's own "
        "(the load average of the machine is in each title). **ratio** is DOP853's time on the lean right-hand side "
        "(benchmarks/lean_rhs.py: the system's equations in plain numpy and float arithmetic, checked against "
        "`system.vector_field` before timing) over lieint's; **field ms** and **× field** time DOP853 at the same "
        "rtol on lieint's own vector field — a baseline that flatters lieint, for reference only.",
    ]
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text("\n".join(head + MARKDOWN) + "\n")


def main(quick: bool, busy: bool, only: str | None = None) -> None:
    # the least of 25 calls: a 0.2 ms call still gets cheaper past 5 (0.25 ms at 5, 0.186 at 50)
    reps = 3 if quick else 25
    threads = os.environ.get("NUMBA_NUM_THREADS", "default")
    blas = os.environ.get("OPENBLAS_NUM_THREADS", "unset")
    print(f"numba threads: {threads}, OPENBLAS_NUM_THREADS={blas}, cores: {os.cpu_count()}")
    all_series = {}
    for label, system, y0, T in cases():
        if only is not None and only not in label:
            continue
        case = Case(system, y0, T)
        all_series[label] = (case, sweeps(case, quick))
        print(f"{label:<27s} T = {T:g}, reference error estimate {case.ref_error:.1e}")
    table(all_series, reps, "Idle machine")
    if busy:
        hog = subprocess.Popen([sys.executable, "-c", "while True: pass"])
        try:
            time.sleep(1.0)
            table(all_series, reps, "With another CPU-bound process running")
        finally:
            hog.kill()
    legend = (
        "ratio: DOP853's CPU time on the lean right-hand side / lieint's (the cheapest lieint series reaching the "
        "target; [cay]: Cayley coordinates); 853/fixed: the cheaper adaptive rkmk853's CPU time / the cheapest "
        "fixed-step series at the same target; DOP/853: DOP853's (lean) / the cheaper rkmk853's; field ms, x field: "
        "DOP853 at the same rtol on lieint's own vector field, and its CPU time / lieint's (reference only)"
    )
    print(legend)
    MARKDOWN.extend(["", legend])


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a smoke run: fewer settings and repeats")
    parser.add_argument("--busy", action="store_true", help="time again with a CPU-bound process running")
    parser.add_argument("--ensembles", action="store_true", help="the ensemble throughput of every system")
    parser.add_argument("--ensembles-only", action="store_true", help="only the ensemble throughput")
    parser.add_argument("--only", metavar="TEXT", help="only the systems whose label contains TEXT (e.g. 'n=6')")
    parser.add_argument("--markdown", metavar="PATH", help="also write the tables to a Markdown page")
    args = parser.parse_args()
    if not args.ensembles_only:
        main(args.quick, args.busy, args.only)
        if args.markdown:
            write_markdown(args.markdown, "python benchmarks/systems_speed.py " + " ".join(sys.argv[1:]))
    if args.ensembles or args.ensembles_only:
        ensembles(args.quick)
        from flop_ceiling import report  # the 3D ensemble against this machine's ceiling

        report()
