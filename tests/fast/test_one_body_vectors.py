"""One 3D heavy top, Chaplygin ball or rolling ball in vectors (lieint.fast.tangent_layouts.HeavyTop3Layout,
Chaplygin3Layout, RollingBall3Layout): a single body's fixed-step RKMK in exponential coordinates runs on the plain
step of its tangent module (no tangent vectors), not on the compiled pieces' matrices. Checked
against the generic numpy path for every such method of the registry, with dense output, events
and ``t_eval``, and for what the right action keeps; a projecting run, Cayley coordinates and an
ensemble keep their own paths, and say so."""

from __future__ import annotations

import numpy as np
import pytest
from bodies import assert_states_close, body3, spin_field
from conftest import compiled_methods, random_rotation

import lieint

#: the methods the one-body vector steps serve: fixed-step RKMK in exponential coordinates
VECTOR_METHODS = [m for m in compiled_methods() if lieint.get_method(m).compiled().family == "rkmk"]
KINDS = ("heavy top", "Chaplygin ball", "rolling ball", "ball on an incline")
LABELS = {"heavy top": "3D heavy top in vectors", "Chaplygin ball": "3D Chaplygin ball in vectors",
          "rolling ball": "3D rolling ball in vectors", "ball on an incline": "3D rolling ball in vectors"}  # fmt: skip
KEPT = {"heavy top": ["casimirs", "gamma_norm"], "Chaplygin ball": ["casimirs", "gamma_norm", "gamma_A2_gamma"],
        "rolling ball": ["gamma_norm"], "ball on an incline": ["gamma_norm"]}  # fmt: skip


def _state(system, rng, spin=1.0):
    kw = {"R": random_rotation(rng, 3)} if "R" in system.fields else {}
    y0 = system.initial_state(angular_velocity=spin * rng.normal(size=3), **kw)
    if "center" in y0:
        y0["center"][:2] = rng.normal(size=2)
    return y0


def test_the_vector_steps_serve_every_fixed_step_rkmk_method():
    # the list the tests below run is the registry's, and not empty
    assert {"lie_euler", "rkmk4", "rkmk6"} <= set(VECTOR_METHODS)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("method", VECTOR_METHODS)
def test_one_body_in_vectors_matches_the_generic_path(rng, kind, method):
    """Every method, a principal frame that is not the user's (and one that is), with and
    without R and the centre, slow and fast (θ = |ω| h ≥ 0.1: the trigonometric coefficients)."""
    for full, diagonal, spin in ((True, False, 1.0), (False, False, 30.0), (True, True, 30.0), (False, True, 1.0)):
        system = body3(kind, rng, full, diagonal)
        y0 = _state(system, rng, spin)
        kw = dict(t_span=(0.0, 0.6), h=0.02, method=method, save_every=10)
        fast = lieint.integrate(system, y0, backend="numba", **kw)
        ref = lieint.integrate(system, y0, backend="numpy", **kw)
        assert LABELS[kind] in fast.stats.backend_reason
        assert fast.states[spin_field(y0)].shape == (4, 3, 3)
        assert_states_close(fast.states, ref.states, 1e-13, (full, diagonal, spin))


@pytest.mark.parametrize("kind", KINDS)
def test_dense_output_events_and_t_eval_in_vectors_are_the_generic_ones(rng, kind):
    """The steps' increments in the user's algebra (se(3); so(3) for a ball without its centre):
    the interpolant between steps, the rows at ``t_eval`` and the located events are the numpy
    path's."""
    for full in (True, False):
        system = body3(kind, rng, full)
        y0 = _state(system, rng)
        spin = spin_field(y0)
        seen = lieint.integrate(system, y0, (0.0, 2.0), h=0.02, method="rkmk4", backend="numpy").states[spin][:, 0, 1]
        level = 0.5 * float(seen.min() + seen.max())  # crossed on the way

        def crossing(t, y, level=level, spin=spin):
            return y[spin][0, 1] - level

        kw = dict(t_span=(0.0, 2.0), h=0.02, method="rkmk4", dense_output=True, t_eval=np.linspace(0.1, 1.9, 7),
                  events=crossing)  # fmt: skip
        fast = lieint.integrate(system, y0, backend="numba", **kw)
        ref = lieint.integrate(system, y0, backend="numpy", **kw)
        assert LABELS[kind] in fast.stats.backend_reason
        assert_states_close(fast.states, ref.states, 3e-14, full)
        midway = np.linspace(0.011, 1.987, 9)
        assert_states_close(fast.sol(midway), ref.sol(midway), 3e-14, full)
        assert len(ref.t_events[0]) >= 1
        np.testing.assert_allclose(fast.t_events[0], ref.t_events[0], rtol=0, atol=1e-12)


@pytest.mark.parametrize("kind", KINDS)
def test_the_vector_steps_keep_what_the_action_keeps(rng, kind):
    """2,000 unprojected RKMK4 steps: the Casimirs and |Γ| (the Chaplygin ball's ΓᵀA²Γ, the
    incline's |G|) drift by round-off only and R stays a rotation; the energy, which RKMK4 does not
    keep, moves (on the incline the ball rolls down and spins up: its error is not small)."""
    system = body3(kind, rng)
    sol = lieint.integrate(system, _state(system, rng), (0.0, 20.0), h=0.01, method="rkmk4", save_every=500)
    assert LABELS[kind] in sol.stats.backend_reason
    for name in KEPT[kind]:
        assert np.max(sol.drift(name)) < 1e-12, name
    if "G" in sol.states:
        assert np.max(np.abs(np.linalg.norm(sol.states["G"], axis=-1) - 9.81)) < 1e-12
    assert np.max(sol.invariants["orthogonality"]) < 1e-13
    assert 0 < np.max(sol.drift("energy"))
    if kind != "ball on an incline":
        assert np.max(sol.drift("energy")) < 1e-5


@pytest.mark.parametrize("kind", KINDS)
def test_projection_cayley_and_ensembles_keep_their_own_compiled_paths(rng, kind):
    """A projecting run goes through the compiled pieces (which project R and Γ), Cayley
    coordinates too, an ensemble through the SIMD lanes; each says so and matches the numpy path."""
    system = body3(kind, rng)
    y0 = _state(system, rng)
    two = {k: np.stack([v, v]) for k, v in y0.items()}
    for state, options, words in (
        (y0, dict(project=True), "compiled pieces"),
        (y0, dict(coordinates="cayley"), "compiled pieces"),
        (two, {}, "SIMD lanes"),
    ):
        kw = dict(t_span=(0.0, 0.5), h=0.01, method="rkmk4", save_every=10, **options)
        fast = lieint.integrate(system, state, backend="numba", **kw)
        ref = lieint.integrate(system, state, backend="numpy", **kw)
        assert words in fast.stats.backend_reason and "in vectors" not in fast.stats.backend_reason, options
        assert_states_close(fast.states, ref.states, 1e-13, options)


@pytest.mark.parametrize("kind", KINDS)
def test_a_step_beyond_the_dexpinv_radius_is_refused_in_vectors_as_on_the_generic_path(rng, kind):
    system = body3(kind, rng)
    y0 = _state(system, rng, 400.0)  # |ω| h ≥ 2π at a stage
    for backend in ("numba", "numpy"):
        match = "se\\(3\\)" if kind in ("heavy top", "rolling ball", "ball on an incline") else "\\(3\\)"
        with pytest.raises(lieint.DexpinvRangeError, match=match):
            lieint.integrate(system, y0, (0.0, 1.0), h=0.1, method="rkmk4", backend=backend)
