"""Ensembles of the 3D heavy top in SIMD lanes (lieint.fast.heavy_lanes): the generic path's
numbers for every method the lanes serve, the same bits however the ensemble is cut, a body's
result independent of its neighbours, the Casimirs kept, and the errors of the per-body path."""

from __future__ import annotations

import numpy as np
import pytest
from bodies import spd
from conftest import compiled_methods, random_rotation

import lieint

#: the methods the lanes serve: fixed-step RKMK in exponential coordinates
LANES_METHODS = [m for m in compiled_methods() if lieint.get_method(m).compiled().family == "rkmk"]


def _heavy(rng, orientation=True, diagonal=False):
    B = np.diag(rng.uniform(0.5, 1.5, 3)) if diagonal else spd(rng, 3, 0.5, 1.5)
    return lieint.HeavyTop(B, 1.3, 0.3 * rng.normal(size=3), [0.0, 0.0, -9.81], orientation=orientation)


def _ensemble(top, rng, n):
    kw = {"R": random_rotation(rng, 3, (n,))} if top.orientation else {}
    return top.initial_state(angular_velocity=rng.normal(size=(n, 3)), **kw)


def test_the_lanes_serve_every_fixed_step_rkmk_method_in_exponential_coordinates():
    # the list the tests below run is the registry's, and not empty
    assert {"lie_euler", "rkmk4", "rkmk6"} <= set(LANES_METHODS)


@pytest.mark.parametrize("method", LANES_METHODS)
def test_heavy_lanes_match_the_generic_path(rng, method):
    """Every lanes method against the numpy path (non-diagonal B: the principal frame turned;
    13 bodies: a block of 16 lanes with three spare), projected and not, with and without R;
    one body spins fast enough (θ = |w| h ≥ 0.1) for the trigonometric coefficients."""
    for orientation, project in ((True, False), (False, True)):
        top = _heavy(rng, orientation)
        y0 = _ensemble(top, rng, 13)
        y0["A"][5] *= 30.0
        kw = dict(t_span=(0.0, 0.6), h=0.02, method=method, project=project, save_every=10)
        fast = lieint.integrate(top, y0, backend="numba", **kw)
        ref = lieint.integrate(top, y0, backend="numpy", **kw)
        assert "3D heavy top in SIMD lanes" in fast.stats.backend_reason
        assert list(fast.states) == list(ref.states) and fast.states["A"].shape == (4, 13, 3, 3)
        for name, values in ref.states.items():
            scale = max(1.0, np.abs(values).max())
            np.testing.assert_allclose(fast.states[name], values, rtol=0, atol=3e-14 * scale, err_msg=name)


def test_an_ensemble_cut_in_chunks_gives_one_calls_bits(rng):
    """The same body gives the same bits in a call of 140 bodies (two blocks of 128 lanes) and
    in chunks of 64 and 12 (blocks of 64 and 16 lanes, the body at other positions), also beside
    a body whose steps reach θ = |w| h ≥ 0.1 (its block takes the trigonometric fix-up)."""
    top = _heavy(rng)
    n = 140
    y0 = _ensemble(top, rng, n)
    y0["A"][40] *= 40.0
    kw = dict(t_span=(0.0, 0.3), h=0.01, method="rkmk4", save_every=10)
    whole = lieint.integrate(top, y0, **kw)
    assert "SIMD lanes" in whole.stats.backend_reason
    for lo, hi in ((5, 69), (128, 140)):
        part = lieint.integrate(top, {k: v[lo:hi] for k, v in y0.items()}, **kw)
        for name in ("A", "Gamma", "R"):
            assert np.array_equal(part.states[name], whole.states[name][:, lo:hi]), (lo, name)


def test_one_body_of_the_ensemble_is_the_body_run_alone(rng):
    """A body alone runs on the per-body path (the heavy top's compiled pieces): the same
    numbers to round-off as the body in an ensemble's lanes."""
    top = _heavy(rng)
    y0 = _ensemble(top, rng, 9)
    kw = dict(t_span=(0.0, 1.0), h=0.01, method="rkmk6", save_every=20)
    ensemble = lieint.integrate(top, y0, **kw)
    alone = lieint.integrate(top, {k: v[6] for k, v in y0.items()}, **kw)
    assert "SIMD lanes" in ensemble.stats.backend_reason and "compiled pieces" in alone.stats.backend_reason
    for name, values in alone.states.items():
        scale = max(1.0, np.abs(values).max())
        np.testing.assert_allclose(ensemble.states[name][:, 6], values, rtol=0, atol=2e-14 * scale, err_msg=name)


def test_the_lanes_keep_the_casimirs_and_the_attitude(rng):
    """The right action keeps ⟨Π, Γ⟩ and |Γ| exactly (Γ and Π + t × Γ turn by one rotation), so
    over 2,000 unprojected steps they drift by round-off only, and R stays a rotation; the
    energy error of RKMK4 is that of the generic path (it is the same map)."""
    top = _heavy(rng)
    y0 = _ensemble(top, rng, 24)
    sol = lieint.integrate(top, y0, (0.0, 20.0), h=0.01, method="rkmk4", project=False, save_every=500)
    assert "SIMD lanes" in sol.stats.backend_reason
    assert np.max(sol.drift("casimirs")) < 1e-12
    assert np.max(sol.drift("gamma_norm")) < 1e-12
    assert np.max(sol.invariants["orthogonality"]) < 1e-13
    assert 0 < np.max(sol.drift("energy")) < 1e-6


def test_dense_output_and_t_eval_of_the_lanes_are_the_generic_ones(rng):
    """The lanes keep every step's state and increment in se(3): the interpolant between the
    steps and the rows at ``t_eval`` are the numpy path's (events need a single body)."""
    top = _heavy(rng, diagonal=True)
    y0 = _ensemble(top, rng, 3)
    kw = dict(t_span=(0.0, 1.0), h=0.02, method="rkmk4", dense_output=True, t_eval=np.linspace(0.0, 1.0, 7))
    fast = lieint.integrate(top, y0, backend="numba", **kw)
    ref = lieint.integrate(top, y0, backend="numpy", **kw)
    assert "SIMD lanes" in fast.stats.backend_reason
    midway = np.linspace(0.011, 0.987, 9)
    for name in ref.states:
        scale = max(1.0, np.abs(ref.states[name]).max())
        np.testing.assert_allclose(fast.states[name], ref.states[name], rtol=0, atol=3e-14 * scale)
        np.testing.assert_allclose(fast.sol(midway)[name], ref.sol(midway)[name], rtol=0, atol=3e-14 * scale)


def test_a_step_beyond_the_dexpinv_radius_is_refused_as_on_the_generic_path(rng):
    top = _heavy(rng)
    y0 = _ensemble(top, rng, 4)
    y0["A"][2] *= 400.0  # |w| h ≥ 2π at a stage
    for backend in ("numba", "numpy"):
        with pytest.raises(lieint.DexpinvRangeError, match="se\\(3\\)"):
            lieint.integrate(top, y0, (0.0, 1.0), h=0.1, method="rkmk4", backend=backend)
