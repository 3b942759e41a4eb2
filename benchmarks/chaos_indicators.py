"""MEGNO and the largest Lyapunov exponent of integrable and chaotic tops at T = 2000 (and 4000).

Integrable: the 3D free top, the 4D (Manakov) top, the Lagrange and Kovalevskaya tops, the 3D
Chaplygin ball (MEGNO → 2, the largest exponent → 0 like log(t)/t); chaotic: a generic heavy
top at an energy where it is (MEGNO grows, the exponent stays). Open: the 4D Chaplygin ball
(a generic mass tensor), whose integrability the counting leaves undecided. Every case is one call of ``lieint.megno`` /
``lieint.lyapunov`` on the exact tangent map of the method (rkmk4, h as printed), so the
numbers are reproducible: ``python benchmarks/chaos_indicators.py [--T 2000] [--h 0.05]
[--only NAME] [--lyapunov] [--spectrum] [--vectors N]``. ``--vectors N`` runs N random
initial tangent vectors at once (a batch of the same state) and prints the range of ⟨Y⟩: on a
torus its approach to 2 depends on the vector. Prints the load average (the cost column is a
time on a shared machine).
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import lieint


def cases() -> dict:
    """name → (system, initial state): the same bodies as tests/tangent/test_chaos.py."""
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0], orientation=False)
    lag = lieint.HeavyTop.lagrange(1.0, 0.5, mass=1.0, length=0.2, orientation=False)
    kov = lieint.HeavyTop.kovalevskaya(1.0, mass=1.0, length=0.1, orientation=False)
    B = lieint.EulerTop.from_principal_moments([1.0, 1.5, 2.0]).B
    w = np.array([1.0, 2.0, 1.5])
    generic = lieint.HeavyTop(B, 1.0, [0.1, 0.05, 0.08], [0.0, 0.0, -9.81], orientation=False)
    ball = lieint.ChaplyginBall(np.diag([0.08, 0.12, 0.16]), 1.0, 1.0, orientation=False, track_center=False)
    top4 = lieint.EulerTop(np.diag([0.6, 0.9, 1.2, 1.5]), orientation=False)
    rng = np.random.default_rng(4)
    Q, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    ball4 = lieint.ChaplyginBall(Q @ np.diag([0.06, 0.09, 0.12, 0.15]) @ Q.T, 1.0, 1.0, orientation=False,
                                 track_center=False)  # fmt: skip
    X = rng.normal(size=(4, 4))
    return {
        "free top 3D": (top, top.initial_state(angular_velocity=[1.0, 0.3, 0.2])),
        "Manakov top 4D": (top4, top4.initial_state(Omega=0.5 * (X - X.T))),
        "Chaplygin ball 4D (open)": (ball4, ball4.initial_state(Omega=0.5 * (X - X.T))),
        "free top 3D near the separatrix": (top, top.initial_state(angular_velocity=[0.3, 1.0, 0.4])),
        "Lagrange top": (lag, lag.initial_state(angular_velocity=[1.0, 0.5, 5.0])),
        "Kovalevskaya top": (kov, kov.initial_state(angular_velocity=[1.0, 0.5, 1.0])),
        "Chaplygin ball 3D": (ball, ball.initial_state(Omega=lieint.groups.bivectors.hat([0.3, 1.0, 0.4]))),
        "generic heavy top": (generic, generic.initial_state(angular_velocity=2.0 * w / np.linalg.norm(w))),
        "generic heavy top, energy 6.5": (generic, generic.initial_state(angular_velocity=w)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--T", type=float, default=2000.0)
    parser.add_argument("--h", type=float, default=0.05)
    parser.add_argument("--only", default="")
    parser.add_argument("--lyapunov", action="store_true", help="also the largest exponent by lieint.lyapunov")
    parser.add_argument("--spectrum", action="store_true", help="the whole spectrum and its ± pairing")
    parser.add_argument("--vectors", type=int, default=1, help="MEGNO of N random initial tangent vectors")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f}; T = {args.T:g}, h = {args.h:g}, method rkmk4")
    for name, (system, y0) in cases().items():
        if args.only and args.only.lower() not in name.lower():
            continue
        start = time.perf_counter()
        if args.vectors > 1:
            batch = {k: np.repeat(np.asarray(v)[None], args.vectors, axis=0) for k, v in y0.items()}
            m = lieint.megno(system, batch, (0.0, args.T), h=args.h, save_every=max(1, round(args.T / args.h / 40)))
            half = m.mean_history[np.searchsorted(m.t, args.T / 2 - 1e-9)]
            print(
                f"{name:20s} {args.vectors} vectors: <Y>(T/2) {half.min():.3f} – {half.max():.3f}  "
                f"<Y>(T) {m.mean.min():.3f} – {m.mean.max():.3f}  ({time.perf_counter() - start:.0f} s)",
                flush=True,
            )
            # on a torus 2 − <Y> = (C log t + D)/t: fitted on [T/4, T], extrapolated to 2T and 4T
            late = m.t >= args.T / 4
            for b in range(args.vectors):
                C, D = np.polyfit(np.log(m.t[late]), m.t[late] * (2.0 - m.mean_history[late, b]), 1)
                ahead = [2.0 - (C * np.log(k * args.T) + D) / (k * args.T) for k in (2, 4)]
                print(
                    f"    vector {b}: <Y>(T) {m.mean[b]:.3f}, C = {C:.1f}, D = {D:.1f}; "
                    f"predicted <Y>(2T) {ahead[0]:.3f}, <Y>(4T) {ahead[1]:.3f}"
                )
            continue
        m = lieint.megno(system, y0, (0.0, args.T), h=args.h, save_every=max(1, round(args.T / args.h / 40)))
        half = m.mean_history[np.searchsorted(m.t, args.T / 2 - 1e-9)]
        line = (
            f"{name:20s} <Y>(T/2) = {float(half):8.3f}  <Y>(T) = {float(m.mean):8.3f}  λ(|δ|) = {float(m.lyapunov):.4f}"
        )
        if args.lyapunov or args.spectrum:
            spec = lieint.lyapunov(system, y0, (0.0, args.T), h=args.h, k=None if args.spectrum else 1)
            line += f"  λ₁ = {spec.exponents[0]:.4f}"
            if args.spectrum:
                line += (
                    f"  spectrum {np.array2string(spec.exponents, precision=4)}  pairing {spec.pairing_defect():.1e}"
                )
        print(f"{line}  ({time.perf_counter() - start:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
