"""The trust horizon against what it predicts: the time at which the h and h/4 runs part.

The truth is two :func:`lieint.integrate` runs (compiled) at h and h/4: their difference is
``e_h − e_{h/4} ≈ (1 − 4⁻ᵖ) e_h``, the global error of the h run to within 0.4 % for rkmk4.
"""

from __future__ import annotations

import numpy as np
import pytest

import lieint


def near_separatrix(delta, y=1.0, z=0.3):
    """w with ``(G² − 2E I₂)/(2E I₂) ≈ delta`` for I = (1, 2, 3): ``G² − 2E I₂ = 3z² − x²``."""
    x = np.sqrt((3 * z * z - 2 * delta * (2 * y * y + 3 * z * z)) / (1 + 2 * delta))
    return [x, y, z]


def parting(system, y0, T, h, method, tolerance):
    """The grid time at which the h and h/4 runs first differ by more than ``tolerance`` (largest
    entry of A or R), and that difference on the h grid."""
    a = lieint.integrate(system, y0, (0.0, T), h=h, method=method)
    b = lieint.integrate(system, y0, (0.0, T), h=h / 4, method=method, t_eval=a.t)
    d = np.max([np.abs(a.states[k] - b.states[k]).reshape(len(a.t), -1).max(axis=1) for k in ("A", "R")], axis=0)
    assert d.max() > tolerance, "the runs never part: the comparison would say nothing"
    return a.t[np.argmax(d > tolerance)], d


def test_the_separatrix_run_is_trusted_until_its_h_and_h4_runs_part():
    """The free 3D top 10⁻³ from the separatrix (moments 1, 2, 3), rkmk4 at h = 0.1: the horizon
    for 1e-3 within a factor 2 of the time the h and h/4 runs part by 1e-3 (t ≈ 35), while the
    energy drift says nothing is wrong."""
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=near_separatrix(1e-3))
    T, h = 50.0, 0.1
    truth, d = parting(top, y0, T, h, "rkmk4", 1e-3)
    run = lieint.trust_horizon(top, y0, (0.0, T), h=h, method="rkmk4", tolerance=1e-3)
    assert 0.5 * truth <= run.horizon <= 2.0 * truth, (run.horizon, truth)
    # the estimate follows the actual error before the horizon (it is first order in the error)
    early = run.t <= truth
    big = early & (d > 1e-5)
    assert np.all(np.abs(run.estimate[big] - d[big]) < 0.2 * d[big])
    sol = lieint.integrate(top, y0, (0.0, T), h=h, method="rkmk4")
    assert sol.drift("energy") < 1e-5  # what the monitor says: 6e-7 while the state errs by 1e-3


def test_a_second_order_splitting_is_trusted_until_its_runs_part():
    """splitting2 (order 2, so step doubling's factor 4/3) on the same top at h = 0.02: its
    h and h/4 runs part by 1e-3 at t ≈ 4.8."""
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=near_separatrix(1e-3))
    truth, _ = parting(top, y0, 8.0, 0.02, "splitting2", 1e-3)
    run = lieint.trust_horizon(top, y0, (0.0, 8.0), h=0.02, method="splitting2", tolerance=1e-3, stop=True)
    assert 0.5 * truth <= run.horizon <= 2.0 * truth, (run.horizon, truth)


def test_a_batch_reports_one_horizon_per_body_and_stop_ends_the_run():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[near_separatrix(1e-3), [1.0, 0.3, 0.2]])
    run = lieint.trust_horizon(top, y0, (0.0, 40.0), h=0.1, tolerance=1e-3)
    assert run.horizon.shape == (2,) and 17.5 < run.horizon[0] < 70 and run.horizon[1] == np.inf
    one = lieint.trust_horizon(top, {k: v[0] for k, v in y0.items()}, (0.0, 40.0), h=0.1, tolerance=1e-3, stop=True)
    assert one.horizon == run.horizon[0] and one.t[-1] == pytest.approx(one.horizon)


def test_bad_input_is_refused_by_name():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    for bad in (0.0, -1.0, float("nan"), "1e-3", True):
        with pytest.raises(ValueError, match=r"`tolerance` must be a finite positive number"):
            lieint.trust_horizon(top, y0, (0.0, 1.0), h=0.1, tolerance=bad)
    with pytest.raises(TypeError, match=r"`stop` must be True or False"):
        lieint.trust_horizon(top, y0, (0.0, 1.0), h=0.1, stop="yes")
    with pytest.raises(ValueError, match=r"`method` 'exact_flow' has no tangent map"):
        lieint.trust_horizon(top, y0, (0.0, 1.0), h=0.1, method="exact_flow")
    with pytest.raises(ValueError, match=r"`h` must be a finite positive number"):
        lieint.trust_horizon(top, y0, (0.0, 1.0), h=-0.1)
