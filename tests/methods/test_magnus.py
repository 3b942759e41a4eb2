"""PrescribedRotation (Ṙ = RΩ(t)) and the Magnus methods, against a closed-form rotation."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import fitted_slope
from scipy.linalg import expm

import lieint
from lieint.groups.bivectors import hat

# R(t) = exp(a(t) Â) exp(b(t) B̂) has the body rate Ω = RᵀṘ = exp(−bB̂) ȧÂ exp(bB̂) + ḃB̂
A_HAT, B_HAT = hat(np.array([0.3, -0.5, 0.8])), hat(np.array([0.6, 0.2, -0.4]))


def a(t):
    return 0.7 * np.sin(t) + 0.3 * t


def b(t):
    return 0.5 * t * t


def exact(t):
    return expm(a(t) * A_HAT) @ expm(b(t) * B_HAT)


def omega(t):
    E = expm(b(t) * B_HAT)
    return E.T @ ((0.7 * np.cos(t) + 0.3) * A_HAT) @ E + t * B_HAT


SYSTEM = lieint.PrescribedRotation(omega)
T = 3.0


def final_error(system, method, n):
    sol = lieint.integrate(system, system.initial_state(), (0.0, T), h=T / n, method=method)
    return float(np.abs(sol.states["R"][-1] - exact(T)).max())


@pytest.mark.parametrize(
    ("method", "order"),
    [("magnus4", 4), ("magnus6", 6), ("cf3", 3), ("cf4", 4), ("cg3", 3), ("cg4a", 4), ("rkmk4", 4)],
)
def test_orders_on_the_linear_problem(method, order):
    ns = [20, 40, 80]
    errs = [final_error(SYSTEM, method, n) for n in ns]
    assert abs(fitted_slope([T / n for n in ns], errs) - order) <= 0.1, errs


def test_magnus_stays_on_the_group_with_dense_output(rng):
    sol = lieint.integrate(SYSTEM, SYSTEM.initial_state(), (0.0, T), h=0.1, method="magnus6", dense_output=True)
    assert sol.drift("orthogonality") < 1e-13
    R = sol.sol(rng.uniform(0.0, T, 200))["R"]
    assert np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max() < 1e-14
    assert np.abs(sol.sol(1.234)["R"] - exact(1.234)).max() < 1e-6


def test_sampled_rates_converge_with_the_sampling():
    """Gyroscope-like samples: the spline of the samples is O(Δt⁴), so the attitude error is too."""
    errs, dts = [], [0.1, 0.05, 0.025]
    for dt in dts:
        times = np.arange(0.0, T + dt / 2, dt)
        gyro = lieint.PrescribedRotation(np.array([omega(t) for t in times]), times)
        errs.append(final_error(gyro, "magnus6", 240))
    assert abs(fitted_slope(dts, errs) - 4) <= 0.3, errs
    vec = lieint.PrescribedRotation(np.tile([0.0, 0.0, 1.0], (5, 1)), np.linspace(0.0, 2.0, 5))
    sol = lieint.integrate(vec, vec.initial_state(), (0.0, np.pi / 2), h=0.1, method="magnus4")
    assert np.allclose(sol.states["R"][-1] @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-14)


def test_magnus_is_refused_for_state_dependent_generators():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=r"`method` 'magnus4'.*depends on t only"):
        lieint.integrate(top, top.initial_state(angular_velocity=[0.3, 1.0, 0.4]), (0, 1), h=0.1, method="magnus4")


def test_bad_rates_are_refused():
    with pytest.raises(ValueError, match="`times` is required"):
        lieint.PrescribedRotation(np.zeros((5, 3)))
    with pytest.raises(ValueError, match="strictly increasing"):
        lieint.PrescribedRotation(np.zeros((5, 3)), [0, 1, 1, 2, 3])
    with pytest.raises(ValueError, match="rates"):
        lieint.PrescribedRotation(np.zeros((5, 2)), np.arange(5.0))
    with pytest.raises(ValueError, match="skew"):
        lieint.PrescribedRotation(lambda t: np.ones((3, 3)))
    gyro = lieint.PrescribedRotation(np.zeros((5, 3)), np.arange(5.0))
    with pytest.raises(ValueError, match="sampled on"):
        lieint.integrate(gyro, gyro.initial_state(), (0.0, 6.0), h=0.5, method="magnus4")
