"""Commutator-free (cf3, cf4) and Crouch–Grossman (cg3, cg4a) methods: coefficients and orders."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import fitted_slope

import lieint
from lieint.methods import commutator_free as cf
from lieint.methods.order_conditions import order_residuals

TOP = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
Y0 = TOP.initial_state(angular_velocity=[0.3, 1.0, 0.4])
T = 5.0
EXACT = TOP.exact_solution([T], Y0)["A"][-1]
METHODS = {"cf3": (cf.CF3, 3), "cf4": (cf.CF4, 4), "cg3": (cf.CG3, 3), "cg4a": (cf.CG4A, 4)}


def top_error(method, n):
    h, t, y = T / n, 0.0, Y0
    for _ in range(n):
        y, t = method.step(TOP, t, y, h, None).y, t + h
    return float(np.linalg.norm(y["A"] - EXACT))


@pytest.mark.parametrize("name", list(METHODS))
def test_summed_tableau_has_the_classical_order_and_not_more(name):
    method, p = METHODS[name]
    assert lieint.get_method(name) is method and method.order == p
    A, b = method.classical_A, method.classical_b
    assert max(abs(r) for _, r in order_residuals(A, b, p)) < 1e-13
    assert max(abs(r) for _, r in order_residuals(A, b, p + 1)) > 1e-6


@pytest.mark.parametrize("name", list(METHODS))
def test_order_on_the_top_in_the_asymptotic_regime(name):
    method, p = METHODS[name]
    ns = [80, 160, 320]
    errs = [top_error(method, n) for n in ns]
    assert abs(fitted_slope([T / n for n in ns], errs) - p) <= 0.1, errs


@pytest.mark.parametrize("name", list(METHODS))
def test_the_group_action_keeps_the_casimirs(name):
    sol = lieint.integrate(TOP, Y0, (0.0, 20.0), h=0.1, method=name, dense_output=True)
    assert sol.drift("casimirs") < 1e-13 and sol.drift("orthogonality") < 1e-13
    R = sol.sol(7.33)["R"]
    assert np.abs(R.T @ R - np.eye(3)).max() < 1e-14


def test_composition_order_matters():
    """Applying the exponentials in the opposite order (the convention of the other action) keeps
    the summed classical tableau but breaks the non-commutative conditions: order 2."""
    for method in (cf.CF4, cf.CG4A):
        rev = cf.CommutatorFree(
            method.name + "-reversed",
            method.order,
            method.c,
            tuple(tuple(reversed(st)) for st in method.stages),
            tuple(reversed(method.output)),
        )
        ns = [80, 160, 320]
        errs = [top_error(rev, n) for n in ns]
        assert abs(fitted_slope([T / n for n in ns], errs) - 2) <= 0.1, errs


def test_bad_coefficients_are_refused():
    with pytest.raises(ValueError, match="does not have order 4"):
        cf.CommutatorFree("x", 4, (0.0, 0.5), ((), ((0.5, 0.0),)), ((0.0, 1.0),))
    with pytest.raises(ValueError, match="earlier stages"):
        cf.CommutatorFree("x", 1, (0.0, 0.5), ((), ((0.5, 0.5),)), ((0.0, 1.0),))
