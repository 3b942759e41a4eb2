"""The default adaptive method on the compiled engine (the 3D top), beside its generic path; the
Dzhanibekov flips it locates; what a study says of a series far above its rtol."""

from __future__ import annotations

import numpy as np
import pytest

import lieint
from lieint.groups import vee

TOP = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
METHOD = "rkmk853+energy"


def run(y0, T, rtol, system=TOP, **kw):
    return lieint.integrate(system, y0, (0.0, T), method=METHOD, rtol=rtol, atol=1e-3 * rtol, **kw)


def test_compiled_on_the_3d_top_and_the_generic_paths_steps():
    y0 = TOP.initial_state(angular_velocity=[0.3, 0.5, 1.0])
    fast, slow = run(y0, 20.0, 1e-8), run(y0, 20.0, 1e-8, backend="numpy")
    assert fast.stats.backend == "numba" and "energy kept" in fast.stats.backend_reason
    assert slow.stats.backend == "numpy"
    # the same steps up to the controller's round-off floor (tests/test_fast_adaptive.py: an error
    # norm near round-off, as on the first steps, moves the next step by its relative round-off;
    # every compiled step replays as the generic one to 1e-13 there)
    assert fast.stats.nsteps == slow.stats.nsteps and fast.stats.nrejected == slow.stats.nrejected
    np.testing.assert_allclose(fast.t, slow.t, rtol=1e-3, atol=0)
    for field in ("A", "R"):
        assert np.max(np.abs(fast.states[field][-1] - slow.states[field][-1])) < 10 * 1e-8, field
    exact = TOP.exact_solution(fast.t, y0)["A"]
    assert np.max(np.abs(fast.states["A"] - exact)) < 1e-8 * np.abs(y0["A"]).max()
    assert fast.drift("energy") < 1e-13 and fast.drift("casimirs") < 1e-13 and fast.drift("orthogonality") < 1e-12


def test_an_ensemble_keeps_each_bodys_own_energy():
    w = np.array([[0.3, 0.5, 1.0], [0.01, 1.0, 0.01], [2.0, -0.1, 0.3]])
    y0 = TOP.initial_state(angular_velocity=w)
    sol = run(y0, 10.0, 1e-8)
    assert sol.stats.backend == "numba"
    E = TOP.energy(sol.states["A"])
    np.testing.assert_allclose(E, np.broadcast_to(TOP.energy(y0["A"]), E.shape), rtol=1e-13, atol=0)
    for k in range(3):  # each body as the same run alone (a shared step size: tighter than asked)
        alone = run({f: v[k] for f, v in y0.items()}, 10.0, 1e-8)
        assert np.max(np.abs(sol.states["A"][-1, k] - alone.states["A"][-1])) < 1e-7


def test_a_run_split_into_calls_keeps_the_level_of_its_start(monkeypatch):
    """The level travels with the compiled state: a run whose controller loop is called for 16
    rows at a time takes the bits of one called once."""
    import lieint.fast.engine as engine

    y0 = TOP.initial_state(angular_velocity=[0.01, 1.0, 0.01])
    whole = run(y0, 30.0, 1e-9)
    monkeypatch.setattr(engine, "ROWS_PER_CALL", 16)
    split = run(y0, 30.0, 1e-9)
    assert whole.stats.nsteps == split.stats.nsteps > 5 * 16
    for field in ("A", "R"):
        np.testing.assert_array_equal(whole.states[field], split.states[field])
    assert split.drift("energy") < 1e-13


@pytest.mark.parametrize(
    ("what", "kw", "system"),
    [
        ("cayley", {"coordinates": "cayley"}, TOP),
        ("heavy top", {}, lieint.HeavyTop(np.diag([1.0, 2.0, 3.0]), 1.0, [0.0, 0.1, 0.3], [0.0, 0.0, -9.81])),
        ("events", {"events": lambda t, y: vee(TOP.angular_velocity(y["A"]))[..., 1]}, TOP),
        ("dense output", {"dense_output": True}, TOP),
    ],
)
def test_elsewhere_the_generic_path_says_why(what, kw, system):
    y0 = system.initial_state(angular_velocity=[0.3, 0.5, 1.0])
    sol = run(y0, 1.0, 1e-7, system=system, **kw)
    assert sol.stats.backend == "numpy", what
    reason = sol.stats.backend_reason
    assert "+energy" in reason and ("3D Euler top" in reason or "step again" in reason), reason


def test_dzhanibekov_flips_within_10x_of_dop853():
    """The flips (sign changes of the middle-axis rate) at rtol 1e-10, atol 1e-12 against the
    exact flip times (elliptic functions, no integrator)."""
    I, w0, T = [1.0, 2.0, 3.0], [0.01, 1.0, 0.01], 60.0
    y0 = TOP.initial_state(angular_velocity=w0)
    exact = lieint.euler_top_flip_times(I, w0, T)

    def flip(t, y):
        return vee(TOP.angular_velocity(y["A"]))[..., 1]

    errors = {}
    for method in (METHOD, "scipy:DOP853"):
        sol = lieint.integrate(TOP, y0, (0.0, T), method=method, rtol=1e-10, atol=1e-12, events=flip)
        assert sol.t_events[0].size == exact.size == 3, method
        errors[method] = np.max(np.abs(sol.t_events[0] - exact))
    assert errors[METHOD] <= 10 * errors["scipy:DOP853"], errors
    assert errors[METHOD] < 1e-10, errors


def test_a_study_note_names_the_remedy():
    from lieint.study.notes import rtol_notes

    class Row:  # the fields rtol_notes reads
        def __init__(self, series, family, error, rtol):
            self.series, self.family, self.error, self.rtol = series, family, error, rtol
            self.success, self.resolved = True, True

    class Study:
        def __init__(self, rows):
            self.rows = rows

    rows = [Row("rkmk853 [numba]", "rkmk-embedded", 1e-5, 1e-9), Row(f"{METHOD} [numba]", "rkmk-energy", 1e-10, 1e-9)]
    (note,) = rtol_notes(Study(rows))
    assert note.series == ("rkmk853 [numba]",) and "take rkmk853+energy" in note.text
