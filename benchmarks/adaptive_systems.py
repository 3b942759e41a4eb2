"""Global error per rtol of the adaptive methods on every built-in system, beside scipy's pairs.

Five problems, each with the whole state in the error (every field the system integrates):

* ``free top`` — the 3D Euler top I = (1, 2, 3) near its unstable axis, ω₀ = (0.01, 1, 0.01),
  with the attitude R, T = 100; the truth is the Jacobi-elliptic solution (``exact_solution``);
* ``heavy top`` — asymmetric (principal moments (1, 1.2, 0.5)), centre of mass (0, 0.05, 0.3),
  tilted by 0.4 rad about e₁ and spinning fast, ω₀ = (0.2, 0.1, 10), T = 10;
* ``offset ball``, ``Chaplygin ball``, ``4D top`` — the embedded scenes ``offset_ball``,
  ``chaplygin_ball`` and ``manakov_4d``, T = 10, 10 and 20.

Without a closed form the truth is scipy's DOP853 at rtol 1e-14 (scipy's floor, 2.2e-14), atol
1e-16 on the equations written out in numpy (``benchmarks/lean_rhs.py``, checked against
``system.vector_field`` first): code that shares nothing with lieint's steppers; the script
prints its distance to the same integration at 3× the tolerances. The error of a run is
``‖y(T) − y_ref(T)‖₂ / ‖y_ref(T)‖₂`` over the flat state, atol = 1e-3·rtol.

    OPENBLAS_NUM_THREADS=1 python benchmarks/adaptive_systems.py [--local] [--rtols 1e-6,1e-8,1e-10]
        [--systems "heavy top,free top"] [--methods rkmk853+energy,rkmk853,scipy:DOP853]

A method is named as in the registry, optionally ``NAME:COORDINATES`` and ``NAME@DEGREE`` (the
dexp⁻¹ series truncated after ``ad_u^DEGREE``; ``@exact`` for the exact dexp⁻¹). Each cell is
global error / rtol and the accepted steps. ``--flips`` prints the error of the Dzhanibekov flip times located as events
(I = (1, 2, 3), ω₀ = (0.01, 1, 0.01), T = 60, rtol 1e-10, atol 1e-12) against
``lieint.euler_top_flip_times``.
``--growth`` prints the global error at T/8, T/4, T/2 and T at the first rtol and the exponent of
its growth (1: like t; 2: like t²).
``--local`` prints instead, for each method on each
system at one rtol (the first of ``--rtols``), the true local error of every accepted step (one
step from the numerical state against the reference from that state) over the pair's own error
estimate, in the controller's norm: median and 90th percentile — how well the estimate that
chooses the steps sees the step's error.
"""

from __future__ import annotations

import argparse

import lean_rhs
import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import lieint
from lieint.control import StepSizeController
from lieint.scenes import build_system, embedded_scene
from lieint.systems.mass import moments_tensor

DEFAULT_METHODS = (
    "rkmk45+energy",
    "scipy:RK45",
    "rkmk853+energy",
    "rkmk853+energy:cayley",
    "rkmk853",
    "scipy:DOP853",
)


def problems() -> dict:
    """name → (system, y0, T)."""
    out = {}
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    out["free top"] = (top, top.initial_state(angular_velocity=[0.01, 1.0, 0.01]), 100.0)
    heavy = lieint.HeavyTop(moments_tensor([1.0, 1.2, 0.5], "moments"), 1.0, [0.0, 0.05, 0.3], [0.0, 0.0, -9.81])
    tilt = Rotation.from_rotvec([0.4, 0.0, 0.0]).as_matrix()
    out["heavy top"] = (heavy, heavy.initial_state(angular_velocity=[0.2, 0.1, 10.0], R=tilt), 10.0)
    for label, scene, T in (("offset ball", "offset_ball", 10.0), ("Chaplygin ball", "chaplygin_ball", 10.0),
                            ("4D top", "manakov_4d", 20.0)):  # fmt: skip
        system, y0 = build_system(embedded_scene(scene))
        out[label] = (system, y0, T)
    return out


def build_method(spec: str):
    """``NAME[:COORDINATES][@DEGREE]`` → the method (scipy's by name)."""
    name, _, degree = spec.partition("@")
    name, _, coordinates = name.partition(":")
    if name == "scipy":  # "scipy:DOP853" has no coordinates
        return spec
    options = {}
    if degree:
        options["dexpinv_degree"] = None if degree == "exact" else int(degree)
    return lieint.get_method(name, coordinates=coordinates or None, **options)


class Truth:
    """The reference solution of one problem: exact where the system has it, else tight DOP853."""

    def __init__(self, system, y0, T):
        self.system, self.y0, self.T = system, y0, T
        self.exact = isinstance(system, lieint.EulerTop) and system.n == 3
        if not self.exact:
            lean_rhs.check(system, y0)
            self.rhs = lean_rhs.lean_rhs(system)

    def flow(self, y, h, tolerance=1.0):
        """The state a time h after y, flat."""
        if self.exact:
            ex = self.system.exact_solution(np.array([0.0, h]), y)
            return lean_rhs.flatten(self.system, {k: v[-1] for k, v in ex.items()})
        z = lean_rhs.flatten(self.system, y)
        return solve_ivp(self.rhs, (0.0, h), z, method="DOP853", rtol=2.3e-14 * tolerance,
                         atol=1e-16 * tolerance).y[:, -1]  # fmt: skip

    def reference_spread(self) -> float:
        if self.exact:
            return 0.0
        a, b = self.flow(self.y0, self.T), self.flow(self.y0, self.T, 3.0)
        return float(np.linalg.norm(a - b) / np.linalg.norm(a))


def global_ratio(truth: Truth, end, method, rtol):
    system, y0, T = truth.system, truth.y0, truth.T
    sol = lieint.integrate(system, y0, (0.0, T), method=method, rtol=rtol, atol=1e-3 * rtol)
    z = lean_rhs.flatten(system, {k: v[-1] for k, v in sol.states.items()})
    return float(np.linalg.norm(z - end) / np.linalg.norm(end)) / rtol, sol.stats.nsteps


def local_ratios(truth: Truth, method, rtol):
    """true local error / estimate (controller's norm) over the accepted steps of a Lie pair."""
    system, y0, T = truth.system, truth.y0, truth.T
    control = StepSizeController(rtol, 1e-3 * rtol)
    sol = lieint.integrate(system, y0, (0.0, T), method=method, rtol=rtol, atol=1e-3 * rtol)
    ratios = []
    for k in range(1, len(sol.t) - 1):  # the first step is at round-off
        y = {f: sol.states[f][k] for f in sol.states}
        h = sol.t[k + 1] - sol.t[k]
        result = method.step(system, sol.t[k], y, h, method.init(system, sol.t[k], y, h))
        exact = lean_rhs.unflatten(system, truth.flow(y, h))
        true = {f: result.y[f] - exact[f] for f in result.y}
        ratios.append(control.error_norm(y, result.y, true) / control.error_norm(y, result.y, result.error))
    return np.asarray(ratios)


def flips(specs) -> None:
    """The Dzhanibekov flips (I = (1, 2, 3), ω₀ = (0.01, 1, 0.01), T = 60) located as events at
    rtol 1e-10, atol 1e-12, against the exact flip times ``lieint.euler_top_flip_times``."""
    from lieint.groups import vee

    I, w0, T = [1.0, 2.0, 3.0], [0.01, 1.0, 0.01], 60.0
    top = lieint.EulerTop.from_principal_moments(I)
    y0 = top.initial_state(angular_velocity=w0)
    exact = lieint.euler_top_flip_times(I, w0, T)

    def flip(t, y):
        return vee(top.angular_velocity(y["A"]))[..., 1]

    print(f"Dzhanibekov flips, T = {T:g}, rtol 1e-10, atol 1e-12: max |t_event − t_exact| over {exact.size} flips")
    for spec in specs:
        sol = lieint.integrate(top, y0, (0.0, T), method=build_method(spec), rtol=1e-10, atol=1e-12, events=flip)
        found = sol.t_events[0]
        error = np.max(np.abs(found - exact)) if found.size == exact.size else float("nan")
        print(f"  {spec:28}{error:>10.2e} s  ({found.size} flips, {sol.stats.nsteps} steps)", flush=True)


def growth(truth: Truth, specs, rtol) -> None:
    """Global error at T/8, T/4, T/2, T and the exponent of its growth (least squares in log-log):
    about 1 for an error that grows like t, 2 like t²."""
    system, y0, T = truth.system, truth.y0, truth.T
    times = T * np.array([0.125, 0.25, 0.5, 1.0])
    ends = [truth.flow(y0, t) for t in times]
    for spec in specs:
        method = build_method(spec)
        sol = lieint.integrate(system, y0, (0.0, T), method=method, rtol=rtol, atol=1e-3 * rtol, t_eval=times)
        errors = []
        for k, end in enumerate(ends):
            z = lean_rhs.flatten(system, {f: v[k] for f, v in sol.states.items()})
            errors.append(np.linalg.norm(z - end) / np.linalg.norm(end))
        slope = np.polyfit(np.log(times), np.log(errors), 1)[0]
        cells = " ".join(f"{e:9.2e}" for e in errors)
        print(f"  {spec:28}{cells}   exponent {slope:5.2f}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rtols", default="1e-6,1e-8,1e-10")
    parser.add_argument("--systems", default="")
    parser.add_argument("--methods", default=",".join(DEFAULT_METHODS))
    parser.add_argument("--local", action="store_true")
    parser.add_argument("--flips", action="store_true")
    parser.add_argument("--growth", action="store_true")
    args = parser.parse_args()
    rtols = [float(r) for r in args.rtols.split(",")]
    specs = args.methods.split(",")
    if args.flips:
        flips(specs)
        return
    chosen = [s.strip() for s in args.systems.split(",") if s.strip()]
    for label, (system, y0, T) in problems().items():
        if chosen and label not in chosen:
            continue
        truth = Truth(system, y0, T)
        if args.growth:
            print(f"\n{label}, rtol {rtols[0]:g}: global error at T/8, T/4, T/2, T (T = {T:g})")
            growth(truth, [s for s in specs if not s.startswith("scipy")] + [s for s in specs if s.startswith("scipy")],
                   rtols[0])  # fmt: skip
            continue
        if args.local:
            print(f"\n{label}, T = {T:g}, rtol {rtols[0]:g}: true local error / estimate, median [90th percentile]")
            for spec in specs:
                if spec.startswith("scipy"):
                    continue
                r = local_ratios(truth, build_method(spec), rtols[0])
                print(f"  {spec:28}{np.median(r):>9.3g} [{np.percentile(r, 90):.3g}]  ({r.size + 1} steps)", flush=True)
            continue
        end = truth.flow(y0, T)
        spread = truth.reference_spread()
        print(f"\n{label}, T = {T:g}: global error / rtol (accepted steps); reference spread {spread:.1e}")
        print(f"| rtol | {' | '.join(specs)} |")
        print("|---" * (len(specs) + 1) + "|")
        for rtol in rtols:
            cells = []
            for spec in specs:
                r, n = global_ratio(truth, end, build_method(spec), rtol)
                cells.append(f"{r:.3g} ({n})")
            print(f"| {rtol:.0e} | {' | '.join(cells)} |", flush=True)


if __name__ == "__main__":
    main()
