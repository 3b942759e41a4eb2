"""Rigid bodies as PGA motors: conventions, agreement with the matrix systems, orders, defects."""

import mpmath
import numpy as np
import pytest
from conftest import fitted_slope, random_rotation

import lieint
from lieint.ga import MotorRigidBody, matrix_to_rotor
from lieint.ga.motor import MotorGroup
from lieint.ga.pga import PGA
from lieint.groups import SE, hat

B3 = np.diag([1.0, 2.0, 3.0])
SPRINGS = [[0.5, 0.0, 0.0, 0.6, 0.0, 1.0, 30.0, 0.2], [-0.5, 0.0, 0.0, -0.6, 0.1, 1.0, 20.0, 0.3]]


def _twist(rng, scale=1.0):
    X = np.zeros((4, 4))
    X[:3, :3] = hat(scale * rng.normal(size=3))
    X[:3, 3] = rng.normal(size=3)
    return X


# -- the algebra ------------------------------------------------------------------------------


def test_motor_of_a_pose_moves_points_and_lines(rng):
    R, c = random_rotation(rng, 3), rng.normal(size=3)
    M = PGA.motor(matrix_to_rotor(R, as_multivector=False), c)
    x, d = rng.normal(size=(2, 3))
    np.testing.assert_allclose(PGA.point_coordinates(PGA.sandwich(M, PGA.point(x))), R @ x + c, atol=1e-14)
    # the line through x along d is carried to the line through Rx + c along Rd (moment (Rx + c) × Rd)
    moved = PGA.sandwich(M, PGA.line(np.cross(x, d), d))
    np.testing.assert_allclose(moved, PGA.line(np.cross(R @ x + c, R @ d), R @ d), atol=1e-14)
    np.testing.assert_allclose(PGA.translation(M), c, atol=1e-15)


@pytest.mark.parametrize("scale", [2.0, 1e-3, 1e-9, 0.0])
def test_motor_exp_matches_a_50_digit_matrix_exponential(rng, scale):
    """e^{B/2} of the twist bivector is the pose exp(ξ), checked against mpmath's expm."""
    mpmath.mp.dps = 50
    X = _twist(rng, scale)
    M = MotorGroup().exp(X)
    ref = np.array(mpmath.expm(mpmath.matrix(X.tolist())).tolist(), dtype=float)
    np.testing.assert_allclose(MotorGroup().matrix(M), ref, atol=2e-15)
    assert PGA.defect(M) < 1e-15


def test_twist_is_the_derivative_of_the_motor(rng):
    X = _twist(rng)
    t = 1e-7
    M0 = MotorGroup().exp(X)
    dM = (MotorGroup().exp(X * (1 + t)) - MotorGroup().exp(X * (1 - t))) / (2 * t)  # d/ds exp(sξ) at s = 1
    np.testing.assert_allclose(dM, 0.5 * PGA.product(M0, MotorGroup().bivector(X)), atol=1e-7)


def test_motor_cayley_and_normalisation(rng):
    X = _twist(rng, 1.5)
    np.testing.assert_allclose(MotorGroup().matrix(MotorGroup().cay(X)), SE(3).cay(X), atol=1e-14)
    M = MotorGroup().exp(X)
    noisy = M + 1e-8 * rng.normal(size=16) * np.isin(np.arange(16), [0, 5, 6, 7, 8, 9, 10, 15])
    assert PGA.defect(noisy) > 1e-9
    assert PGA.defect(PGA.normalize(noisy)) < 1e-15


# -- the body ---------------------------------------------------------------------------------


@pytest.mark.parametrize("gravity", [None, [0.0, 0.0, -9.81]])
@pytest.mark.slow
def test_motor_body_agrees_with_free_body(gravity):
    """Rotation to round-off (the same stages); the centre to the truncation error of the screw
    motion (FreeBody moves the centre exactly in space)."""
    kw = dict(angular_velocity=[0.3, 1.0, 0.2], velocity=[1.0, 0.0, 2.0], center=[0.1, 0.2, 0.3])
    free, motor = lieint.FreeBody(B3, 2.0, gravity), MotorRigidBody(B3, 2.0, gravity)
    T, h = 5.0, 0.002
    a = lieint.integrate(free, free.initial_state(**kw), (0, T), h=h, backend="numpy", save_every=50)
    b = lieint.integrate(motor, motor.initial_state(**kw), (0, T), h=h, save_every=50)
    out = b.outputs(["R", "center"])
    assert np.max(np.abs(out["R"] - a.states["R"])) < 1e-12
    assert np.max(np.abs(out["center"] - a.states["center"])) < 1e-10
    assert b.drift("energy") < 1e-9


def test_motor_heavy_top_converges_to_the_heavy_top():
    """Two order-4 discretisations of one flow: their difference shrinks as h⁴."""
    ht = lieint.HeavyTop(B3, 1.0, [0.0, 0.1, 0.3], [0.0, 0.0, -9.81])
    mt = MotorRigidBody(B3, 1.0, [0.0, 0.0, -9.81], fixed_point=True, center_of_mass=[0.0, 0.1, 0.3])
    w = [0.3, 1.0, 0.4]
    hs = [0.02, 0.01, 0.005]
    diffs = []
    for h in hs:
        a = lieint.integrate(ht, ht.initial_state(angular_velocity=w), (0, 2.0), h=h, backend="numpy")
        b = lieint.integrate(mt, mt.initial_state(angular_velocity=w), (0, 2.0), h=h)
        diffs.append(np.max(np.abs(b.outputs(["R"])["R"] - a.states["R"])))
    assert fitted_slope(hs, diffs) > 3.7
    assert diffs[-1] < 1e-10
    assert b.drift("vertical_momentum") < 1e-13  # the Casimir ⟨Π, Γ⟩, exactly


def test_spring_at_the_centre_is_a_harmonic_oscillator():
    """A zero-length spring at the centre of mass: c(t) = a + (c₀ − a) cos(ωt), ω = √(k/M)."""
    a, k, M = np.array([0.0, 0.0, 1.0]), 8.0, 2.0
    body = MotorRigidBody(B3, M, springs=[[0, 0, 0, *a, k, 0.0]])
    c0 = np.array([0.3, -0.2, 0.5])
    sol = lieint.integrate(body, body.initial_state(angular_velocity=[0, 0, 0], center=c0), (0, 3.0), h=0.005)
    exact = a + (c0 - a) * np.cos(np.sqrt(k / M) * sol.t)[:, None]
    assert np.max(np.abs(sol.outputs(["center"])["center"] - exact)) < 1e-8
    np.testing.assert_allclose(sol.outputs(["R"])["R"], np.broadcast_to(np.eye(3), (sol.t.size, 3, 3)), atol=1e-15)


def test_springs_conserve_energy_and_keep_the_motor_exact():
    body = MotorRigidBody(B3, 2.0, [0, 0, -9.81], springs=SPRINGS)
    y0 = body.initial_state(angular_velocity=[0.3, 1.0, 0.2], velocity=[0.2, 0, 0.1])
    drifts = []
    for h in (0.01, 0.005):
        sol = lieint.integrate(body, y0, (0, 5.0), h=h, project=True)
        drifts.append(sol.drift("energy"))
        assert sol.drift("motor_defect") < 1e-15
    assert drifts[1] < drifts[0] / 10  # the energy error is the method's (order 4), not a wrong torque
    unprojected = lieint.integrate(body, y0, (0, 5.0), h=0.01)
    assert unprojected.drift("motor_defect") < 1e-13


def test_fitted_orders_on_the_motor_group():
    body = MotorRigidBody(B3, 2.0, [0, 0, -9.81], springs=SPRINGS)
    y0 = body.initial_state(angular_velocity=[0.3, 1.0, 0.2], velocity=[0.2, 0, 0.1])
    T = 1.0
    ref = lieint.integrate(body, y0, (0, T), h=T / 1024, method="rkmk6")
    ref_pose = MotorGroup().matrix(ref.states["motor"][-1])
    for name, hs in {
        "lie_euler": [T / 200, T / 400, T / 800],
        "rkmk2": [T / 50, T / 100, T / 200],
        "rkmk3": [T / 25, T / 50, T / 100],
        "rkmk4": [T / 20, T / 40, T / 80],
        "rkmk6": [T / 16, T / 24, T / 32],
    }.items():
        errors = []
        for h in hs:
            sol = lieint.integrate(body, y0, (0, T), h=h, method=name)
            errors.append(np.max(np.abs(MotorGroup().matrix(sol.states["motor"][-1]) - ref_pose)))
        order = lieint.get_method(name).order
        assert fitted_slope(hs, errors) > order - 0.3, (name, errors)


def test_motor_body_errors_name_the_argument():
    with pytest.raises(ValueError, match="3 × 3"):
        MotorRigidBody(np.eye(4), 1.0)
    with pytest.raises(ValueError, match="springs"):
        MotorRigidBody(B3, 1.0, springs=[[1.0, 2.0]])
    with pytest.raises(ValueError, match="center_of_mass"):
        MotorRigidBody(B3, 1.0, center_of_mass=[0, 0, 1])
    top = MotorRigidBody(B3, 1.0, [0, 0, -9.81], fixed_point=True, center_of_mass=[0, 0, 0.3])
    with pytest.raises(ValueError, match="pivot"):
        top.initial_state(angular_velocity=[0, 0, 1.0], velocity=[1.0, 0, 0])
    with pytest.raises(ValueError, match="unit motor"):
        top.validate_state({"motor": 2.0 * np.eye(16)[0], "momentum": np.zeros(16)})
    body = MotorRigidBody(B3, 1.0, springs=[{"body_point": [1, 0, 0], "anchor": [0, 0, 1], "stiffness": 2.0}])
    assert body.springs.shape == (1, 8)
