"""Rolling balls at the edges: heavy offset close to the surface, fast spin, steep incline."""

import numpy as np
import pytest

import lieint

pytestmark = pytest.mark.hard


def fitted(hs, errs):
    return float(np.polyfit(np.log(hs), np.log(errs), 1)[0])


def test_heavy_offset_centre_of_mass_close_to_the_surface(record):
    # 0.95 r below the centre: a near point mass near the rim (B_C ≈ M X_G X_Gᵀ + small)
    M, r = 1.0, 1.0
    XG = np.array([0.0, 0.0, -0.95])
    B_C = M * np.outer(XG, XG) + 0.01 * np.eye(3)
    ball = lieint.RollingBall(B_C, M, r, center_of_mass=XG, gravity=[0, 0, -9.81])
    y0 = ball.initial_state(angular_velocity=[2.0, 1.0, 0.5])
    hs = [0.002, 0.001, 0.0005]
    sols = [lieint.integrate(ball, y0, (0, 2), h=h, method="rkmk4", save_every=100) for h in hs]
    drifts = [float(s.drift("energy")) for s in sols]
    record("offset 0.95 r: energy drift at h = 5e-4", drifts[-1], "initial T − U")
    record("offset 0.95 r: fitted energy order", fitted(hs, drifts), "method order 4")
    assert all(np.all(np.isfinite(s.states["Omega"])) for s in sols)
    assert drifts[-1] < 1e-8 and fitted(hs, drifts) > 3.5


def test_fast_spin_about_the_vertical(record):
    ball = lieint.RollingBall(
        np.diag([0.1, 0.12, 0.14]), 1.0, 1.0, center_of_mass=[0.02, 0.0, -0.05], gravity=[0, 0, -9.81]
    )
    y0 = ball.initial_state(angular_velocity=[0.1, 0.0, 100.0])
    sol = lieint.integrate(ball, y0, (0, 0.5), h=1e-4, method="rkmk4", save_every=1000)
    record("spin 100 rad/s about the vertical: energy drift (h = 1e-4)", float(sol.drift("energy")), "initial T − U")
    assert sol.drift("energy") < 1e-9 and np.all(np.isfinite(sol.states["center"]))


@pytest.mark.parametrize("degrees", [60.0, 85.0, 89.0])
def test_steep_incline(record, degrees):
    theta = np.radians(degrees)
    M, r = 2.0, 0.5
    g = 9.81 * np.array([np.sin(theta), 0.0, -np.cos(theta)])
    ball = lieint.RollingBall(M * r * r / 5 * np.eye(3), M, r, gravity=g)
    sol = lieint.integrate(ball, ball.initial_state(angular_velocity=[0, 0, 0]), (0, 1), h=0.002, method="rkmk4")
    accel = 2 * (sol.states["center"][-1, 0] - sol.states["center"][0, 0])
    exact = 5 / 7 * 9.81 * np.sin(theta)
    record(f"incline {degrees:g}°: relative acceleration error", abs(accel - exact) / exact, "5/7 g sin θ")
    # the initial T − U is tiny on a steep plane (U ∝ cos θ); measure against the final kinetic energy
    E = sol.invariants["energy"]
    scale = 0.7 * M * (5 / 7 * 9.81 * np.sin(theta)) ** 2  # ½ (7/5) M v² at t = 1
    rel = float(np.max(np.abs(E - E[0]))) / scale
    record(f"incline {degrees:g}°: energy drift / final kinetic energy", rel, "initial T − U")
    assert abs(accel - exact) / exact < 1e-8 and rel < 1e-8
