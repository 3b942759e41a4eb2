"""The driver: batches, saving, the scipy adapter, failure reporting."""

import numpy as np
import pytest
from conftest import random_rotation, random_skew

import lieint


@pytest.fixture
def top3():
    return lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])


def test_batch_integrates_as_one_ensemble_equal_to_a_loop(rng, top3):
    w = rng.normal(size=(2, 3, 3))
    R = random_rotation(rng, 3, (2, 3))
    y0 = top3.initial_state(angular_velocity=w, R=R)
    sol = lieint.integrate(top3, y0, (0, 1), h=0.05, method="rkmk4", project=True)
    assert sol.states["A"].shape == (21, 2, 3, 3, 3)
    assert sol.invariants["energy"].shape == (21, 2, 3)
    assert sol.drift("casimirs").shape == (2, 3)
    for i in range(2):
        for j in range(3):
            single = lieint.integrate(
                top3,
                top3.initial_state(angular_velocity=w[i, j], R=R[i, j]),
                (0, 1),
                h=0.05,
                method="rkmk4",
                project=True,
            )
            np.testing.assert_allclose(sol.states["A"][:, i, j], single.states["A"], atol=1e-14)
            np.testing.assert_allclose(sol.states["R"][:, i, j], single.states["R"], atol=1e-14)


def test_large_ensemble_without_python_loop_over_bodies(rng, top3):
    y0 = top3.initial_state(angular_velocity=rng.normal(size=(10_000, 3)))
    sol = lieint.integrate(top3, y0, (0, 0.1), h=0.01, method="rkmk4", save_every=5)
    assert sol.states["R"].shape == (3, 10_000, 3, 3)
    assert np.max(sol.drift("casimirs")) < 1e-13


def test_save_every_keeps_every_kth_step_and_the_last(top3):
    y0 = top3.initial_state(angular_velocity=[0.1, 1.0, 0.2])
    sol = lieint.integrate(top3, y0, (0, 1.0), h=0.1, save_every=3)
    np.testing.assert_allclose(sol.t, [0.0, 0.3, 0.6, 0.9, 1.0])
    full = lieint.integrate(top3, y0, (0, 1.0), h=0.1)
    np.testing.assert_allclose(sol.states["A"], full.states["A"][[0, 3, 6, 9, 10]])
    assert sol.nsteps == 10 and sol.nfev == 40


def test_last_step_lands_on_t1(top3):
    y0 = top3.initial_state(angular_velocity=[0.1, 1.0, 0.2])
    sol = lieint.integrate(top3, y0, (0, 1.05), h=0.1)
    assert sol.nsteps == 11 and sol.t[-1] == 1.05
    exact = top3.exact_solution([1.05], y0)["A"][-1]
    assert np.linalg.norm(sol.states["A"][-1] - exact) < 1e-4


def test_n2_top_keeps_omega_constant(rng):
    top = lieint.EulerTop(np.diag([1.0, 3.0]))
    Om = random_skew(rng, 2)
    sol = lieint.integrate(top, top.initial_state(Omega=Om), (0, 10), h=0.1, method="rkmk4")
    np.testing.assert_allclose(sol.states["A"], np.broadcast_to(top.momentum(Om), sol.states["A"].shape), atol=1e-14)
    theta = Om[1, 0] * 10
    np.testing.assert_allclose(
        sol.states["R"][-1], [[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]], atol=1e-12
    )


@pytest.mark.parametrize("solver", ["RK45", "DOP853", "Radau", "LSODA"])
def test_scipy_adapter_runs_the_same_system(top3, solver):
    y0 = top3.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    sol = lieint.integrate(top3, y0, (0, 5), h=0.5, method=f"scipy:{solver}", rtol=1e-10, atol=1e-12)
    assert sol.success and sol.t.size == 11
    exact = top3.exact_solution(sol.t, y0)["A"]
    assert np.max(np.abs(sol.states["A"] - exact)) < 1e-6


def test_scipy_adapter_with_projection_at_save_points(top3):
    y0 = top3.initial_state(angular_velocity=[0.3, 1.0, 0.4], R=random_rotation(np.random.default_rng(1), 3, (2,)))
    kw = dict(t_span=(0, 50), method="scipy:RK45", rtol=1e-5, atol=1e-7, t_eval=np.linspace(0, 50, 26))
    raw = lieint.integrate(top3, y0, **kw)
    proj = lieint.integrate(top3, y0, project=True, **kw)
    assert np.max(proj.invariants["orthogonality"]) < 1e-14
    assert np.max(raw.invariants["orthogonality"]) > 1e-8


def test_a_blow_up_is_reported_not_silent():
    top = lieint.EulerTop(np.diag([1e-12, 1.0, 1.0]))
    y0 = top.initial_state(angular_velocity=[10.0, 10.0, 10.0])
    with pytest.warns(lieint.LieStepWarning):
        sol = lieint.integrate(top, y0, (0, 100), h=1.0, method="rk4")
    assert not sol.success
    assert "non-finite" in sol.message and "Reduce the step" in sol.message
    assert np.all(np.isfinite(sol.states["A"]))


def test_cayley_method_object_and_method_names(top3):
    m = lieint.get_method("rkmk4", coordinates="cayley")
    assert m.coordinates == "cayley" and m.name == "rkmk4[cayley]"
    y0 = top3.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    sol = lieint.integrate(top3, y0, (0, 1), h=0.1, method=m)
    assert sol.method == "rkmk4[cayley]"
    names = lieint.method_names()
    assert {"lie_euler", "rkmk2", "rkmk3", "rkmk4", "rkmk6", "rk4", "scipy:DOP853"} <= set(names)


def test_invariants_are_lazy_and_only_those_of_the_system(top3):
    y0 = top3.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    sol = lieint.integrate(top3, y0, (0, 1), h=0.1)
    assert set(sol.invariants) == {"energy", "casimirs", "manakov", "momentum", "orthogonality"}
    assert sol.invariants._cache == {}
    sol.invariants["energy"]
    assert list(sol.invariants._cache) == ["energy"]
    with pytest.raises(KeyError, match="Unknown invariant 'flux'"):
        sol.invariants["flux"]


def test_top_without_orientation_steps_only_A(top3):
    top = lieint.EulerTop(top3.B, orientation=False)
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    sol = lieint.integrate(top, y0, (0, 1), h=0.1)
    assert list(sol.states) == ["A"]
    assert "momentum" not in sol.invariants
    full = lieint.integrate(top3, top3.initial_state(angular_velocity=[0.3, 1.0, 0.4]), (0, 1), h=0.1)
    np.testing.assert_allclose(sol.states["A"], full.states["A"], atol=1e-15)


def test_the_stats_name_every_field_of_the_run_fixed_and_adaptive():
    # the driver builds Stats by position: every field must hold what its name says
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    fixed = lieint.integrate(top, y0, (0.0, 1.0), h=0.1, method="rkmk4", save_every=3, project=True).stats
    assert (fixed.method, fixed.order, fixed.coordinates, fixed.backend) == ("rkmk4", 4, "exp", "numba")
    assert fixed.backend_reason.startswith("compiled engine") and (fixed.nsteps, fixed.nrejected) == (10, 0)
    assert fixed.nfev == 40 and fixed.cpu_time >= 0.0 and fixed.wall_time >= 0.0
    assert (fixed.h, fixed.rtol, fixed.atol, fixed.project, fixed.save_every, fixed.threads) == (
        0.1,
        None,
        None,
        True,
        3,
        1,
    )
    adaptive = lieint.integrate(top, y0, (0.0, 1.0), method="rkmk45", rtol=1e-7, atol=1e-9).stats
    assert (adaptive.method, adaptive.order, adaptive.h, adaptive.rtol, adaptive.atol) == (
        "rkmk45",
        5,
        None,
        1e-7,
        1e-9,
    )
    assert (adaptive.project, adaptive.save_every, adaptive.threads) == (False, 1, 1)
    assert adaptive.nsteps > 0 and adaptive.nfev >= 6 * adaptive.nsteps
