"""Figures of the one stepper contract and the one driver, printed from one run.

Every registered method on the embedded Lagrange top through :func:`lieint.integrate` and a
streamed run (:func:`lieint.run`); the same drift from both front ends; Cayley against
exponential coordinates for an adaptive pair; per-member ensemble drift against a norm pooled
over the members (the definition that understated each member's drift); scipy's real step
counts. Run::

    OPENBLAS_NUM_THREADS=1 python benchmarks/contract_figures.py
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import numpy as np

import lieint
from lieint.methods.registry import method_specs
from lieint.scenes import embedded_scene
from lieint.scenes.engine import build_system, scene_solver_options


def every_method_in_both_front_ends() -> None:
    scene = embedded_scene("lagrange_top")
    system, y0 = build_system(scene)
    print("every registered method, Lagrange top, T = 10 (integrate | streamed run):")
    print(f"  {'method':14s} {'steps':>6s} {'nfev':>6s} {'energy drift':>13s} {'streamed':>13s}")
    with tempfile.TemporaryDirectory() as tmp:
        for name in lieint.method_names():
            options = scene_solver_options(scene) | {"method": name}
            if not method_specs()[name].coordinates:
                options["coordinates"] = None
            sol = lieint.integrate(system, y0, (scene.t_start, scene.t_end), **options)
            streamed_scene = dataclasses.replace(scene, method=name, coordinates=options["coordinates"])
            report = lieint.run(streamed_scene, Path(tmp) / f"{name.replace(':', '_')}.h5", progress=False)
            print(
                f"  {name:14s} {sol.nsteps:6d} {sol.nfev:6d} {sol.drift('energy'):13.3e} "
                f"{report.drifts.get('energy', float('nan')):13.3e}  {report.status}"
            )


def cayley_against_exp() -> None:
    scene = embedded_scene("lagrange_top")
    system, y0 = build_system(scene)
    finals = {}
    for coordinates in ("exp", "cayley"):
        sol = lieint.integrate(system, y0, (0.0, 10.0), method="rkmk45", coordinates=coordinates, rtol=1e-6)
        finals[coordinates] = sol.states["A"][-1]
    print(
        f"rkmk45 rtol 1e-6: final A, Cayley minus exponential coordinates: "
        f"{np.abs(finals['exp'] - finals['cayley']).max():.2e} (the coordinates are honoured)"
    )


def ensemble_drift_per_member(members: int = 200) -> None:
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    rng = np.random.default_rng(1)
    w = np.array([0.01, 1.0, 0.01]) + 0.05 * rng.standard_normal((members, 3))
    y0 = top.initial_state(angular_velocity=w)
    sol = lieint.integrate(top, y0, (0.0, 100.0), h=0.05, method="rkmk4", backend="numpy")
    energy = sol.invariants["energy"]  # (time, members)
    per_member = sol.drift("energy")
    pooled = np.abs(energy - energy[0]).max(axis=0) / np.linalg.norm(energy[0])
    print(
        f"{members}-member ensemble, RKMK4 h = 0.05, T = 100: worst member's energy drift "
        f"{per_member.max():.2e}; pooled-norm definition {pooled.max():.2e} "
        f"({per_member.max() / pooled.max():.1f}x understated, sqrt(members) = {np.sqrt(members):.1f})"
    )


def scipy_step_counts() -> None:
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 0.5, 1.0])
    for name in ("scipy:DOP853", "scipy:RK45", "scipy:BDF"):
        sol = lieint.integrate(top, y0, (0.0, 10.0), h=0.1, method=name, rtol=1e-9, atol=1e-12)
        print(f"{name:13s} T = 10, rtol 1e-9: nsteps {sol.nsteps}, nfev {sol.nfev}")


if __name__ == "__main__":
    every_method_in_both_front_ends()
    cayley_against_exp()
    ensemble_drift_per_member()
    scipy_step_counts()
