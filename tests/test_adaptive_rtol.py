"""What the adaptive pairs' tolerance buys, measured against scipy's pairs (see the guide,
"Adaptive steps and rtol"): the controller and the norm are scipy's; the Lie pairs' larger
global error comes from their error structure (the Casimir kept, the energy not)."""

from __future__ import annotations

import numpy as np
import pytest

import lieint

TOP = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])


def global_ratio(method, y0, T, rtol, system=TOP):
    sol = lieint.integrate(system, y0, (0.0, T), method=method, rtol=rtol, atol=1e-3 * rtol)
    exact = system.exact_solution(sol.t, y0)["A"]
    err = np.max(np.linalg.norm(sol.states["A"] - exact, axis=(-2, -1))) / np.linalg.norm(y0["A"])
    return err / rtol, sol


def test_the_controller_turns_equal_estimates_into_scipys_steps():
    """rkmk23 and RK23 see estimates of the same size and take the same steps at equal settings."""
    y0 = TOP.initial_state(angular_velocity=[0.3, 0.5, 1.0])
    _, lie = global_ratio("rkmk23", y0, 30.0, 1e-5)
    _, ref = global_ratio("scipy:RK23", y0, 30.0, 1e-5)
    assert abs(lie.stats.nsteps / ref.stats.nsteps - 1) < 0.05, (lie.stats.nsteps, ref.stats.nsteps)


@pytest.mark.parametrize("method", ["rkmk23", "rkmk45"])
def test_global_error_is_proportional_to_rtol(method):
    y0 = TOP.initial_state(angular_velocity=[0.3, 0.5, 1.0])
    r4, _ = global_ratio(method, y0, 30.0, 1e-4)
    r6, _ = global_ratio(method, y0, 30.0, 1e-6)
    assert 0.6 < r6 / r4 < 1.4, (r4, r6)


def test_near_the_separatrix_the_lie_error_changes_the_orbit_the_classical_one_scales_it():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0], orientation=False)
    y0 = top.initial_state(angular_velocity=[0.01, 1.0, 0.01])
    E0, C0 = float(top.energy(y0["A"])), np.linalg.norm(y0["A"])
    drifts = {}
    for method in ("rkmk45", "scipy:RK45"):
        sol = lieint.integrate(top, y0, (0.0, 40.0), method=method, rtol=1e-6, atol=1e-9)
        A = sol.states["A"][-1]
        drifts[method] = (float(top.energy(A)) / E0 - 1, np.linalg.norm(A) / C0 - 1)
    dE, dC = drifts["rkmk45"]
    assert abs(dC) < 1e-13 and abs(dE) > 1e-8  # |A| kept: the energy error selects another orbit
    dE, dC = drifts["scipy:RK45"]
    assert abs(dE) > 1e-8 and abs(dC / dE - 0.5) < 0.05  # a scaling of A: E/|A|² (the orbit's shape) kept
