"""Wall time of one single-trajectory call, beside the compiled kernel it runs, by stage.

Run: ``python benchmarks/single_call.py`` (about half a minute; a minute or two with
``--against``). The call is
``lieint.integrate(top, y0, (0, 1), method="rkmk4", h=0.01)``: 100 RKMK4 steps of the 3D
Euler top with its orientation, 101 saved rows. It prints the minimum and median wall time over
``--repeats`` calls, the bare compiled kernel (``lieint.fast.top3._run_serial`` on prepared
arrays) and the Python around it, stage by stage, each stage timed on its own in the same loop:

* ``method``: ``get_method`` (name → method object);
* ``validate``: ``system.validate_state`` (keys, shapes, finiteness, skew A, R in SO(3));
* ``arguments``: ``t_span``, ``h`` and the step observer;
* ``driver``: ``Driver(...)`` (the step plan and the method's check of the system);
* ``start``: kernel set-up and the state in the principal frame;
* ``first row``: the initial row in the user's frame;
* ``advance``: the compiled loop, its saved rows in the user's frame, the finiteness check;
* ``solution``: the ``Solution`` and its ``Stats``;
* ``step check``: the ``LieStepWarning`` check of ``h ξ`` at the saved states (the compiled
  kernel's own ``max |ω|`` where it has one).

It also times, as totals, the same call with ``method="rk4"``, a batch of 10 bodies and a 4D
top (the generic numpy path, 10 steps). The single trajectories run first, the 10 bodies and the
4D top after them: the 10-body call starts numba's thread pool (two threads on two cores).

``--against PATH`` measures another checkout (e.g. the main branch) side by side: both run in
subprocesses (``PYTHONPATH`` set to each tree), alternating, and the table shows the minimum
of the minima and the median of the medians over the rounds. ``--hog`` keeps one busy-looping
process running meanwhile (a loaded machine).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

STAGES = ["method", "validate", "arguments", "driver", "start", "first row", "advance", "solution", "step check"]
CALLS = ["total rkmk4", "kernel"] + STAGES + ["total rk4", "total rkmk4 10 bodies", "total rkmk4 4D (numpy)"]


def _summary(samples: dict[str, list[float]]) -> dict[str, tuple[float, float]]:
    return {k: (min(v) * 1e6, statistics.median(v) * 1e6) for k, v in samples.items()}


def measure(repeats: int) -> dict[str, tuple[float, float]]:
    """Minimum and median (µs) of each call and stage over ``repeats``."""
    import lieint
    from lieint import ivp
    from lieint._validation import check_finite_positive
    from lieint.driver import Driver
    from lieint.fast import top3
    from lieint.ivp import _check_t_span, _warn_if_unresolved
    from lieint.methods.registry import get_method
    from lieint.observe import StepObserver, group_action_of

    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.01, 1.0, 0.01])
    ys10 = top.initial_state(angular_velocity=np.random.default_rng(0).normal(size=(10, 3)))
    top4 = lieint.EulerTop(np.diag([1.0, 2.0, 3.0, 4.0]))
    X = np.random.default_rng(1).normal(size=(4, 4))
    y4 = top4.initial_state(Omega=X - X.T)

    def call(method="rkmk4", system=top, y=y0, t1=1.0, backend="auto"):
        return lieint.integrate(system, y, (0.0, t1), method=method, h=0.01, backend=backend)

    # the bare kernel: the serial compiled loop on arrays prepared once
    m = get_method("rkmk4")
    kernel = Driver(top, m, (0.0, 1.0), h=0.01)
    carry = kernel.start(y0)
    k = kernel.loop.kernel
    pi0, R0 = carry.state["pi"], carry.state["R"]
    saves = kernel.plan.saves_between(1, 0, kernel.plan.nsteps)
    tab = m.compiled()
    args = (
        np.ascontiguousarray(pi0),
        np.ascontiguousarray(R0),
        1.0 / np.asarray(k.moments, dtype=float),
        np.ascontiguousarray(tab["A"], dtype=float),
        np.ascontiguousarray(tab["b"], dtype=float),
        np.asarray(k.coeffs, dtype=float),
        True,
        0.01,
        kernel.plan.last_step,
        0,
        kernel.plan.nsteps,
        kernel.plan.nsteps,
        saves,
        False,
        np.empty((saves.size, 1, 3)),
        np.empty((saves.size, 1, 3, 3)),
        np.empty((1, 3)),
        np.empty((1, 3, 3)),
    )

    def bare():
        return top3._run_serial(*args)

    def staged(samples):
        clock = time.perf_counter
        t = [clock()]
        stepper = get_method("rkmk4")
        t.append(clock())
        y = top.validate_state(y0, "y0")
        t.append(clock())
        t0, t1 = _check_t_span((0.0, 1.0))
        h = check_finite_positive(0.01, "h")
        if hasattr(ivp, "_observer"):  # as integrate builds it (none when nothing watches the steps)
            observer = ivp._observer(top, stepper, t0, None, False, None, False)
        else:  # before: always built
            observer = StepObserver(top, t0, order=stepper.order, group_action=group_action_of(stepper))
        t.append(clock())
        driver = Driver(top, stepper, (t0, t1), h=h, observer=observer)
        t.append(clock())
        c = driver.start(y)
        t.append(clock())
        first = driver.loop.first_row(c)
        t.append(clock())
        segment = driver.advance(c)
        t.append(clock())
        sol = driver.solution(first, [segment], c, 0.0, 0.0)
        t.append(clock())
        if hasattr(driver, "generator_radius"):  # the kernel's own radius of ξ, as integrate does
            _warn_if_unresolved(top, sol, h, driver.generator_radius(sol.states, limit=np.pi / h))
        else:  # before: ξ evaluated at the saved states
            _warn_if_unresolved(top, sol, h)
        t.append(clock())
        for name, a, b in zip(STAGES, t, t[1:], strict=False):
            samples[name].append(b - a)

    timed = {
        "total rkmk4": call,
        "kernel": bare,
        "total rk4": lambda: call("rk4"),
        "total rkmk4 10 bodies": lambda: call(y=ys10),
        "total rkmk4 4D (numpy)": lambda: call(system=top4, y=y4, t1=0.1, backend="numpy"),  # generic path
    }
    samples: dict[str, list[float]] = {name: [] for name in CALLS}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, fn in timed.items():  # compile / load and warm up (the 10 bodies in their phase)
            for _ in range(20 if "10 bodies" not in name else 0):
                fn()
        for _ in range(20):
            staged(samples)
        samples = {name: [] for name in CALLS}
        clock = time.perf_counter
        # single trajectories first: the 10-body call starts numba's thread pool, whose idle
        # threads then share the two cores with everything that follows
        for phase in (("total rkmk4", "kernel", "total rk4"), ("total rkmk4 10 bodies", "total rkmk4 4D (numpy)")):
            for _ in range(20):
                timed[phase[0]]()
            for i in range(repeats):
                for name in phase:
                    if name == "total rkmk4 4D (numpy)" and i % 10:
                        continue  # the generic path is ~100x slower: a tenth of the repeats
                    t = clock()
                    timed[name]()
                    samples[name].append(clock() - t)
                if phase[0] == "total rkmk4":
                    staged(samples)
    return _summary(samples)


def _table(columns: dict[str, dict[str, tuple[float, float]]]) -> str:
    heads = list(columns)
    lines = [f"{'µs':<26s}" + "".join(f"{h + ' min':>16s}{h + ' med':>16s}" for h in heads)]
    for name in CALLS:
        row = f"{name:<26s}"
        for h in heads:
            lo, med = columns[h][name]
            row += f"{lo:16.1f}{med:16.1f}"
        lines.append(row)
        if name == "kernel":
            lines.append("  stages (each timed on its own):")
        if name == STAGES[-1]:
            row = f"{'  sum of the stages':<26s}"
            for h in heads:
                row += f"{sum(columns[h][s][0] for s in STAGES):16.1f}{sum(columns[h][s][1] for s in STAGES):16.1f}"
            lines.append(row)
    return "\n".join(lines)


def _subprocess(tree: str, repeats: int) -> dict[str, tuple[float, float]]:
    env = dict(os.environ, PYTHONPATH=tree, OPENBLAS_NUM_THREADS="1")
    out = subprocess.check_output(
        [sys.executable, str(Path(__file__).resolve()), "--json", "--repeats", str(repeats)], env=env, cwd=tree
    )
    return {k: tuple(v) for k, v in json.loads(out).items()}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2000)
    parser.add_argument("--against", metavar="PATH", help="another checkout to measure side by side")
    parser.add_argument("--rounds", type=int, default=4, help="alternating subprocess rounds with --against")
    parser.add_argument("--hog", action="store_true", help="keep one busy-looping process running meanwhile")
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.json:
        print(json.dumps(measure(args.repeats)))
        return
    hog = subprocess.Popen([sys.executable, "-c", "while True: pass"]) if args.hog else None
    try:
        if args.against is None:
            columns = {"this": measure(args.repeats)}
        else:
            here = str(Path(__file__).resolve().parents[1])
            trees = {"before": str(Path(args.against).resolve()), "after": here}
            runs: dict[str, list] = {h: [] for h in trees}
            per_round = max(1, args.repeats // args.rounds)
            for _ in range(args.rounds):
                for label, tree in trees.items():
                    runs[label].append(_subprocess(tree, per_round))
            columns = {
                label: {
                    name: (min(r[name][0] for r in rs), statistics.median(r[name][1] for r in rs)) for name in CALLS
                }
                for label, rs in runs.items()
            }
    finally:
        if hog is not None:
            hog.kill()
            hog.wait()
    load = "with a CPU hog running" if args.hog else "no hog"
    print(f"lieint.integrate(top, y0, (0, 1), method='rkmk4', h=0.01): 100 steps, {args.repeats} repeats, {load}")
    print(_table(columns))


if __name__ == "__main__":
    main()
