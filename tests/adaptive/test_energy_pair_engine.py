"""The energy-keeping pairs on the compiled engine (the 3D top, the n-D top, the systems with
compiled pieces), beside their generic path; the Dzhanibekov flips the default locates; what a
study says of a series far above its rtol."""

from __future__ import annotations

import numpy as np
import pytest
from bodies import coverage_systems, initial, registered_methods, variants

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


#: the systems the energy pairs run compiled on: each compiled form (the 3D top, whose Cayley
#: coordinates run on the n-D top's energy form, the n-D top, the pieces of the heavy top, the free
#: body and the balls), from the coverage tests' list, and the offset rolling ball
ENERGY_SYSTEMS = {**coverage_systems(), "rolling_ball/offset n=3": variants(3)["rolling_ball/offset"]}


def _energy_methods():
    """(name, coordinates) of every registered energy-keeping pair in each of its coordinates."""
    return [(name, c) for name, c in registered_methods() if name.endswith("+energy")]


@pytest.mark.parametrize(
    "label", [pytest.param(x, marks=pytest.mark.slow) if x == "heavy_top n=4" else x for x in sorted(ENERGY_SYSTEMS)]
)
def test_compiled_beyond_the_3d_top_takes_the_generic_paths_steps(label):
    """Every registered energy pair, in exponential and Cayley coordinates, on each compiled form:
    compiled, the generic path's accepted and rejected steps and states (up to the controller's
    round-off floor: tests/fast/test_embedded_pairs.py), every compiled step the generic step
    from the same state and step size to round-off, and every state on the initial energy."""
    system = ENERGY_SYSTEMS[label]
    y0 = initial(system, np.random.default_rng(2))
    H0 = float(system.invariants["energy"](0.0, y0))
    rtol = 1e-8
    for name, coordinates in _energy_methods():
        kw = dict(method=name, coordinates=coordinates, rtol=rtol, atol=1e-3 * rtol, project=False)
        fast = lieint.integrate(system, y0, (0.0, 0.5), **kw)
        slow = lieint.integrate(system, y0, (0.0, 0.5), backend="numpy", **kw)
        where = (label, name, coordinates, fast.stats.backend_reason)
        assert fast.stats.backend == "numba" and "energy kept" in fast.stats.backend_reason, where
        assert (fast.stats.nsteps, fast.stats.nrejected) == (slow.stats.nsteps, slow.stats.nrejected), where
        assert fast.stats.nsteps > 3 and fast.t[-1] == slow.t[-1] == 0.5, where
        # the controller's round-off floor: while the estimate is a few ulps of the state (the
        # first steps; the whole run of rkmk853 on the free body, whose fall it integrates
        # exactly) either path's round-off moves the next step size by up to percents of a
        # percent (the plain pairs' too; the 3D top's test above): the times to 1e-2, the states
        # at the common end to the methods' own error — and the replay below to round-off
        np.testing.assert_allclose(fast.t, slow.t, rtol=1e-2, atol=0, err_msg=str(where))
        for field in slow.states:
            scale = max(1.0, float(np.abs(slow.states[field]).max()))
            assert np.max(np.abs(fast.states[field][-1] - slow.states[field][-1])) < 10 * rtol * scale, (where, field)
        # replayed: each compiled step against the generic step of the same size from its start
        method = lieint.get_method(name, coordinates=coordinates)
        worst = 0.0
        for k in range(fast.t.size - 1):
            yk = {f: v[k] for f, v in fast.states.items()}
            step = method.step(system, fast.t[k], yk, fast.t[k + 1] - fast.t[k], {"energy0": np.asarray(H0)})
            for f in step.y:
                worst = max(worst, float(np.max(np.abs(fast.states[f][k + 1] - step.y[f]))))
        assert worst < 1e-13 * max(1.0, max(float(np.abs(v).max()) for v in slow.states.values())), (where, worst)
        # on the level to the round-off of H's terms (the free body's kinetic and potential
        # energies grow as it falls: the generic path holds it to a few 1e-13 too)
        drift = np.max(np.abs(system.invariants["energy"](0.0, fast.states) - H0))
        assert drift <= 1e-12 * max(1.0, abs(H0)), (where, drift)


def test_an_n_d_tops_split_run_keeps_the_level_of_its_start(monkeypatch):
    """On the 4D top the level travels with the compiled state too: a run whose controller loop
    is called for 8 rows at a time takes the bits of one called once."""
    import lieint.fast.engine as engine

    system = ENERGY_SYSTEMS["euler_top n=4"]
    y0 = initial(system, np.random.default_rng(5))
    whole = run(y0, 5.0, 1e-9, system=system)
    monkeypatch.setattr(engine, "ROWS_PER_CALL", 8)
    split = run(y0, 5.0, 1e-9, system=system)
    assert whole.stats.nsteps == split.stats.nsteps > 3 * 8
    for field in whole.states:
        np.testing.assert_array_equal(whole.states[field], split.states[field])


@pytest.mark.parametrize("system", [TOP, variants(3)["heavy_top"], lieint.EulerTop(np.diag([0.6, 0.9, 1.2, 1.5]))])
def test_dense_output_events_and_t_eval_step_again_on_the_engine(system):
    """Between its steps an energy pair's solution is its own step from the last step end
    (lieint.dense.Restep), on the engine too: the compiled run's interpolant at t is the generic
    path's step from the compiled run's row to t (to 1e-13), the t_eval rows are that curve, and
    an event found on it is where the event function vanishes; its time is the generic run's to
    the two runs' own difference (their steps differ at the controller's round-off floor)."""
    y0 = initial(system, np.random.default_rng(6))
    path = run(y0, 2.0, 1e-8, system=system, backend="numpy").states["A"][:, 0, 1]
    level = 0.5 * (path.min() + path.max())

    def crossing(t, y):
        return y["A"][..., 0, 1] - level

    kw = dict(dense_output=True, events=crossing, t_eval=np.linspace(0.0, 2.0, 9))
    fast = run(y0, 2.0, 1e-8, system=system, **kw)
    slow = run(y0, 2.0, 1e-8, system=system, backend="numpy", **kw)
    assert fast.stats.backend == "numba" and "energy kept" in fast.stats.backend_reason
    plain = run(y0, 2.0, 1e-8, system=system)
    method = lieint.get_method(METHOD)
    state = method.init(system, 0.0, y0, 0.1)
    for j in range(0, plain.t.size - 1, max(1, plain.t.size // 5)):
        t = plain.t[j] + 0.37 * (plain.t[j + 1] - plain.t[j])
        row = {k: v[j] for k, v in plain.states.items()}
        ref = method.step(system, plain.t[j], row, t - plain.t[j], state).y
        for field, values in ref.items():
            np.testing.assert_allclose(fast.sol(t)[field], values, rtol=0, atol=1e-13 * max(1, np.abs(values).max()))
    for field in fast.states:
        np.testing.assert_allclose(fast.states[field], slow.states[field], rtol=0, atol=1e-7)
        np.testing.assert_array_equal(fast.states[field][3], fast.sol(fast.t[3])[field])
    assert len(fast.t_events[0]) == len(slow.t_events[0]) > 0
    np.testing.assert_allclose(fast.t_events[0], slow.t_events[0], rtol=0, atol=1e-7)
    for t_event in fast.t_events[0]:
        assert abs(crossing(t_event, fast.sol(t_event))) < 1e-10


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
