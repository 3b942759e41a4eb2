"""Particles (docs/theory.md §10): bivector and trivector first integrals, the surface constraint kept
by RATTLE, Verlet's and RATTLE's orders fitted against exact solutions and a tight reference."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import fitted_slope

import lieint
from lieint.groups.bivectors import wedge
from lieint.systems.multivectors import trivector, trivector_dimension
from lieint.systems.particles import RadialPotential, surface_particle
from lieint.systems.surfaces import Ellipsoid, Sphere, SurfaceOfRevolution, make_surface

EGG = [0.0, 0.0, 1.0, 0.3]  # ρ² + z² + 0.3 z³ = 1


def egg_particle(n=3):
    axis = np.zeros(n)
    axis[-1] = 1.0
    egg = SurfaceOfRevolution(EGG, axis=axis)
    p = lieint.SurfaceParticle(1.3, egg, force=-0.8 * axis)
    direction = np.zeros(n)
    direction[0], direction[-1] = 1.0, 0.2
    v = np.zeros(n)
    v[1] = 0.8
    if n > 3:
        v[2] = 0.3
    return p, p.initial_state(position=egg.point(direction), velocity=v)


def fixed(system, y0, method, h, nsteps):
    method = lieint.get_method(method)
    t, y, state = 0.0, y0, method.init(system, 0.0, y0, h)
    for _ in range(nsteps):
        r = method.step(system, t, y, h, state)
        y, state, t = r.y, r.state, t + h
    return y


# -- multivectors ----------------------------------------------------------------------------------


def test_trivector_components_are_the_3x3_minors(rng):
    u, v, w = rng.normal(size=(3, 5))
    tri = trivector(u, v, w)
    assert tri.shape == (trivector_dimension(5),) == (10,)
    M = np.stack([u, v, w])
    assert tri[0] == pytest.approx(np.linalg.det(M[:, [0, 1, 2]]), rel=1e-14)
    assert tri[-1] == pytest.approx(np.linalg.det(M[:, [2, 3, 4]]), rel=1e-14)
    # n = 3: the triple product ⟨u × v, w⟩
    a, b, c = rng.normal(size=(3, 3))
    assert trivector(a, b, c)[0] == pytest.approx(np.cross(a, b) @ c, rel=1e-13)


# -- central and constant forces -------------------------------------------------------------------


@pytest.mark.parametrize("n", [3, 4])
def test_verlet_keeps_the_kepler_bivector_to_round_off(n):
    C = np.arange(n) * 0.1
    kepler = lieint.CentralForceParticle(1.0, C, "kepler")
    q = C.copy()
    q[0] += 1.0
    v = np.zeros(n)
    v[1], v[-1] = 1.1, 0.2
    y0 = kepler.initial_state(position=q, velocity=v)
    sol = lieint.integrate(kepler, y0, (0.0, 50.0), h=0.01, method="verlet")
    assert sol.states["q"].shape == (5001, n)
    assert sol.drift("angular_momentum") <= 1e-15
    # the energy oscillates with an O(h²) amplitude and does not drift
    assert 1e-8 < sol.drift("energy") < 1e-3
    # discriminating: RK4 (not symplectic, no momentum map) loses the bivector far above round-off
    rk = lieint.integrate(kepler, y0, (0.0, 50.0), h=0.01, method="rk4")
    assert rk.drift("angular_momentum") > 1e-12


def test_verlet_energy_error_is_second_order_and_bounded():
    osc = lieint.CentralForceParticle(1.0, [0.0, 0.0], "harmonic", strength=4.0)
    y0 = osc.initial_state(position=[1.0, 0.0], velocity=[0.0, 0.5])
    drifts = [lieint.integrate(osc, y0, (0.0, 200.0), h=h, method="verlet").drift("energy") for h in (0.02, 0.01)]
    assert drifts[0] / drifts[1] == pytest.approx(4.0, rel=0.05)


def test_verlet_order_against_the_exact_harmonic_orbit():
    k, m = 2.0, 0.5
    osc = lieint.CentralForceParticle(m, [0.0, 0.0, 0.0], RadialPotential.harmonic(k))
    q0, v0 = np.array([1.0, 0.2, 0.0]), np.array([0.0, 0.7, 0.3])
    y0 = osc.initial_state(position=q0, velocity=v0)
    w, T = np.sqrt(k / m), 5.0
    exact = q0 * np.cos(w * T) + v0 / w * np.sin(w * T)
    ns = [100, 200, 400, 800]
    errs = [np.linalg.norm(fixed(osc, y0, "verlet", T / n, n)["q"] - exact) for n in ns]
    assert fitted_slope([T / n for n in ns], errs) == pytest.approx(2.0, abs=0.05)


def test_constant_force_keeps_e_wedge_velocity_and_verlet_is_exact_on_the_parabola():
    f = np.array([0.0, 0.3, -9.81, 0.1])
    p = lieint.ConstantForceParticle(2.0, f)
    q0, v0 = np.array([0.0, 1.0, 2.0, 0.0]), np.array([1.0, 0.0, 3.0, -0.5])
    y0 = p.initial_state(position=q0, velocity=v0)
    sol = lieint.integrate(p, y0, (0.0, 3.0), h=0.1, method="verlet")
    assert sol.drift("force_bivector") <= 1e-15
    T = sol.t[-1]
    np.testing.assert_allclose(sol.states["q"][-1], q0 + v0 * T + 0.5 * f / 2.0 * T**2, rtol=0, atol=1e-13)
    # the bivector of the exact flow is e ∧ v₀ at every time (f ∧ f = 0)
    np.testing.assert_allclose(
        p.invariants["force_bivector"](T, {"v": v0 + f / 2.0 * T}), wedge(f / np.linalg.norm(f), v0), atol=1e-15
    )


# -- particle on a surface -------------------------------------------------------------------------


@pytest.mark.parametrize("n", [3, 4])
def test_rattle_keeps_the_surface_the_tangency_and_clairaut(n):
    p, y0 = egg_particle(n)
    assert set(p.invariants) == {"energy", "constraint", "tangency", "clairaut"}
    sol = lieint.integrate(p, y0, (0.0, 40.0), h=0.01, method="rattle", save_every=10)
    assert sol.drift("constraint") <= 1e-15 * 4
    assert sol.drift("tangency") <= 1e-15 * 4
    assert sol.drift("clairaut") <= 1e-15
    assert np.shape(p.invariants["clairaut"](0.0, y0)) == (trivector_dimension(n),)
    assert sol.drift("energy") < 1e-3  # bounded O(h²) oscillation of a symplectic method
    # discriminating: RKMK4 on the index-1 equations leaves the surface without projection
    rk = lieint.integrate(p, y0, (0.0, 40.0), h=0.01, method="rkmk4", save_every=10)
    assert rk.drift("constraint") > 1e-12 and rk.drift("clairaut") > 1e-12


def test_clairaut_is_the_angular_momentum_about_the_axis_in_3d():
    p, y0 = egg_particle(3)
    q, v = y0["q"], y0["v"]
    assert p.invariants["clairaut"](0.0, y0)[0] == pytest.approx(np.cross(q, v)[2], rel=1e-14)


def test_rattle_order_against_the_exact_great_circle():
    r = 1.7
    sphere = Sphere(3, r, centre=[0.1, 0.0, -0.2])
    p = lieint.SurfaceParticle(1.0, sphere)
    u = np.array([1.0, 2.0, 2.0]) / 3.0
    w = np.array([2.0, -2.0, 1.0]) / 3.0  # ⟂ u
    speed, T = 1.3, 4.0
    y0 = p.initial_state(position=sphere.centre + r * u, velocity=speed * w)
    om = speed / r
    exact = sphere.centre + r * (np.cos(om * T) * u + np.sin(om * T) * w)
    ns = [50, 100, 200, 400]
    errs = [np.linalg.norm(fixed(p, y0, "rattle", T / n, n)["q"] - exact) for n in ns]
    assert fitted_slope([T / n for n in ns], errs) == pytest.approx(2.0, abs=0.05)
    assert "angular_momentum" in p.invariants
    sol = lieint.integrate(p, y0, (0.0, 20.0), h=0.05, method="rattle")
    assert sol.drift("angular_momentum") <= 1e-15


def test_rattle_order_on_the_egg_against_a_tight_reference():
    p, y0 = egg_particle(3)
    T = 3.0
    ref = lieint.integrate(p, y0, (0.0, T), method="scipy:DOP853", rtol=1e-13, atol=1e-13, t_eval=[0.0, T])
    exact = ref.states["q"][-1]
    ns = [60, 120, 240, 480]
    errs = [np.linalg.norm(fixed(p, y0, "rattle", T / n, n)["q"] - exact) for n in ns]
    assert fitted_slope([T / n for n in ns], errs) == pytest.approx(2.0, abs=0.05)


def test_ellipsoid_particle_with_projection_and_rattle_agree():
    ell = Ellipsoid([1.0, 0.7, 0.4])
    p = lieint.SurfaceParticle(1.0, ell, force=[0.0, 0.0, -1.0])
    assert "clairaut" not in p.invariants  # no axis of symmetry
    y0 = p.initial_state(position=ell.point([1.0, 1.0, 1.0]), velocity=[0.0, 0.0, 0.0])
    a = lieint.integrate(p, y0, (0.0, 2.0), h=0.002, method="rattle")
    b = lieint.integrate(p, y0, (0.0, 2.0), method="scipy:DOP853", rtol=1e-12, atol=1e-12, project=True)
    np.testing.assert_allclose(a.states["q"][-1], b.states["q"][-1], atol=1e-5)
    assert a.drift("constraint") <= 1e-15 and a.drift("tangency") <= 1e-15


def test_project_puts_a_state_on_the_surface_and_tangent():
    p, y0 = egg_particle(3)
    off = {"q": y0["q"] * 1.01, "v": y0["v"] + 0.1 * p.surface.gradient(y0["q"])}
    on = p.project(off)
    assert abs(p.surface.h(on["q"]) - 1.0) <= 2e-16
    assert abs(p.surface.gradient(on["q"]) @ on["v"]) <= 1e-15


def test_surface_factory_builds_surfaces_from_data():
    p = surface_particle(1.0, "revolution", [0.0, 0.0, -1.0], profile=EGG, axis=[0.0, 0.0, 2.0])
    assert isinstance(p.surface, SurfaceOfRevolution) and np.allclose(p.surface.axis, [0, 0, 1])
    s = surface_particle(2.0, "sphere", [0.0, -1.0], radius=2.0)
    assert isinstance(s.surface, Sphere) and s.n == 2 and s.surface.radius == 2.0
    sphere = make_surface("revolution", profile=[0.0, 0.0, 1.0], axis=[0.0, 0.0, 1.0])
    q = np.array([0.6, 0.0, 0.8])
    assert sphere.h(q) == pytest.approx(1.0, abs=1e-15)  # P(z) = z²: the unit sphere


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: make_surface("torus"), "`surface` must be one of"),
        (lambda: make_surface("sphere", semi_axes=[1, 2, 3]), "`semi_axes` does not apply"),
        (lambda: make_surface("ellipsoid"), "needs `semi_axes`"),
        (lambda: Ellipsoid([1.0, -2.0]), "`semi_axes` must be a vector of n ≥ 2 positive"),
        (lambda: SurfaceOfRevolution([1.0], [0, 0, 1]), "`profile` must be the coefficients"),
        (lambda: lieint.SurfaceParticle(1.0, "sphere"), "`surface` must be a Surface"),
        (lambda: lieint.CentralForceParticle(1.0, [0, 0, 0], "yukawa"), "`potential` must be"),
        (lambda: lieint.CentralForceParticle(1.0, [0, 0, 0], "power"), "`exponent` is needed"),
        (lambda: lieint.ConstantForceParticle(1.0, [0.0, 0.0]), "`force` must be a nonzero vector"),
        (lambda: lieint.CentralForceParticle(-1.0, [0, 0, 0]), "mass"),
    ],
)
def test_bad_particle_input_is_named(call, match):
    with pytest.raises((ValueError, TypeError), match=match):
        call()


def test_initial_state_off_the_surface_is_refused():
    p, y0 = egg_particle(3)
    with pytest.raises(ValueError, match="`position` must lie on the surface"):
        p.initial_state(position=[2.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="`velocity` must be tangent"):
        p.initial_state(position=y0["q"], velocity=y0["q"])


def test_symplectic_methods_refuse_systems_they_cannot_step():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.1, 1.0, 0.2])
    with pytest.raises(ValueError, match="`method` 'verlet' steps Newton's equations"):
        lieint.integrate(top, y0, (0.0, 1.0), h=0.1, method="verlet")
    p, yp = egg_particle(3)
    with pytest.raises(ValueError, match=r"`method` 'verlet'.*SurfaceParticle declares"):
        lieint.integrate(p, yp, (0.0, 1.0), h=0.1, method="verlet")
    kepler = lieint.CentralForceParticle(1.0, [0, 0, 0])
    yk = kepler.initial_state(position=[1.0, 0.0, 0.0], velocity=[0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="`method` 'rattle' steps a particle constrained"):
        lieint.integrate(kepler, yk, (0.0, 1.0), h=0.1, method="rattle")


def test_verlet_reuses_the_last_force_only_at_the_same_point():
    kepler = lieint.CentralForceParticle(1.0, [0, 0, 0])
    y0 = kepler.initial_state(position=[1.0, 0.0, 0.0], velocity=[0.0, 1.0, 0.0])
    sol = lieint.integrate(kepler, y0, (0.0, 1.0), h=0.1, method="verlet")
    assert sol.stats.nfev == 11  # one force per step, plus the first
    # a checkpointed or projected state that moved q makes Verlet evaluate the force afresh
    m = lieint.get_method("verlet")
    r = m.step(kepler, 0.0, y0, 0.1, None)
    moved = {"q": r.y["q"] * (1 + 1e-3), "v": r.y["v"]}
    assert m.step(kepler, 0.1, moved, 0.1, r.state).nfev == 2
    assert m.step(kepler, 0.1, r.y, 0.1, r.state).nfev == 1
