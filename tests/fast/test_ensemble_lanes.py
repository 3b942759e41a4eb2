"""Ensembles of the 3D heavy top, the 3D Chaplygin ball, the 3D rolling ball (offset centre of
mass, gravity along the normal or on an incline) and the 4D Euler top in SIMD lanes
(lieint.fast.heavy_lanes, chaplygin_lanes, rolling_lanes, top4_lanes): the generic path's
numbers for every method the lanes serve, the
same bits however the ensemble is cut, a body's result independent of its neighbours, the
invariants the right action keeps, dense output, and the per-body path's errors."""

from __future__ import annotations

import numpy as np
import pytest
from bodies import assert_states_close, body3, spd, spin_field
from conftest import compiled_methods, random_rotation

import lieint

#: the methods the lanes serve: fixed-step RKMK in exponential coordinates
LANES_METHODS = [m for m in compiled_methods() if lieint.get_method(m).compiled().family == "rkmk"]
KINDS = ("heavy top", "Chaplygin ball", "rolling ball", "ball on an incline", "4D top")
#: what each kind's ensembles are called in ``sol.stats.backend_reason``
LABELS = {"heavy top": "3D heavy top", "Chaplygin ball": "3D Chaplygin ball", "rolling ball": "3D rolling ball",
          "ball on an incline": "3D rolling ball", "4D top": "4D top"}  # fmt: skip
#: the invariants the right action keeps exactly (besides R on SO(n))
KEPT = {
    "heavy top": ["casimirs", "gamma_norm"], "Chaplygin ball": ["casimirs", "gamma_norm", "gamma_A2_gamma"],
    "rolling ball": ["gamma_norm"], "ball on an incline": ["gamma_norm"], "4D top": ["casimirs", "momentum"],
}  # fmt: skip


def _body(kind, rng, full=True, diagonal=False):
    """A 4D top (``kind`` "4D top"), else :func:`bodies.body3`'s 3D body."""
    if kind == "4D top":
        B = np.diag(rng.uniform(0.5, 2.5, 4)) if diagonal else spd(rng, 4, 0.5, 2.5)
        return lieint.EulerTop(B, orientation=full)
    return body3(kind, rng, full, diagonal)


def _ensemble(system, rng, n):
    kw = {"R": random_rotation(rng, system.n, (n,))} if "R" in system.fields else {}
    if system.n == 4:
        W = rng.normal(size=(n, 4, 4))
        return system.initial_state(Omega=W - np.swapaxes(W, 1, 2), **kw)
    y0 = system.initial_state(angular_velocity=rng.normal(size=(n, 3)), **kw)
    if "center" in y0:  # anywhere on the plane
        y0["center"][:, :2] = rng.normal(size=(n, 2))
    return y0


def test_the_lanes_serve_every_fixed_step_rkmk_method_in_exponential_coordinates():
    # the list the tests below run is the registry's, and not empty
    assert {"lie_euler", "rkmk4", "rkmk6"} <= set(LANES_METHODS)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("method", LANES_METHODS)
def test_lanes_match_the_generic_path(rng, kind, method):
    """Every lanes method against the numpy path (a non-diagonal mass tensor; 13 bodies: a block
    of 16 lanes with three spare), projected and not, with and without R and the centre; one
    body spins fast enough (θ = |ω| h ≥ 0.1) for the trigonometric coefficients. The rolling
    balls' and the 4D top's fast body spins at h |Ω|_F/√2 = 0.25 exactly: at 30 times its speed
    (h ξ up to 3.4 on the 4D top) round-off is amplified so much that the per-body compiled path
    and the numpy path already differ by 7e-13 in the offset ball's Ω and 1.1e-12 in the 4D
    top's R."""
    for full, project in ((True, False), (False, True)):
        system = _body(kind, rng, full)
        y0 = _ensemble(system, rng, 13)
        if kind in ("heavy top", "Chaplygin ball"):
            y0[spin_field(y0)][5] *= 30.0
        else:
            body = {k: v[5] for k, v in y0.items()}
            Om = body["Omega"] if "Omega" in body else system.generator(0.0, body)
            y0[spin_field(y0)][5] *= 0.25 / (0.02 * np.sqrt(0.5 * np.sum(Om**2)))
        kw = dict(t_span=(0.0, 0.6), h=0.02, method=method, project=project, save_every=10)
        fast = lieint.integrate(system, y0, backend="numba", **kw)
        ref = lieint.integrate(system, y0, backend="numpy", **kw)
        assert f"{LABELS[kind]} in SIMD lanes" in fast.stats.backend_reason
        assert fast.states[spin_field(y0)].shape == (4, 13, system.n, system.n)
        assert_states_close(fast.states, ref.states, 1e-13, (full, project))


@pytest.mark.parametrize("kind", KINDS)
def test_an_ensemble_cut_in_chunks_gives_one_calls_bits(rng, kind):
    """The same body gives the same bits in a call of 140 bodies (two blocks of 128 lanes) and
    in chunks of 64 and 12 (blocks of 64 and 16 lanes, the body at other positions), also beside
    a body whose steps reach θ = |ω| h ≥ 0.1 (its block takes the trigonometric fix-up)."""
    system = _body(kind, rng)
    n = 140
    y0 = _ensemble(system, rng, n)
    y0[spin_field(y0)][40] *= 40.0
    kw = dict(t_span=(0.0, 0.3), h=0.01, method="rkmk4", save_every=10)
    whole = lieint.integrate(system, y0, **kw)
    assert "SIMD lanes" in whole.stats.backend_reason
    for lo, hi in ((5, 69), (128, 140)):
        part = lieint.integrate(system, {k: v[lo:hi] for k, v in y0.items()}, **kw)
        for name in system.fields:
            assert np.array_equal(part.states[name], whole.states[name][:, lo:hi]), (lo, name)


@pytest.mark.parametrize("kind", KINDS)
def test_one_body_of_the_ensemble_is_the_body_run_alone(rng, kind):
    """A body alone runs on the per-body path (the system's compiled form): the same numbers
    to round-off as the body in an ensemble's lanes."""
    system = _body(kind, rng)
    y0 = _ensemble(system, rng, 9)
    kw = dict(t_span=(0.0, 1.0), h=0.01, method="rkmk6", save_every=20)
    ensemble = lieint.integrate(system, y0, **kw)
    alone = lieint.integrate(system, {k: v[6] for k, v in y0.items()}, **kw)
    assert "SIMD lanes" in ensemble.stats.backend_reason
    assert "compiled engine" in alone.stats.backend_reason and "SIMD lanes" not in alone.stats.backend_reason
    assert_states_close({k: v[:, 6] for k, v in ensemble.states.items()}, alone.states, 3e-14)


@pytest.mark.parametrize("kind", KINDS)
def test_the_lanes_keep_what_the_action_keeps(rng, kind):
    """The right action turns Γ and the momentum (the heavy top's Π + t × Γ; the incline's G) by
    one rotation, so over 2,000 unprojected steps the Casimirs, |Γ| (the Chaplygin ball's ΓᵀA²Γ,
    the incline's |G|, the 4D top's spatial momentum R A Rᵀ) drift by round-off only and R stays a
    rotation; the energy, which RKMK4 does not keep, moves."""
    system = _body(kind, rng)
    y0 = _ensemble(system, rng, 24)
    sol = lieint.integrate(system, y0, (0.0, 20.0), h=0.01, method="rkmk4", project=False, save_every=500)
    assert "SIMD lanes" in sol.stats.backend_reason
    for name in KEPT[kind]:
        assert np.max(sol.drift(name)) < 1e-12, name
    if "G" in sol.states:
        assert np.max(np.abs(np.linalg.norm(sol.states["G"], axis=-1) - 9.81)) < 1e-12
    assert np.max(sol.invariants["orthogonality"]) < 1e-13
    if kind == "ball on an incline":  # it rolls down to |ω| h ≈ 0.6: RKMK4's energy error is O(1)
        assert 0 < np.max(sol.drift("energy"))
    else:
        assert 0 < np.max(sol.drift("energy")) < 1e-5


@pytest.mark.parametrize("kind", KINDS)
def test_dense_output_and_t_eval_of_the_lanes_are_the_generic_ones(rng, kind):
    """The lanes keep every step's state and increment in the system's algebra: the interpolant
    between the steps and the rows at ``t_eval`` are the numpy path's (events need one body)."""
    for full in (True, False):
        system = _body(kind, rng, full, diagonal=True)
        y0 = _ensemble(system, rng, 3)
        kw = dict(t_span=(0.0, 1.0), h=0.02, method="rkmk4", dense_output=True, t_eval=np.linspace(0.0, 1.0, 7))
        fast = lieint.integrate(system, y0, backend="numba", **kw)
        ref = lieint.integrate(system, y0, backend="numpy", **kw)
        assert "SIMD lanes" in fast.stats.backend_reason
        assert_states_close(fast.states, ref.states, 3e-14, full)
        midway = np.linspace(0.011, 0.987, 9)
        assert_states_close(fast.sol(midway), ref.sol(midway), 3e-14, full)


@pytest.mark.parametrize("kind", KINDS)
def test_a_step_beyond_the_dexpinv_radius_is_refused_as_on_the_generic_path(rng, kind):
    system = _body(kind, rng)
    y0 = _ensemble(system, rng, 4)
    y0[spin_field(y0)][2] *= 400.0  # |ω| h ≥ 2π at a stage
    for backend in ("numba", "numpy"):
        with pytest.raises(lieint.DexpinvRangeError, match="so\\(4\\)" if kind == "4D top" else "se\\(3\\)"):
            lieint.integrate(system, y0, (0.0, 1.0), h=0.1, method="rkmk4", backend=backend)
