"""Compiled 3D-top kernels: single trajectories run serially; no cliff at coarse steps."""

import numpy as np
import pytest
from conftest import random_rotation

import lieint
from lieint.fast.engine import use_threads


def top3():
    I = np.array([1.1, 1.7, 2.3])
    return lieint.EulerTop(np.diag((I.sum() - 2 * I) / 2))


def test_fewer_bodies_than_threads_run_serially():
    parallel, threads = use_threads(1)
    assert not parallel and threads == 1
    import numba

    many = numba.get_num_threads()
    assert use_threads(many) == (many > 1, many if many > 1 else 1)


def test_a_single_trajectory_reports_the_serial_kernel(rng):
    top = top3()
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    sol = lieint.integrate(top, y0, (0, 1), h=0.01, backend="numba")
    assert sol.stats.threads == 1 and "serial" in sol.stats.backend_reason


@pytest.mark.parametrize("bodies", [2, 70])  # per body / SIMD lanes
def test_ensembles_in_threads_match_the_generic_path(rng, bodies):
    import numba

    top = top3()
    y0 = top.initial_state(angular_velocity=rng.normal(size=(bodies, 3)), R=random_rotation(rng, 3, (bodies,)))
    kw = dict(t_span=(0.0, 1.0), h=0.01, method="rkmk4", save_every=50)
    fast = lieint.integrate(top, y0, backend="numba", **kw)
    ref = lieint.integrate(top, y0, backend="numpy", **kw)
    if bodies >= 64 * numba.get_num_threads() or (bodies < 64 and bodies >= numba.get_num_threads() > 1):
        assert fast.stats.threads == numba.get_num_threads()
    scale = np.abs(ref.states["A"]).max()
    np.testing.assert_allclose(fast.states["A"], ref.states["A"], atol=1e-13 * scale)
    np.testing.assert_allclose(fast.states["R"], ref.states["R"], atol=1e-13)


@pytest.mark.parametrize("bodies", [1, 70])
def test_coarse_rkmk6_steps_stay_compiled_and_match(rng, bodies):
    # |w| ≈ 1.3 and h = 0.5: the old a-priori bound h·|w|·max Σ|a_ij| ≥ π sent this to the generic path
    top = top3()
    w = np.array([0.3, 1.0, 0.4]) * 1.2 + 0.01 * rng.normal(size=(bodies, 3))
    y0 = top.initial_state(angular_velocity=w)
    kw = dict(t_span=(0.0, 20.0), h=0.5, method="rkmk6", save_every=8)
    fast = lieint.integrate(top, y0, backend="auto", **kw)
    ref = lieint.integrate(top, y0, backend="numpy", **kw)
    assert fast.stats.backend == "numba"
    scale = np.abs(ref.states["A"]).max()
    np.testing.assert_allclose(fast.states["A"], ref.states["A"], atol=1e-12 * scale)
    np.testing.assert_allclose(fast.states["R"], ref.states["R"], atol=1e-12)


@pytest.mark.parametrize("bodies", [1, 70])
def test_a_stage_beyond_the_series_radius_fails_on_both_paths(bodies):
    top = top3()
    y0 = top.initial_state(angular_velocity=np.broadcast_to([0.3, 4.0, 0.4], (bodies, 3)))
    kw = dict(t_span=(0.0, 10.0), h=5.0, method="rkmk4")
    for backend in ("numpy", "numba"):
        with pytest.raises(lieint.DexpinvRangeError, match="Lie step too large for exponential coordinates"):
            lieint.integrate(top, y0, backend=backend, **kw)
