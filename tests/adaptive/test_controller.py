"""Adaptive RKMK from embedded pairs: order-checked pairs, error control on the state."""

import itertools

import numpy as np
import pytest

import lieint
from lieint.control import StepSizeController
from lieint.methods import RKMK, tableaux
from lieint.methods.order_conditions import order_residuals


def error_norm(y0, y1, y_hat, rtol, atol):
    return StepSizeController(rtol, atol).error_norm(y0, y1, {k: y1[k] - y_hat[k] for k in y1})


@pytest.mark.parametrize(
    ("pair", "p", "q"),
    [(tableaux.BOGACKI_SHAMPINE32, 3, 2), (tableaux.DORMAND_PRINCE54, 5, 4), (tableaux.DORMAND_PRINCE853, 8, 5)],
)
def test_pairs_have_their_orders(pair, p, q):
    assert (pair.order, pair.embedded_order) == (p, q)
    assert max(abs(r) for _, r in order_residuals(pair.tableau.A, pair.tableau.b, p)) < 1e-12
    assert max(abs(r) for _, r in order_residuals(pair.tableau.A, pair.b_hat, q)) < 1e-12
    assert max(abs(r) for _, r in order_residuals(pair.tableau.A, pair.b_hat, q + 1)) > 1e-8


def test_dexpinv_truncation_follows_the_pair():
    assert lieint.get_method("rkmk853").dexpinv_degree == 6
    assert lieint.get_method("rkmk45").dexpinv_degree == 3
    with pytest.raises(ValueError, match="caps an order-8 RKMK method at order 7"):
        RKMK("x", tableaux.DORMAND_PRINCE853, dexpinv_degree=5)


def test_error_is_measured_on_the_state_relative_to_its_size():
    y0 = {"A": np.array([1.0, 1e-6])}
    y1 = {"A": np.array([1.0 + 1e-9, 1e-6])}
    yh = {"A": np.array([1.0, 1e-6 + 1e-9])}
    # the same absolute difference 1e-9 is small on the large component and large on the small one
    assert error_norm(y0, y1, {"A": y1["A"] + np.array([1e-9, 0.0])}, rtol=1e-8, atol=1e-12) < 0.1
    assert error_norm(y0, y1, yh, rtol=1e-8, atol=1e-12) > 10


@pytest.mark.parametrize("method", ["rkmk23", "rkmk45", "rkmk853"])
def test_tolerance_controls_the_global_error(method):
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    errors = []
    tols = [1e-5, 1e-7, 1e-9] if method != "rkmk23" else [1e-4, 1e-6]
    for tol in tols:
        sol = lieint.integrate(top, y0, (0, 10), method=method, rtol=tol, atol=tol * 1e-2)
        assert sol.success and sol.t[-1] == 10.0
        exact = top.exact_solution(sol.t, y0)["A"]
        errors.append(np.max(np.abs(sol.states["A"] - exact)))
        assert sol.drift("casimirs") < 1e-13  # still a Lie-group method
    assert all(a > 10 * b for a, b in itertools.pairwise(errors)), errors


def test_rejected_steps_are_retried_not_accepted():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    sol = lieint.integrate(top, y0, (0, 10), h=5.0, method="rkmk45", rtol=1e-8, atol=1e-10)
    assert sol.stats.nrejected >= 1 and sol.success
    exact = top.exact_solution(sol.t, y0)["A"]
    assert np.max(np.abs(sol.states["A"] - exact)) < 1e-5
    # far past the dexp⁻¹ radius at the first trial: rejected, not raised
    fast = top.initial_state(angular_velocity=[0.0, 0.3, 20.0])
    sol = lieint.integrate(top, fast, (0, 1), h=2.0, method="rkmk853", rtol=1e-6, atol=1e-8)
    assert sol.success and sol.stats.nrejected >= 1


def test_adaptive_works_on_any_system():
    ball = lieint.ChaplyginBall(np.diag([0.1, 0.15, 0.2]), 1.0, 1.0)
    y0 = ball.initial_state(angular_velocity=[1.0, 2.0, 0.5])
    sol = lieint.integrate(ball, y0, (0, 5), method="rkmk45", rtol=1e-9, atol=1e-11, save_every=5)
    assert sol.success and sol.drift("energy") < 1e-7 and sol.drift("casimirs") < 1e-13
