"""Invariants of the Euler top: what Lie-group methods keep to round-off, and what they don't."""

import numpy as np
import pytest
from conftest import random_rotation, random_skew
from scipy.integrate import solve_ivp

import lieint


def random_top(rng, n):
    Q = random_rotation(rng, n)
    return lieint.EulerTop(Q @ np.diag(rng.uniform(0.5, 2.0, n)) @ Q.T)


@pytest.mark.parametrize("n", [3, 5])
@pytest.mark.parametrize("method", ["rkmk4", "lie_euler"])
def test_lie_methods_keep_the_spectrum_to_round_off_over_1e4_steps(rng, n, method):
    top = random_top(rng, n)
    y0 = top.initial_state(Omega=random_skew(rng, n), R=random_rotation(rng, n))
    sol = lieint.integrate(top, y0, (0.0, 100.0), h=0.01, method=method, save_every=100)
    assert sol.nsteps == 10_000
    assert sol.drift("casimirs") <= 1e-12
    # The space momentum a = R A Rᵀ is kept too (the action moves R and A together), up to
    # round-off in R that accumulates about linearly without projection: 2.3e-12 measured for
    # n = 5 over 10⁴ steps, i.e. a budget of 1e-15 per step.
    assert sol.drift("momentum") <= 1e-15 * sol.nsteps


@pytest.mark.parametrize("n", [3, 5])
def test_classical_rk4_visibly_drifts(rng, n):
    top = random_top(rng, n)
    y0 = top.initial_state(Omega=random_skew(rng, n))
    kw = dict(t_span=(0.0, 100.0), h=0.1, save_every=100)
    lie = lieint.integrate(top, y0, method="rkmk4", **kw).drift("casimirs")
    rk4 = lieint.integrate(top, y0, method="rk4", **kw).drift("casimirs")
    # measured: n = 3: 9.8e-10 vs 2.2e-13; n = 5: 1.3e-6 vs 2.6e-13
    assert rk4 > 1e-10 and rk4 > 1e3 * lie, (rk4, lie)


@pytest.mark.slow
def test_projection_keeps_R_orthogonal_with_det_one_after_1e5_steps():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    sol = lieint.integrate(top, y0, (0.0, 1000.0), h=0.01, method="lie_euler", project=True, save_every=10_000)
    assert sol.nsteps == 100_000
    assert np.max(sol.invariants["orthogonality"]) <= 1e-14
    np.testing.assert_allclose(np.linalg.det(sol.states["R"]), 1.0, atol=1e-15)


def test_energy_error_shrinks_at_the_method_order(rng):
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    drifts = [lieint.integrate(top, y0, (0, 10), h=h, method="rkmk4").drift("energy") for h in (0.1, 0.05)]
    assert 10 < drifts[0] / drifts[1] < 25  # ≈ 2⁴


def test_manakov_integrals_are_first_integrals_of_the_4d_top(rng):
    """Independent truth: a tight DOP853 solution of the embedded ODE keeps them."""
    top = lieint.EulerTop(np.diag([0.5, 1.0, 1.7, 2.3]), orientation=False)
    A0 = top.initial_state(Omega=random_skew(rng, 4))["A"]

    def rhs(t, a):
        A = a.reshape(4, 4)
        return top.infinitesimal_action(top.angular_velocity(A), {"A": A})["A"].ravel()

    ref = solve_ivp(rhs, (0, 20), A0.ravel(), method="DOP853", rtol=1e-13, atol=1e-14, t_eval=[0, 5, 20])
    M = top.invariants["manakov"].function(None, {"A": ref.y.T.reshape(-1, 4, 4)})
    assert M.shape == (3, len(top.manakov_labels)) == (3, 2)
    assert np.max(np.abs(M - M[0])) / np.max(np.abs(M[0])) < 1e-11
    # ... and a non-invariant (tr(A² B)) does change: the check can fail.
    A = ref.y.T.reshape(-1, 4, 4)
    other = np.trace(A @ A @ top.B, axis1=-2, axis2=-1)
    assert np.ptp(other) / abs(other[0]) > 1e-3


def test_manakov_coefficients_match_a_direct_polynomial_fit(rng):
    n = 4
    A = random_skew(rng, n)
    S = np.diag([1.0, 4.0, 9.0, 16.0])
    top = lieint.EulerTop(np.diag([1.0, 2.0, 3.0, 4.0]), orientation=False)
    got = top.invariants["manakov"].function(None, {"A": A})
    lams = np.linspace(-1, 1, 5)
    for idx, (k, j) in enumerate(top.manakov_labels):
        vals = [np.trace(np.linalg.matrix_power(A - lam * S, k)) for lam in lams]
        coeff = np.polynomial.polynomial.polyfit(lams, vals, k)[j]
        assert np.isclose(got[idx], coeff, rtol=1e-9)


def test_energy_definition(rng):
    top = random_top(rng, 4)
    Om = random_skew(rng, 4)
    A = top.momentum(Om)
    assert np.isclose(top.energy(A), -0.5 * np.trace(Om @ top.B @ Om))
    assert top.energy(A) > 0
    np.testing.assert_allclose(top.angular_velocity(A), Om, atol=1e-13)
