"""Figures of geometric algebra in lieint: the exponential, the rotor forms, the PGA motor body.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/ga_figures.py [--quick] [--part exp|rotor|motor|speed]``

Prints

1. ``lieint.ga.exp`` against mpmath (50 digits) for random non-simple bivectors, n = 4…8, with
   scipy's ``expm`` of the skew matrix and clifford's own ``MultiVector.exp`` beside it;
2. rotor form vs matrix form of every rigid body over 10⁴ RKMK4 steps: ``max |R_matrix − R(rotor)|``,
   the other fields, the drift of Casimirs and energy of both; and the *baseline* of each
   problem: the same matrix run from an initial state moved by one ulp (how much round-off the
   problem itself amplifies over that run);
3. ``MotorRigidBody`` vs ``FreeBody`` and ``HeavyTop`` over T = 50, the motor defect, fitted orders;
4. speed: seconds per step of the rotor / motor paths and of the matrix paths (generic numpy
   path, the one they share), measured side by side (interleaved, best of several), and ratios.
"""

from __future__ import annotations

import argparse
import time

import mpmath
import numpy as np
import scipy.linalg

import lieint
from lieint import ga
from lieint.ga import MotorRigidBody, RotorForm
from lieint.ga.motor import MotorGroup

B3 = np.diag([1.0, 2.0, 3.0])
B_BALL = np.diag([0.2, 0.3, 0.4])


def exp_figures(trials: int) -> None:
    print("1. e^{ω/2} of random non-simple bivectors: max relative error of R against mpmath expm (50 digits)")
    print(f"   {'n':>2} {'lieint.ga.exp':>14} {'scipy expm':>11} {'clifford exp':>13}")
    rng = np.random.default_rng(1)
    mpmath.mp.dps = 50
    for n in range(4, 9):
        worst = np.zeros(3)
        for _ in range(trials):
            X = rng.normal(size=(n, n))
            X = X - X.T
            ref = np.array(mpmath.expm(mpmath.matrix(X.tolist())).tolist(), dtype=float)
            B = ga.skew_to_bivector(X) / 2
            ours = ga.rotor_to_matrix(ga.exp(B))
            theirs = ga.rotor_to_matrix(B.exp())
            E = scipy.linalg.expm(X)
            for i, Q in enumerate((ours, E, theirs)):
                worst[i] = max(worst[i], np.linalg.norm(Q - ref) / np.linalg.norm(ref))
        print(f"   {n:>2} {worst[0]:>14.1e} {worst[1]:>11.1e} {worst[2]:>13.1e}")


def rotor_cases():
    rng = np.random.default_rng(7)
    X4 = rng.normal(size=(4, 4))
    return {
        "EulerTop n=3": (lieint.EulerTop(B3), {"angular_velocity": [0.3, 1.0, 0.2]}),
        "EulerTop n=4": (lieint.EulerTop(np.diag([1.0, 1.5, 2.2, 3.0])), {"Omega": X4 - X4.T}),
        "Lagrange top": (lieint.HeavyTop.lagrange(1.0, 0.5, 1.0, 0.3), {"angular_velocity": [0.1, 0.2, 5.0]}),
        "FreeBody": (
            lieint.FreeBody(B3, 2.0, [0.0, 0.0, -9.81]),
            {"angular_velocity": [0.3, 1.0, 0.2], "velocity": [1.0, 0.0, 2.0]},
        ),
        "RollingBall": (
            lieint.RollingBall(B_BALL, 1.0, 1.0, center_of_mass=[0.1, 0.0, 0.05], gravity=[0, 0, -9.81]),
            {"angular_velocity": [0.3, 1.0, 0.2]},
        ),
        "ChaplyginBall": (lieint.ChaplyginBall(B_BALL, 1.0, 1.0), {"angular_velocity": [0.3, 1.0, 0.2]}),
    }


def _ulp_moved(y):
    return {k: v * (1.0 + np.finfo(float).eps) for k, v in y.items()}


def rotor_figures(steps: int, h: float) -> None:
    print(f"\n2. rotor form vs matrix form, {steps} RKMK4 steps of h = {h}")
    print(
        f"   {'system':<14} {'|ΔR|':>8} {'baseline':>8} {'other':>8} {'rotor':>8} "
        f"{'Casimir drift m/r':>18} {'energy drift m/r':>18}"
    )
    T = steps * h
    for name, (system, kw) in rotor_cases().items():
        rotor = RotorForm(system)
        y0 = system.initial_state(**kw)
        opts = dict(method="rkmk4", h=h, save_every=steps // 20)
        a = lieint.integrate(system, y0, (0, T), backend="numpy", **opts)
        base = lieint.integrate(system, _ulp_moved(y0), (0, T), backend="numpy", **opts)
        b = lieint.integrate(rotor, rotor.initial_state(**kw), (0, T), **opts)
        dR = np.max(np.abs(ga.rotor_to_matrix(b.states["rotor"], n=system.n) - a.states["R"]))
        dbase = np.max(np.abs(base.states["R"] - a.states["R"]))
        other = max((np.max(np.abs(a.states[k] - b.states[k])) for k in system.fields if k != "R"), default=0.0)
        cas = f"{a.drift('casimirs'):.1e}/{b.drift('casimirs'):.1e}" if "casimirs" in system.invariants else "-"
        en = f"{a.drift('energy'):.1e}/{b.drift('energy'):.1e}"
        print(
            f"   {name:<14} {dR:>8.1e} {dbase:>8.1e} {other:>8.1e} {b.drift('rotor_defect'):>8.1e} {cas:>18} {en:>18}"
        )


def motor_figures(T: float) -> None:
    print(f"\n3. MotorRigidBody (PGA motors) vs the matrix systems, T = {T}, RKMK4")
    kw = dict(angular_velocity=[0.3, 1.0, 0.2], velocity=[1.0, 0.0, 2.0], center=[0.1, 0.2, 0.3])
    for gravity in (None, [0.0, 0.0, -9.81]):
        free, motor = lieint.FreeBody(B3, 2.0, gravity), MotorRigidBody(B3, 2.0, gravity)
        for h in (0.004, 0.002, 0.001):
            a = lieint.integrate(free, free.initial_state(**kw), (0, T), h=h, backend="numpy", save_every=100)
            b = lieint.integrate(motor, motor.initial_state(**kw), (0, T), h=h, save_every=100)
            out = b.outputs(["R", "center"])
            dR = np.max(np.abs(out["R"] - a.states["R"]))
            print(
                f"   vs FreeBody (gravity {gravity is not None!s:<5}) h={h}: |ΔR| {dR:.1e}"
                f"  |Δcenter| {np.max(np.abs(out['center'] - a.states['center'])):.1e}"
                f"  motor defect {b.drift('motor_defect'):.1e}"
            )
    ht = lieint.HeavyTop(B3, 1.0, [0.0, 0.1, 0.3], [0.0, 0.0, -9.81])
    mt = MotorRigidBody(B3, 1.0, [0.0, 0.0, -9.81], fixed_point=True, center_of_mass=[0.0, 0.1, 0.3])
    w = [0.3, 1.0, 0.4]
    for h in (0.005, 0.0025, 0.00125):
        a = lieint.integrate(ht, ht.initial_state(angular_velocity=w), (0, T), h=h, backend="numpy", save_every=100)
        b = lieint.integrate(mt, mt.initial_state(angular_velocity=w), (0, T), h=h, save_every=100, project=True)
        print(
            f"   vs HeavyTop h={h}: |ΔR| {np.max(np.abs(b.outputs(['R'])['R'] - a.states['R'])):.1e}"
            f"  motor defect (projected) {b.drift('motor_defect'):.1e}  vertical momentum drift "
            f"{b.drift('vertical_momentum'):.1e}  energy drift {b.drift('energy'):.1e} "
            f"(HeavyTop {a.drift('energy'):.1e})"
        )
    body = MotorRigidBody(
        B3, 2.0, [0, 0, -9.81], springs=[[0.5, 0, 0, 0.6, 0, 1, 30, 0.2], [-0.5, 0, 0, -0.6, 0.1, 1, 20, 0.3]]
    )
    y0 = body.initial_state(angular_velocity=[0.3, 1.0, 0.2], velocity=[0.2, 0, 0.1])
    ref = lieint.integrate(body, y0, (0, 1.0), h=1 / 1024, method="rkmk6")
    ref_pose = MotorGroup().matrix(ref.states["motor"][-1])
    orders = []
    for name, ns in {
        "lie_euler": (200, 400, 800),
        "rkmk2": (50, 100, 200),
        "rkmk3": (25, 50, 100),
        "rkmk4": (20, 40, 80),
        "rkmk6": (16, 24, 32),
    }.items():
        errs = [
            np.max(
                np.abs(
                    MotorGroup().matrix(lieint.integrate(body, y0, (0, 1.0), h=1 / n, method=name).states["motor"][-1])
                    - ref_pose
                )
            )
            for n in ns
        ]
        hs = [1 / n for n in ns]
        orders.append(f"{name} {np.polyfit(np.log(hs), np.log(errs), 1)[0]:.2f}")
    print(
        "   fitted orders on the motor group (body on two springs under gravity, pose at T = 1): " + ", ".join(orders)
    )


def speed_figures(steps: int, reps: int) -> None:
    print(f"\n4. speed: CPU µs per RKMK4 step, best of {reps} interleaved runs of {steps} steps (generic numpy path)")
    h = 0.001
    pairs = []
    for name, (system, kw) in rotor_cases().items():
        rotor = RotorForm(system)
        pairs.append((name + " rotor", system, system.initial_state(**kw), rotor, rotor.initial_state(**kw)))
    kw = dict(angular_velocity=[0.3, 1.0, 0.2], velocity=[1.0, 0.0, 2.0])
    free, motor = lieint.FreeBody(B3, 2.0, [0, 0, -9.81]), MotorRigidBody(B3, 2.0, [0, 0, -9.81])
    pairs.append(("motor vs FreeBody", free, free.initial_state(**kw), motor, motor.initial_state(**kw)))
    ht = lieint.HeavyTop(B3, 1.0, [0.0, 0.1, 0.3], [0.0, 0.0, -9.81])
    mt = MotorRigidBody(B3, 1.0, [0.0, 0.0, -9.81], fixed_point=True, center_of_mass=[0.0, 0.1, 0.3])
    pairs.append(
        (
            "motor vs HeavyTop",
            ht,
            ht.initial_state(angular_velocity=[0.3, 1, 0.4]),
            mt,
            mt.initial_state(angular_velocity=[0.3, 1, 0.4]),
        )
    )
    print(f"   {'path':<22} {'matrix':>8} {'GA':>8} {'ratio':>6}")
    for label, sm, ym, sg, yg in pairs:
        best = [np.inf, np.inf]
        for _ in range(reps):
            for i, (s, y) in enumerate(((sm, ym), (sg, yg))):
                t0 = time.process_time()
                lieint.integrate(s, y, (0, steps * h), h=h, method="rkmk4", backend="numpy")
                best[i] = min(best[i], time.process_time() - t0)
        us = [b / steps * 1e6 for b in best]
        print(f"   {label:<22} {us[0]:>8.0f} {us[1]:>8.0f} {us[1] / us[0]:>6.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller runs (a smoke test of this script)")
    parser.add_argument("--part", choices=["all", "exp", "rotor", "motor", "speed"], default="all")
    args = parser.parse_args()
    run = {p: args.part in ("all", p) for p in ("exp", "rotor", "motor", "speed")}
    if run["exp"]:
        exp_figures(1 if args.quick else 5)
    if run["rotor"]:
        for h in (0.001,) if args.quick else (0.001, 0.01):
            rotor_figures(1000 if args.quick else 10_000, h)
    if run["motor"]:
        motor_figures(2.0 if args.quick else 50.0)
    if run["speed"]:
        speed_figures(200, 2) if args.quick else speed_figures(1500, 5)


if __name__ == "__main__":
    main()
