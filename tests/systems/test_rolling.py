"""Rolling balls (docs/theory.md §4) against truths that do not come from lieint."""

import numpy as np
import pytest
from conftest import fitted_slope, random_rotation, random_skew
from scipy.integrate import solve_ivp
from scipy.linalg import solve_continuous_lyapunov

import lieint
from lieint.groups import wedge


def incline_gravity(n, theta, g=9.81):
    e = np.eye(n)
    return g * (np.sin(theta) * e[0] - np.cos(theta) * e[-1])


@pytest.mark.parametrize("n", [2, 3, 4, 5])
@pytest.mark.slow
def test_uniform_solid_ball_on_an_incline_accelerates_at_n_plus_2_over_n_plus_4_g_sin_theta(n):
    M, r, theta = 2.0, 0.5, 0.3
    ball = lieint.RollingBall(
        mass_tensor=M * r * r / (n + 2) * np.eye(n), mass=M, radius=r, gravity=incline_gravity(n, theta)
    )
    y0 = ball.initial_state(Omega=np.zeros((n, n)))
    T = 2.0
    sol = lieint.integrate(ball, y0, (0, T), h=0.005, method="rkmk4")
    accel = 2 * (sol.states["center"][-1, 0] - y0["center"][0]) / T**2
    exact = (n + 2) / (n + 4) * 9.81 * np.sin(theta)
    assert abs(accel - exact) / exact <= 1e-8
    # it rolls straight down the slope and stays on the plane
    np.testing.assert_allclose(
        sol.states["center"][:, 1:], np.broadcast_to(y0["center"][1:], (sol.t.size, n - 1)), atol=1e-12
    )


@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_uniform_ball_on_a_horizontal_plane_keeps_omega(rng, n):
    ball = lieint.RollingBall(0.1 * np.eye(n), 1.0, 1.0, gravity=-9.81 * np.eye(n)[-1])
    y0 = ball.initial_state(Omega=random_skew(rng, n), R=random_rotation(rng, n))
    sol = lieint.integrate(ball, y0, (0, 5), h=0.01, method="rkmk4", save_every=100)
    R, Om = sol.states["R"], sol.states["Omega"]
    omega = R @ Om @ np.swapaxes(R, -1, -2)  # space angular velocity: ω̇ = 0
    np.testing.assert_allclose(omega, np.broadcast_to(omega[0], omega.shape), atol=1e-12)


def space_frame_rhs(B_C, M, r, XG, g, nu):
    """Equation (*) in space: b_K ω̇ + ω̇ b_K = b_K ω² − ω² b_K − M (x + k) ∧ (g + ω² k),
    solved by scipy's Lyapunov solver; Ṙ = ωR, q̇_C = ω k. Independent of lieint's code."""
    n = B_C.shape[0]
    k = r * nu

    def rhs(t, z):
        om = z[: n * n].reshape(n, n)
        R = z[n * n : 2 * n * n].reshape(n, n)
        x = R @ XG
        bK = R @ B_C @ R.T + M * (np.outer(x, k) + np.outer(k, x)) + M * np.outer(k, k)
        om2 = om @ om
        C = bK @ om2 - om2 @ bK - M * wedge(x + k, g + om2 @ k)
        domega = solve_continuous_lyapunov(bK, C)
        return np.concatenate([domega.ravel(), (om @ R).ravel(), om @ k])

    return rhs


@pytest.mark.parametrize("n", [3, 4])
def test_chaplygin_ball_agrees_with_the_space_frame_equation(rng, n):
    Q = random_rotation(rng, n)
    B_C = Q @ np.diag(rng.uniform(0.05, 0.15, n)) @ Q.T
    M, r = 1.0, 1.0
    nu = np.eye(n)[-1]
    ball = lieint.ChaplyginBall(mass_tensor=B_C, mass=M, radius=r)
    Om0, R0 = random_skew(rng, n), random_rotation(rng, n)
    y0 = ball.initial_state(Omega=Om0, R=R0, center=[0.0] * (n - 1) + [r])
    T = 3.0
    sol = lieint.integrate(ball, y0, (0, T), h=0.005, method="rkmk6")
    rhs = space_frame_rhs(B_C, M, r, np.zeros(n), -9.81 * nu, nu)
    z0 = np.concatenate([(R0 @ Om0 @ R0.T).ravel(), R0.ravel(), y0["center"]])
    ref = solve_ivp(rhs, (0, T), z0, method="DOP853", rtol=1e-12, atol=1e-12).y[:, -1]
    R = sol.states["R"][-1]
    Om = ball.angular_velocity(sol.states["A"][-1], sol.states["Gamma"][-1])
    np.testing.assert_allclose(R @ Om @ R.T, ref[: n * n].reshape(n, n), atol=1e-9)
    np.testing.assert_allclose(R, ref[n * n : 2 * n * n].reshape(n, n), atol=1e-9)
    np.testing.assert_allclose(sol.states["center"][-1], ref[2 * n * n :], atol=1e-9)


@pytest.mark.parametrize("n", [3, 4])
def test_chaplygin_ball_invariants(rng, n):
    Q = random_rotation(rng, n)
    ball = lieint.ChaplyginBall(mass_tensor=Q @ np.diag(rng.uniform(0.05, 0.15, n)) @ Q.T, mass=1.0, radius=1.0)
    y0 = ball.initial_state(Omega=random_skew(rng, n), R=random_rotation(rng, n))
    hs = [0.04, 0.02, 0.01]
    sols = [lieint.integrate(ball, y0, (0, 10), h=h, method="rkmk4", save_every=25) for h in hs]
    for s in sols:
        assert s.drift("casimirs") < 1e-12
        assert s.drift("gamma_norm") < 1e-13
        assert s.drift("gamma_A2_gamma") < 1e-12
    drifts = [float(s.drift("energy")) for s in sols]
    assert abs(fitted_slope(hs, drifts) - 4) < 0.3, drifts


def test_chaplygin_specialisation_matches_the_general_ball(rng):
    B_C = np.diag([0.1, 0.15, 0.2])
    g = [0.0, 0.0, -9.81]
    special = lieint.ChaplyginBall(B_C, 1.0, 1.0)
    general = lieint.RollingBall(B_C, 1.0, 1.0, gravity=g)
    R0 = random_rotation(rng, 3)
    a = lieint.integrate(
        special, special.initial_state(R=R0, angular_velocity=[1, 2, 0.5]), (0, 2), h=0.002, method="rkmk6"
    )
    b = lieint.integrate(
        general, general.initial_state(R=R0, angular_velocity=[1, 2, 0.5]), (0, 2), h=0.002, method="rkmk6"
    )
    np.testing.assert_allclose(a.states["R"], b.states["R"], atol=1e-10)
    np.testing.assert_allclose(a.states["center"], b.states["center"], atol=1e-10)


@pytest.mark.parametrize("incline", [0.0, 0.4])
def test_offset_ball_energy_is_conserved_at_the_method_order(rng, incline):
    B_C = np.diag([0.3, 0.4, 0.5]) * 0.2
    XG = np.array([0.05, 0.02, -0.1])
    ball = lieint.RollingBall(B_C, 1.0, 1.0, center_of_mass=XG, gravity=incline_gravity(3, incline))
    assert ("G" in ball.fields) == (incline != 0.0)
    y0 = ball.initial_state(angular_velocity=[1.0, 2.0, 3.0], R=random_rotation(rng, 3))
    hs = [0.02, 0.01, 0.005]
    drifts = [float(lieint.integrate(ball, y0, (0, 3), h=h, method="rkmk4").drift("energy")) for h in hs]
    assert abs(fitted_slope(hs, drifts) - 4) < 0.3, drifts


def test_offset_ball_matches_the_space_frame_equation(rng):
    B_C = np.diag([0.3, 0.4, 0.5]) * 0.2
    XG, g, nu = np.array([0.05, 0.02, -0.1]), incline_gravity(3, 0.4), np.eye(3)[-1]
    ball = lieint.RollingBall(B_C, 1.0, 1.0, center_of_mass=XG, gravity=g)
    R0 = random_rotation(rng, 3)
    y0 = ball.initial_state(angular_velocity=[1.0, 2.0, 3.0], R=R0)
    sol = lieint.integrate(ball, y0, (0, 2), h=0.002, method="rkmk6")
    z0 = np.concatenate([(R0 @ y0["Omega"] @ R0.T).ravel(), R0.ravel(), y0["center"]])
    ref = solve_ivp(space_frame_rhs(B_C, 1.0, 1.0, XG, g, nu), (0, 2), z0, method="DOP853", rtol=1e-12, atol=1e-12).y[
        :, -1
    ]
    np.testing.assert_allclose(sol.states["R"][-1], ref[9:18].reshape(3, 3), atol=1e-9)
    np.testing.assert_allclose(sol.states["center"][-1], ref[18:], atol=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"radius": 0.0}, r"`radius` must be a positive finite number; got 0.0"),
        ({"radius": -1.0}, r"`radius` must be a positive finite number"),
        ({"mass": 0.0}, r"`mass` must be a positive finite number; got 0.0"),
        ({"center_of_mass": [0.0, 0.0, 1.5]}, r"`center_of_mass` must lie inside the ball \(\|X_G\| < radius = 1\)"),
        ({"normal": [0.0, 0.0, 0.0]}, r"`normal` must be a nonzero vector"),
        ({"mass_tensor": np.diag([1.0, 1.0, 1.0])}, r"tr B_C = ∫ m\|X\|² must be <= M r² = 1; got 3"),
        ({"mass_tensor": np.diag([0.1, 0.0, 0.0])}, r"at most one zero eigenvalue"),
        (
            {"mass_tensor": np.diag([0.1, 0.1, 0.001]), "center_of_mass": [0, 0, 0.5]},
            r"B_C − M X_G X_Gᵀ must be positive semi-definite",
        ),
        (
            {"gravity": [0.0, -9.81]},
            r"`gravity` must be a vector of dimension n = 3 .*got shape \(2,\)",
        ),
    ],
)
def test_bad_ball_input(kwargs, match):
    args = {"mass_tensor": np.diag([0.1, 0.12, 0.14]), "mass": 1.0, "radius": 1.0} | kwargs
    with pytest.raises(ValueError, match=match):
        lieint.RollingBall(**args)


def test_initial_state_that_violates_the_rolling_constraint():
    ball = lieint.RollingBall(np.diag([0.1, 0.12, 0.14]), 1.0, 2.0, gravity=[0, 0, -9.81])
    with pytest.raises(ValueError, match=r"`center` violates the rolling constraint: .* height r = 2"):
        ball.initial_state(angular_velocity=[0, 0, 1], center=[0, 0, 1.0])
    with pytest.raises(ValueError, match=r"`velocity` violates the rolling constraint q̇_C = ω k \(no sliding\)"):
        ball.initial_state(angular_velocity=[1.0, 0, 0], velocity=[0, 0, 0])
    ok = ball.initial_state(angular_velocity=[1.0, 0, 0], velocity=[0, -2.0, 0])  # ω × (r ν) = (0, −2, 0)
    assert ok["center"][2] == 2.0
