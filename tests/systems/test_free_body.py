import numpy as np
import pytest
from conftest import random_rotation

import lieint


@pytest.mark.parametrize("n", [2, 3, 4])
def test_free_fall_is_exact_and_rotation_is_the_euler_top(rng, n):
    B = np.diag(np.linspace(0.5, 1.5, n))
    g = -9.81 * np.eye(n)[-1]
    body = lieint.FreeBody(mass_tensor=B, mass=2.0, gravity=g)
    v0 = rng.normal(size=n)
    Om = rng.normal(size=(n, n))
    Om = Om - Om.T
    R0 = random_rotation(rng, n)
    y0 = body.initial_state(R=R0, Omega=Om, velocity=v0, center=np.ones(n))
    sol = lieint.integrate(body, y0, (0, 2), h=0.1, method="rkmk4")
    t = sol.t[:, None]
    np.testing.assert_allclose(sol.states["center"], 1.0 + v0 * t + 0.5 * g * t**2, atol=1e-12)
    top = lieint.EulerTop(B)
    ref = lieint.integrate(top, top.initial_state(R=R0, Omega=Om), (0, 2), h=0.1, method="rkmk4")
    np.testing.assert_allclose(sol.states["R"], ref.states["R"], atol=1e-14)
    assert sol.drift("energy") < 1e-5


def test_uniform_motion_conserves_linear_momentum(rng):
    body = lieint.FreeBody(np.diag([1.0, 2.0, 3.0]), 1.0)
    y0 = body.initial_state(angular_velocity=[0.1, 1.0, 0.2], velocity=[1.0, 2.0, 3.0])
    sol = lieint.integrate(body, y0, (0, 5), h=0.1)
    assert sol.drift("linear_momentum") == 0.0
    np.testing.assert_allclose(sol.states["center"][-1], [5.0, 10.0, 15.0], atol=1e-12)
