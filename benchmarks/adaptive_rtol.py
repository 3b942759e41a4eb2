"""Tolerance proportionality of the adaptive pairs: global error / rtol, lieint's pairs beside scipy's.

The 3D Euler top, I = (1, 2, 3), atol = 1e-3·rtol; error = max over the accepted steps of
|A − A_exact|_F / |A₀|_F (Jacobi elliptic solution). Two cases: a generic motion
(ω₀ = (0.3, 0.5, 1), T = 100) and the Dzhanibekov top near the separatrix
(ω₀ = (0.01, 1, 0.01), T = 60). Each row prints error/rtol and the accepted steps of every pair.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/adaptive_rtol.py [--quick] [--local] \\
        [--energy] [--energy-pairs [--no-R]] [--equal-steps]

``--quick`` runs rtol 1e-4 … 1e-8 only (the rkmk23 rows at 1e-9 and 1e-10 take ~10⁵ steps).
``--energy`` prints, instead, the experiment that tests the explanation in docs/theory.md §13
(tables: docs/measurements/adaptive.md): rkmk45 whose every accepted state is moved along its group orbit
(so the Casimir stays exact) back onto the initial energy level, beside rkmk45 and RK45.
``--energy-pairs [--no-R]`` prints global error / rtol of every pair, the same pair with the
energy kept (``rkmk23+energy`` …, :mod:`lieint.methods.energy_projection`) and scipy's pair,
on A alone with ``--no-R`` (the same state for both kinds of pair), or on the top with R, where
each cell gives A's and R's error / rtol (scipy's steps are then set by its error in R).
``--equal-steps`` prints the median ratio of rkmk853's local error in A to classical DOP853's
from the same states with the same steps (the Lie step's error scales with its increment).
``--local`` prints where each pair's local error sits: for every accepted step of rkmk853 and
of scipy's DOP853 (stepped one step at a time through ``scipy.integrate.DOP853``) on both
cases at rtol 1e-8, the true local error (one step from the numerical state against the
Jacobi-elliptic solution from that state) split into its A and R parts, |δA|_F/rtol and
|δR|_F/rtol, and the true error over the pair's own estimate in the controller's norm —
medians and 90th percentiles over the run.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np

import lieint
from lieint.groups.so import so_exp
from lieint.methods.base import Method, StepResult

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


@dataclass(frozen=True)
class EnergyOnOrbit(Method):
    """rkmk45, then ``y ← ρ(exp(sη), y)`` with ``η = [Ω, A] − [Ω, A]ᵀ`` and s from two Newton
    steps so that the energy is the initial one (an experiment, not a lieint method)."""

    name: str = "rkmk45+E"
    order: int = 5
    adaptive = True
    group_action = True

    @property
    def error_order(self) -> int:
        return 4

    def init(self, system, t0, y0, h):
        return float(system.energy(y0["A"]))

    def step(self, system, t, y, h, E0):
        result = lieint.get_method("rkmk45").step(system, t, y, h, None)
        y1 = result.y
        Omega = system.angular_velocity(y1["A"])
        eta = Omega @ y1["A"] - y1["A"] @ Omega
        eta = eta - eta.T
        for _ in range(2):

            def gap(s, y1=y1):
                return float(system.energy(system.act(so_exp(s * eta), y1)["A"])) - E0

            slope = (gap(1e-6) - gap(-1e-6)) / 2e-6
            y1 = system.act(so_exp(-gap(0.0) / slope * eta), y1)
        return StepResult(y1, result.error, result.nfev, E0)


def energy_experiment() -> None:
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    for label, (w0, T) in CASES.items():
        y0 = top.initial_state(angular_velocity=w0)
        print(f"\n{label}: global error / rtol (accepted steps)")
        print("rtol    " + "".join(f"{m:>22}" for m in ("rkmk45+E", "rkmk45", "scipy:RK45")))
        for rtol in (1e-6, 1e-8):
            cells = [
                f"{r:>13.3g} ({n:>6})"
                for r, n in (ratio(top, y0, T, m, rtol) for m in (EnergyOnOrbit(), "rkmk45", "scipy:RK45"))
            ]
            print(f"{rtol:<8.0e}" + "".join(cells), flush=True)


def _exact_step(top, y, h):
    """The exact state a time h after ``y`` (R first put on SO(3): scipy's R drifts off it by
    ~1e-9, and that drift, carried along unchanged, is not part of the step's error)."""
    from lieint.groups.so import project_to_so

    R = y["R"]
    Rp = project_to_so(R)
    ex = top.exact_solution(np.array([0.0, h]), {"A": 0.5 * (y["A"] - y["A"].T), "R": Rp})
    return {"A": ex["A"][1], "R": ex["R"][1] @ Rp.T @ R}


def _lie_local(top, y0, T, rtol):
    from lieint.control import StepSizeController

    control = StepSizeController(rtol, 1e-3 * rtol)
    method = lieint.get_method("rkmk853")
    sol = lieint.integrate(top, y0, (0.0, T), method="rkmk853", rtol=rtol, atol=1e-3 * rtol)
    rows = []
    for k in range(1, len(sol.t) - 1):  # the first step (h ~ 1e-3) is at round-off
        y = {f: sol.states[f][k] for f in sol.states}
        h = sol.t[k + 1] - sol.t[k]
        result = method.step(top, sol.t[k], y, h, None)
        exact = _exact_step(top, y, h)
        true = {f: result.y[f] - exact[f] for f in result.y}
        estimate = control.error_norm(y, result.y, result.error)
        rows.append(_row(true, control.error_norm(y, result.y, true), estimate, rtol))
    return rows


def _scipy_local(top, y0, T, rtol):
    from scipy.integrate import DOP853

    atol = 1e-3 * rtol

    def split(v):
        return {"A": v[:9].reshape(3, 3), "R": v[9:].reshape(3, 3)}

    def f(t, v):
        d = top.vector_field(t, split(v))
        return np.concatenate([d["A"].ravel(), d["R"].ravel()])

    solver = DOP853(f, 0.0, np.concatenate([y0["A"].ravel(), y0["R"].ravel()]), T, rtol=rtol, atol=atol)
    rows, first = [], True
    while solver.status == "running":
        t_old, v_old = solver.t, solver.y.copy()
        solver.step()
        if first:
            first = False
            continue
        h = solver.t - t_old
        scale = atol + rtol * np.maximum(np.abs(v_old), np.abs(solver.y))
        estimate = solver._estimate_error_norm(solver.K, h, scale)
        exact = _exact_step(top, split(v_old), h)
        true = {k: v - exact[k] for k, v in split(solver.y).items()}
        flat = np.concatenate([true["A"].ravel(), true["R"].ravel()])
        rows.append(_row(true, float(np.sqrt(np.mean((flat / scale) ** 2))), estimate, rtol))
    return rows


def _row(true, true_norm, estimate, rtol):
    return np.linalg.norm(true["A"]) / rtol, np.linalg.norm(true["R"]) / rtol, true_norm / estimate


def local_split() -> None:
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    rtol = 1e-8
    print(f"true local error per accepted step, rtol {rtol:g}: median [90th percentile]")
    print(f"{'case':38}{'pair':14}{'steps':>6}{'|dA|/rtol':>22}{'|dR|/rtol':>22}{'true/estimate':>22}")
    for label, (w0, T) in CASES.items():
        y0 = top.initial_state(angular_velocity=w0)
        for name, rows in (("rkmk853", _lie_local(top, y0, T, rtol)), ("scipy:DOP853", _scipy_local(top, y0, T, rtol))):
            cells = "".join(f"{np.median(col):>11.2g} [{np.percentile(col, 90):>7.2g}]" for col in np.asarray(rows).T)
            print(f"{label:38}{name:14}{len(rows) + 1:>6}{cells}", flush=True)


def ratios_a_and_r(top, y0, T, method, rtol):
    """(max |A − A_exact|_F/|A₀|_F, max |R − R_exact|_F/|R₀|_F) over the accepted steps, / rtol."""
    sol = lieint.integrate(top, y0, (0.0, T), method=method, rtol=rtol, atol=1e-3 * rtol)
    exact = top.exact_solution(sol.t, y0)
    errors = [
        np.max(np.linalg.norm(sol.states[f] - exact[f], axis=(-2, -1))) / np.linalg.norm(y0[f]) for f in ("A", "R")
    ]
    return errors[0] / rtol, errors[1] / rtol, sol.stats.nsteps


def equal_steps() -> None:
    """The local error in A of one rkmk853 step and of one classical DOP853 step (scipy's
    tableau, ``rk_step``) from the same states with the same h — the accepted states and steps
    of an ``rkmk853+energy`` run on A alone — against the elliptic solution from each state."""
    from scipy.integrate._ivp.rk import DOP853, rk_step

    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0], orientation=False)
    lie = lieint.get_method("rkmk853")

    def field(t, z):
        return top.vector_field(t, {"A": z.reshape(3, 3)})["A"].ravel()

    print("case                                   rtol   steps  median |δA| rkmk853 / DOP853")
    for label, (w0, T) in CASES.items():
        y0 = top.initial_state(angular_velocity=w0)
        for rtol in (1e-6, 1e-10):
            sol = lieint.integrate(top, y0, (0.0, T), method="rkmk853+energy", rtol=rtol, atol=1e-3 * rtol)
            ratios = []
            for k in range(1, len(sol.t) - 1):
                A, h = sol.states["A"][k], sol.t[k + 1] - sol.t[k]
                exact = top.exact_solution(np.array([0.0, h]), {"A": A})["A"][1]
                mine = lie.step(top, 0.0, {"A": A}, h, None).y["A"]
                z, K = A.ravel(), np.empty((DOP853.n_stages + 1, 9))
                theirs, _ = rk_step(field, 0.0, z, field(0.0, z), h, DOP853.A, DOP853.B, DOP853.C, K)
                ratios.append(np.linalg.norm(mine - exact) / np.linalg.norm(theirs.reshape(3, 3) - exact))
            print(f"{label:38}{rtol:<7.0e}{len(sol.t) - 1:>6}  {np.median(ratios):.3g}", flush=True)


def energy_pairs(with_attitude: bool) -> None:
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0], orientation=with_attitude)
    triples = [(lie, f"{lie}+energy", scipy) for lie, scipy in PAIRS]
    for label, (w0, T) in CASES.items():
        y0 = top.initial_state(angular_velocity=w0)
        what = "A and R: A's / R's global error / rtol" if with_attitude else "A only: global error / rtol"
        print(f"\n{label}, {what} (accepted steps)")
        print("rtol    " + "".join(f"{m:>22}" for triple in triples for m in triple))
        for rtol in [10.0**-k for k in range(4, 11)]:
            cells = []
            for triple in triples:
                for m in triple:
                    if m.startswith("rkmk23") and rtol < 1e-8:  # ~10⁵ steps
                        cells.append(f"{'-':>22}")
                        continue
                    if with_attitude:  # A's and R's error / rtol
                        a, r, n = ratios_a_and_r(top, y0, T, m, rtol)
                        cells.append(f"{a:>7.3g}/{r:<7.3g}({n:>6})")
                        continue
                    r, n = ratio(top, y0, T, m, rtol)
                    cells.append(f"{r:>13.3g} ({n:>6})")
            print(f"{rtol:<8.0e}" + "".join(cells), flush=True)


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
    if "--energy" in sys.argv:
        energy_experiment()
    elif "--energy-pairs" in sys.argv:
        energy_pairs("--no-R" not in sys.argv)
    elif "--local" in sys.argv:
        local_split()
    elif "--equal-steps" in sys.argv:
        equal_steps()
    else:
        main("--quick" in sys.argv)
