"""What the adaptive pairs' tolerance buys, measured against scipy's pairs (see
docs/measurements/adaptive.md): the controller and the norm are scipy's; the Lie pairs' larger
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


def test_the_controller_is_scipys_first_step_and_dop853_estimate():
    """The first trial step is scipy's ``select_initial_step`` on the same state, and the 8(5,3)
    pair's two estimates combine as scipy's DOP853 combines them."""
    from scipy.integrate._ivp.common import select_initial_step

    from lieint.control import StepSizeController
    from lieint.methods.scipy_ivp import StateLayout

    y0 = TOP.initial_state(angular_velocity=[0.3, 0.5, 1.0])
    layout = StateLayout(y0)
    rtol, atol = 1e-7, 1e-10
    ctrl = StepSizeController(rtol, atol)

    def rhs(t, z):
        return layout.pack(TOP.vector_field(t, layout.unpack(z)))

    z0 = layout.pack(y0)
    for q in (2, 4, 7):
        ref = select_initial_step(rhs, 0.0, z0, 100.0, np.inf, rhs(0.0, z0), 1, q, rtol, atol)
        assert ctrl.initial_step(TOP, 0.0, y0, 100.0, q) == pytest.approx(ref, rel=1e-12)
    rng = np.random.default_rng(0)
    e5 = {k: 1e-7 * rng.standard_normal(v.shape) for k, v in y0.items()}
    e3 = {k: 1e-5 * rng.standard_normal(v.shape) for k, v in y0.items()}
    scale = atol + rtol * np.abs(layout.pack(y0))
    s5, s3 = np.sum((layout.pack(e5) / scale) ** 2), np.sum((layout.pack(e3) / scale) ** 2)
    expected = s5 / np.sqrt((s5 + 0.01 * s3) * scale.size)
    assert ctrl.error_norm(y0, y0, (e5, e3)) == pytest.approx(expected, rel=1e-12)
    assert lieint.get_method("rkmk853").error_order == 7  # scipy's error_estimator_order of DOP853


@pytest.mark.parametrize("rtol", [1e-7, 1e-9])
def test_the_853_pair_takes_dop853s_steps(rtol):
    """With DOP853's combined estimate and exponent 1/8, rkmk853 takes as many accepted steps as
    scipy's DOP853 at equal settings (the 5th-order estimate alone with exponent 1/6 took 1.6–2×
    more and bought a global error far below rtol: its error / rtol fell 70× from 1e-5 to 1e-9)."""
    y0 = TOP.initial_state(angular_velocity=[0.3, 0.5, 1.0])
    _, lie = global_ratio("rkmk853", y0, 30.0, rtol)
    _, ref = global_ratio("scipy:DOP853", y0, 30.0, rtol)
    assert abs(lie.stats.nsteps / ref.stats.nsteps - 1) < 0.2, (lie.stats.nsteps, ref.stats.nsteps)
