"""Particle invariants over 10⁶ steps, the atoms against the Euler top, and the fitted orders of
the symplectic methods (docs/theory.md §8, §10).

Run: ``python benchmarks/particle_invariants.py`` (about four minutes; ``--steps 100000`` for a
shorter run). Prints, for each run, the largest deviation over every step:

* Kepler orbit, velocity Verlet: the bivector ``(q − C) ∧ q̇`` (relative) and the energy;
  RK4 beside it over the same steps (no momentum map: the bivector drifts);
* constant force, Verlet: ``e ∧ q̇``;
* a particle on the egg ``ρ² + z² + 0.3 z³ = 1`` under gravity along the axis, RATTLE:
  ``h(q) − 1``, ``⟨∇h, q̇⟩``, Clairaut's trivector ``(q − C) ∧ q̇ ∧ e₃`` and the energy;
* the atoms of docs/theory.md §8 (N = 6, 7, 9 in n = 3, 4, 5) against the Euler top with
  ``B = Σ mᵢ XᵢXᵢᵀ`` over t = 2, both DOP853 at rtol = atol = 1e-13;
* the orders of Verlet (harmonic orbit, exact) and RATTLE (great circle, exact; the egg against
  DOP853 at 1e-13), fitted by least squares over four halvings of h.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import lieint
from lieint.systems.surfaces import Sphere, SurfaceOfRevolution


def run(system, y0, method, h, steps, save_every):
    t0 = time.process_time()
    sol = lieint.integrate(system, y0, (0.0, h * steps), h=h, method=method, save_every=save_every)
    return sol, time.process_time() - t0


def fixed(system, y0, method, h, n):
    m = lieint.get_method(method)
    t, y, state = 0.0, y0, m.init(system, 0.0, y0, h)
    for _ in range(n):
        r = m.step(system, t, y, h, state)
        y, state, t = r.y, r.state, t + h
    return y


def slope(hs, errs):
    return float(np.polyfit(np.log(hs), np.log(errs), 1)[0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1_000_000, help="steps of each long run")
    parser.add_argument("--save-every", type=int, default=1, help="check the invariants every this many steps")
    args = parser.parse_args()
    N, every = args.steps, args.save_every

    print(f"== long runs: {N} steps each, invariants checked every {every} step(s)")
    kepler = lieint.CentralForceParticle(1.0, [0.0, 0.0, 0.0], "kepler")
    y0 = kepler.initial_state(position=[1.0, 0.0, 0.0], velocity=[0.0, 1.2, 0.1])
    sol, cpu = run(kepler, y0, "verlet", 0.01, N, every)
    print(
        f"Kepler, verlet h=0.01   : (q-C)^q' drift {sol.drift('angular_momentum'):.2e}   "
        f"energy drift {sol.drift('energy'):.2e}   CPU {cpu:.1f} s"
    )
    sol, cpu = run(kepler, y0, "rk4", 0.01, N, every)
    print(
        f"Kepler, rk4 h=0.01      : (q-C)^q' drift {sol.drift('angular_momentum'):.2e}   "
        f"energy drift {sol.drift('energy'):.2e}   CPU {cpu:.1f} s"
    )

    falling = lieint.ConstantForceParticle(1.0, [0.0, 0.3, -9.81])
    y0 = falling.initial_state(position=[0.0, 0.0, 0.0], velocity=[1.0, 0.0, 5.0])
    sol, cpu = run(falling, y0, "verlet", 1e-4, N, every)
    print(f"constant force, verlet  : e^q' drift {sol.drift('force_bivector'):.2e}   CPU {cpu:.1f} s")

    egg = SurfaceOfRevolution([0.0, 0.0, 1.0, 0.3], axis=[0.0, 0.0, 1.0])
    p = lieint.SurfaceParticle(1.0, egg, force=[0.0, 0.0, -1.0])
    y0 = p.initial_state(position=[1.0, 0.0, 0.0], velocity=[0.0, 0.8, 0.3])
    sol, cpu = run(p, y0, "rattle", 0.01, N, every)
    print(
        f"egg, rattle h=0.01      : |h-1| {sol.drift('constraint'):.2e}   |grad h.q'| {sol.drift('tangency'):.2e}   "
        f"Clairaut drift {sol.drift('clairaut'):.2e}   energy drift {sol.drift('energy'):.2e}   CPU {cpu:.1f} s"
    )

    print("== atoms against the Euler top (t = 2, DOP853 at 1e-13 both)")
    rng = np.random.default_rng(20261122)
    tight = dict(method="scipy:DOP853", rtol=1e-13, atol=1e-13, t_eval=[0.0, 2.0])
    for n, natoms in [(3, 6), (4, 7), (5, 9)]:
        body = lieint.AtomsBody(rng.uniform(0.5, 2.0, natoms), rng.normal(size=(natoms, n)))
        X = rng.normal(size=(n, n))
        Om = (X - X.T) / 2
        atoms = lieint.integrate(body, body.initial_state(Omega=Om), (0.0, 2.0), **tight)
        top = body.euler_top()
        ref = lieint.integrate(top, top.initial_state(Omega=Om), (0.0, 2.0), **tight)
        q = atoms.states["q"][-1]
        dq = np.max(np.abs(q - body.body_positions @ ref.states["R"][-1].T))
        dA = np.max(np.abs(body.body_momentum(q, atoms.states["v"][-1]) - ref.states["A"][-1]))
        print(
            f"n = {n}, N = {natoms}: max |q_i - R X_i| {dq:.1e}   max |A - A_top| {dA:.1e}   "
            f"distances {atoms.drift('distances'):.1e}"
        )

    print("== fitted orders")
    k, m, T = 2.0, 0.5, 5.0
    osc = lieint.CentralForceParticle(m, [0.0, 0.0, 0.0], "harmonic", strength=k)
    q0, v0 = np.array([1.0, 0.2, 0.0]), np.array([0.0, 0.7, 0.3])
    w = np.sqrt(k / m)
    exact = q0 * np.cos(w * T) + v0 / w * np.sin(w * T)
    ns = [100, 200, 400, 800]
    errs = [
        np.linalg.norm(fixed(osc, osc.initial_state(position=q0, velocity=v0), "verlet", T / n, n)["q"] - exact)
        for n in ns
    ]
    print(f"verlet, harmonic orbit (exact)   : order {slope([T / n for n in ns], errs):.2f}")
    r, speed, T = 1.7, 1.3, 4.0
    sp = lieint.SurfaceParticle(1.0, Sphere(3, r))
    u, wv = np.array([1.0, 2.0, 2.0]) / 3.0, np.array([2.0, -2.0, 1.0]) / 3.0
    exact = r * (np.cos(speed / r * T) * u + np.sin(speed / r * T) * wv)
    ys = sp.initial_state(position=r * u, velocity=speed * wv)
    ns = [50, 100, 200, 400]
    errs = [np.linalg.norm(fixed(sp, ys, "rattle", T / n, n)["q"] - exact) for n in ns]
    print(f"rattle, great circle (exact)     : order {slope([T / n for n in ns], errs):.2f}")
    y0 = p.initial_state(position=[1.0, 0.0, 0.0], velocity=[0.0, 0.8, 0.3])
    T = 3.0
    ref = lieint.integrate(p, y0, (0.0, T), method="scipy:DOP853", rtol=1e-13, atol=1e-13, t_eval=[0.0, T])
    ns = [60, 120, 240, 480]
    errs = [np.linalg.norm(fixed(p, y0, "rattle", T / n, n)["q"] - ref.states["q"][-1]) for n in ns]
    print(f"rattle, egg (DOP853 1e-13)       : order {slope([T / n for n in ns], errs):.2f}")


if __name__ == "__main__":
    main()
