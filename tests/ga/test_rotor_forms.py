"""The rotor form of every rigid body: same numbers as the matrix form, rotors kept on Spin(n)."""

import numpy as np
import pytest
from conftest import random_skew

import lieint
from lieint import ga
from lieint.ga.spin import RotorForm, rotor_cay_of_skew

B3 = np.diag([1.0, 2.0, 3.0])
B_BALL = np.diag([0.2, 0.3, 0.4])


def _cases():
    rng = np.random.default_rng(7)
    return {
        "euler_top_3": (lieint.EulerTop(B3), {"angular_velocity": [0.3, 1.0, 0.2]}),
        "euler_top_4": (lieint.EulerTop(np.diag([1.0, 1.5, 2.2, 3.0])), {"Omega": random_skew(rng, 4, scale=2.0)}),
        "lagrange_top": (lieint.HeavyTop.lagrange(1.0, 0.5, 1.0, 0.3), {"angular_velocity": [0.1, 0.2, 5.0]}),
        "heavy_top_5": (
            lieint.HeavyTop(np.diag([1.0, 1.2, 1.5, 2.0, 2.5]), 1.0, [0.1, 0, 0.2, 0, 0.3], [0, 0, 0, 0, -9.81]),
            {"Omega": random_skew(rng, 5)},
        ),
        "free_body": (
            lieint.FreeBody(B3, 2.0, [0.0, 0.0, -9.81]),
            {"angular_velocity": [0.3, 1.0, 0.2], "velocity": [1.0, 0.0, 2.0]},
        ),
        "rolling_ball": (
            lieint.RollingBall(B_BALL, 1.0, 1.0, center_of_mass=[0.1, 0.0, 0.05], gravity=[0, 0, -9.81]),
            {"angular_velocity": [0.3, 1.0, 0.2]},
        ),
        "chaplygin_ball": (lieint.ChaplyginBall(B_BALL, 1.0, 1.0), {"angular_velocity": [0.3, 1.0, 0.2]}),
    }


CASES = _cases()


@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.slow
def test_rotor_form_gives_the_matrix_numbers(name):
    """1000 RKMK4 steps: R of the rotor equals the matrix path's R, every other field agrees, the
    Casimirs and the energy behave alike, and the rotor stays on Spin(n)."""
    system, keywords = CASES[name]
    rotor = RotorForm(system)
    y0, r0 = system.initial_state(**keywords), rotor.initial_state(**keywords)
    T, h = 4.0, 0.004
    a = lieint.integrate(system, y0, (0.0, T), h=h, method="rkmk4", backend="numpy", save_every=50)
    b = lieint.integrate(rotor, r0, (0.0, T), h=h, method="rkmk4", save_every=50)
    R = ga.rotor_to_matrix(b.states["rotor"], n=system.n)
    assert np.max(np.abs(R - a.states["R"])) < 5e-12
    for field in system.fields:
        if field != "R":
            assert np.max(np.abs(a.states[field] - b.states[field])) < 5e-12, field
    for inv in ("casimirs", "energy", "gamma_norm"):
        if inv in system.invariants:
            assert abs(b.drift(inv) - a.drift(inv)) <= 1e-12 + 1e-6 * a.drift(inv), inv
    assert b.drift("rotor_defect") < 1e-13
    assert "orthogonality" not in rotor.invariants


@pytest.mark.parametrize("coordinates", ["exp", "cayley"])
def test_every_coordinate_map_and_projection(coordinates):
    system, keywords = CASES["euler_top_4"]
    rotor = RotorForm(system)
    opts = dict(method="rkmk4", coordinates=coordinates, project=True)
    a = lieint.integrate(system, system.initial_state(**keywords), (0, 1), h=0.01, backend="numpy", **opts)
    b = lieint.integrate(rotor, rotor.initial_state(**keywords), (0, 1), h=0.01, **opts)
    assert np.max(np.abs(ga.rotor_to_matrix(b.states["rotor"], n=4) - a.states["R"])) < 1e-13


@pytest.mark.parametrize("n", [3, 4, 6])
def test_cayley_rotor_is_the_rotor_of_the_cayley_rotation(rng, n):
    X = random_skew(rng, n, (3,), scale=2.0)
    Q = lieint.SO(n).cay(X)
    np.testing.assert_allclose(ga.rotor_to_matrix(rotor_cay_of_skew(X), n=n), Q, atol=1e-14)


def test_rotor_form_classical_methods_and_explicit_rotors():
    """Classical RK steps the rotor in the embedding (via the infinitesimal action)."""
    system, keywords = CASES["free_body"]
    rotor = RotorForm(system)
    a = lieint.integrate(system, system.initial_state(**keywords), (0, 1), h=0.01, method="rk4")
    b = lieint.integrate(rotor, rotor.initial_state(**keywords), (0, 1), h=0.01, method="rk4")
    np.testing.assert_allclose(ga.rotor_to_matrix(b.states["rotor"], n=3), a.states["R"], atol=1e-12)
    S = ga.matrix_to_rotor(lieint.SO(3).exp(random_skew(np.random.default_rng(1), 3)))
    y = rotor.initial_state(rotor=-S, angular_velocity=[0, 0, 1.0])
    np.testing.assert_allclose(y["rotor"], -ga.to_values(S))  # the sign given is kept


def test_rotor_form_errors_name_the_problem():
    with pytest.raises(ValueError, match="orientation=True"):
        RotorForm(lieint.EulerTop(B3, orientation=False))
    with pytest.raises(TypeError, match="rotor form already"):
        RotorForm(RotorForm(lieint.EulerTop(B3)))
    rotor = RotorForm(lieint.EulerTop(B3))
    with pytest.raises(ValueError, match="unit rotor"):
        rotor.initial_state(rotor=2.0 * np.eye(8)[0])
    with pytest.raises(ValueError, match="`R` or as `rotor`"):
        rotor.initial_state(rotor=np.eye(8)[0], R=np.eye(3))


def test_scene_asks_for_rotors():
    text = """
    [scene]
    name = "Lagrange top as a rotor"
    [body]
    principal_moments = [1.0, 1.0, 0.5]
    mass = 1.0
    center_of_mass = [0.0, 0.0, 0.3]
    orientation = "{orientation}"
    [support]
    type = "fixed_point"
    [forces]
    gravity = [0.0, 0.0, -9.81]
    [initial]
    angular_velocity = [0.1, 0.2, 5.0]
    [integrator]
    method = "rkmk4"
    step = 0.01
    t_end = 1.0
    [output]
    quantities = ["energy", "orientation"]
    """
    runs = {}
    for orientation in ("matrix", "rotor"):
        scene = lieint.scenes.parse_scene(text.format(orientation=orientation))
        runs[orientation] = lieint.scenes.run_scene(scene)
    assert isinstance(runs["rotor"].system, RotorForm)
    np.testing.assert_allclose(runs["rotor"].outputs["orientation"], runs["matrix"].outputs["orientation"], atol=1e-13)
    with pytest.raises(lieint.scenes.SceneError, match="orientation"):
        lieint.scenes.parse_scene(text.format(orientation="quaternion"))
