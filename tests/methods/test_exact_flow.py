"""The exact 3D solution against scipy at tight tolerance (a truth independent of lieint)."""

import numpy as np
import pytest
from conftest import random_rotation
from scipy.integrate import solve_ivp

import lieint
from lieint.groups import hat, vee
from lieint.systems import euler_top_angular_velocity


def euler_rhs(t, w, I):
    return np.cross(I * w, w) / I


CASES = {
    "G2>2EI2": ([1.0, 2.0, 3.0], [0.3, 0.5, 1.0]),
    "G2<2EI2": ([1.0, 2.0, 3.0], [1.0, 0.5, 0.3]),
    "unordered moments": ([2.5, 1.2, 1.9], [0.4, -0.7, 0.2]),
    "symmetric I1=I2": ([1.0, 1.0, 2.0], [0.4, -0.2, 0.9]),
    "symmetric I2=I3": ([1.0, 2.0, 2.0], [0.4, -0.2, 0.9]),
    "near the middle axis": ([1.0, 2.0, 3.0], [1e-3, 1.0, -1e-3]),
    "on an axis (fixed point)": ([1.0, 2.0, 3.0], [0.0, 0.0, 1.5]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_elliptic_solution_matches_dop853(case):
    I, w0 = (np.array(v) for v in CASES[case])
    t = np.linspace(0, 30, 301)
    ref = solve_ivp(euler_rhs, (0, 30), w0, t_eval=t, args=(I,), method="DOP853", rtol=1e-13, atol=1e-15).y.T
    np.testing.assert_allclose(euler_top_angular_velocity(I, w0, t), ref, atol=5e-11)


def test_exact_solution_of_a_non_diagonal_top_and_batches():
    rng = np.random.default_rng(3)
    Q = random_rotation(rng, 3)
    I = np.array([1.3, 2.0, 2.6])
    b = (I.sum() - 2 * I) / 2
    top = lieint.EulerTop(Q @ np.diag(b) @ Q.T)
    w0 = rng.normal(size=(2, 3))
    y0 = top.initial_state(angular_velocity=w0)
    t = np.linspace(0, 10, 11)
    ex = top.exact_solution(t, y0)
    assert ex["A"].shape == (11, 2, 3, 3)
    for i in range(2):
        wp0 = Q.T @ w0[i]  # angular velocity vector in the principal frame (Q proper)
        ref = solve_ivp(euler_rhs, (0, 10), wp0, t_eval=t, args=(I,), method="DOP853", rtol=1e-13, atol=1e-15).y.T
        np.testing.assert_allclose(vee(ex["Omega"][:, i]), ref @ Q.T, atol=1e-10)
    np.testing.assert_allclose(ex["Omega"][0], hat(w0), atol=1e-14)


def test_exact_solution_is_for_n3_only():
    with pytest.raises(ValueError, match="n = 3"):
        lieint.EulerTop(np.eye(4)).exact_solution(
            [1.0], lieint.EulerTop(np.eye(4)).initial_state(Omega=np.zeros((4, 4)))
        )
