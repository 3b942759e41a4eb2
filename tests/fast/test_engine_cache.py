"""The engines of recent runs reused (:func:`lieint.fast.engine.engine_for`'s cache).

Truths: the same runs with the cache emptied before each, bit for bit, and the identities of
what a reused engine shares and what it holds of its own."""

from __future__ import annotations

import math

import numpy as np
import pytest

import lieint
from lieint.fast import engine
from lieint.methods.registry import get_method


def _top4(b=(0.6, 0.9, 1.2, 1.5)):
    top = lieint.EulerTop(np.diag(list(b)))
    M = np.random.default_rng(1).normal(size=(4, 4))
    return top, top.initial_state(Omega=0.3 * (M - M.T))


def test_a_second_run_of_the_same_system_and_method_reuses_the_engine_with_its_own_state():
    top, y0 = _top4()
    method = get_method("rkmk853+energy")
    engine._ENGINES.clear()
    first, _ = engine.engine_for(top, method, y0, adaptive=True)
    second, _ = engine.engine_for(top, method, y0, adaptive=True)
    assert first is not second
    assert first.loops is second.loops and first.layout is second.layout and first.tableau is second.tableau
    first.start(y0)
    assert first._radius2 == 0.0 and second._radius2 == math.inf  # the step check's bound is per run


@pytest.mark.parametrize(
    "method, options",
    [("rkmk853+energy", {"rtol": 1e-8, "atol": 1e-10}), ("rkmk4", {"h": 0.05}), ("moser_veselov", {"h": 0.05})],
)
def test_runs_through_a_reused_engine_are_the_runs_with_a_new_one_bit_for_bit(method, options):
    top, y0 = _top4()
    engine._ENGINES.clear()
    cold = lieint.integrate(top, y0, (0.0, 2.0), method=method, **options)
    warm = lieint.integrate(top, y0, (0.0, 2.0), method=method, **options)
    assert cold.stats.backend == warm.stats.backend == "numba"
    assert len(engine._ENGINES) >= 1
    np.testing.assert_array_equal(cold.t, warm.t)
    for name in cold.states:
        np.testing.assert_array_equal(cold.states[name], warm.states[name])
    assert cold.nfev == warm.nfev and cold.stats.nrejected == warm.stats.nrejected


def test_another_body_batch_or_option_gets_its_own_engine():
    top, y0 = _top4()
    other, _ = _top4((0.7, 0.9, 1.2, 1.5))
    method = get_method("rkmk4")
    engine._ENGINES.clear()
    base, _ = engine.engine_for(top, method, y0)
    assert engine.engine_for(other, method, y0)[0].layout is not base.layout  # another body
    batch = {k: np.stack([v, v]) for k, v in y0.items()}
    assert engine.engine_for(top, method, batch)[0].batch == (2,)  # another batch shape
    assert engine.engine_for(top, method, y0, project=False)[0].layout is not base.layout
    assert engine.engine_for(top, get_method("rkmk6"), y0)[0].tableau is not base.tableau
    assert len(engine._ENGINES) == 5


def test_the_cache_holds_at_most_its_size():
    method = get_method("rkmk4")
    engine._ENGINES.clear()
    for k in range(engine.ENGINE_CACHE_SIZE + 5):
        top, y0 = _top4((0.6 + 0.01 * k, 0.9, 1.2, 1.5))
        engine.engine_for(top, method, y0)
    assert len(engine._ENGINES) == engine.ENGINE_CACHE_SIZE


def test_a_map_whose_stage_module_declines_some_steps_is_chosen_afresh_each_run():
    # the exact flow's engine depends on the run's phases |λh| (long steps: the numpy path)
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    method = get_method("exact_flow")
    engine._ENGINES.clear()
    short, _ = engine.engine_for(top, method, y0, h=0.1)
    assert short is not None and not engine._ENGINES
    long, reason = engine.engine_for(top, method, y0, h=100.0)
    assert long is None and "closed form" in reason


def _fixed_step_methods():
    from lieint.methods.registry import method_specs

    return [name for name in method_specs() if not (m := get_method(name)).adaptive and not m.self_controlled]


@pytest.mark.parametrize("label", ["3D top", "4D top"])
def test_every_compiled_fixed_step_method_runs_the_same_through_a_reused_engine(label):
    # the Euler tops are the systems whose declaration is cached, so their engines are reused
    if label == "3D top":
        top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
        y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    else:
        top, y0 = _top4()
    compared = 0
    for name in _fixed_step_methods():
        try:
            get_method(name).check_system(top)
        except ValueError:
            continue
        engine._ENGINES.clear()
        cold = lieint.integrate(top, y0, (0.0, 0.3), h=0.01, method=name)
        if cold.stats.backend != "numba":
            continue
        warm = lieint.integrate(top, y0, (0.0, 0.3), h=0.01, method=name)
        compared += 1
        for field in cold.states:
            np.testing.assert_array_equal(cold.states[field], warm.states[field], err_msg=name)
        assert cold.nfev == warm.nfev, name
    assert compared >= 12, compared


def test_runs_in_threads_share_the_cache_and_each_gets_its_own_engine():
    # a threaded sweep: many runs of the same and of different tops at once, the cache smaller
    # than the bodies, every run the run alone
    from concurrent.futures import ThreadPoolExecutor

    tops = [_top4((0.6 + 0.01 * k, 0.9, 1.2, 1.5)) for k in range(8)]
    engine._ENGINES.clear()
    alone = [lieint.integrate(top, y0, (0.0, 0.5), h=0.05, method="rkmk4").states["A"] for top, y0 in tops]
    size = engine.ENGINE_CACHE_SIZE
    engine.ENGINE_CACHE_SIZE = 3
    engine._ENGINES.clear()  # every top inserted again, under the smaller bound
    try:
        with ThreadPoolExecutor(4) as pool:
            runs = list(pool.map(lambda k: (k, lieint.integrate(*tops[k % 8], (0.0, 0.5), h=0.05, method="rkmk4")),
                                 range(64)))  # fmt: skip
    finally:
        engine.ENGINE_CACHE_SIZE = size
    for k, sol in runs:
        np.testing.assert_array_equal(sol.states["A"], alone[k % 8])
    assert len(engine._ENGINES) <= 3


def _pieces_bodies():
    import bodies  # tests/bodies.py: one variant of every compiled layout of the pieces systems

    return bodies.variants(3)


@pytest.mark.parametrize("label", sorted(_pieces_bodies()))
def test_the_pieces_systems_declare_one_form_per_set_of_numbers_and_reuse_their_engines(label):
    # the heavy top, the free body and the balls: their declaration is made once per parameter
    # vector, so a second run gets the first run's engine, and runs the same bit for bit
    import bodies

    system = _pieces_bodies()[label]
    y0 = bodies.initial(system, np.random.default_rng(3))
    assert system.compiled() is system.compiled()
    engine._ENGINES.clear()
    for method, options in (("rkmk853+energy", {"rtol": 1e-8, "atol": 1e-10}), ("rkmk4", {"h": 0.01})):
        cold = lieint.integrate(system, y0, (0.0, 0.2), method=method, **options)
        first, _ = engine.engine_for(system, get_method(method), y0, adaptive=method != "rkmk4")
        second, _ = engine.engine_for(system, get_method(method), y0, adaptive=method != "rkmk4")
        assert first.layout is second.layout, method
        warm = lieint.integrate(system, y0, (0.0, 0.2), method=method, **options)
        assert cold.stats.backend == warm.stats.backend == "numba", method
        for name in cold.states:
            np.testing.assert_array_equal(cold.states[name], warm.states[name], err_msg=method)


def test_a_pieces_system_with_edited_numbers_declares_a_new_form_with_them():
    # the declaration is keyed on the numbers, not on the arrays: an array edited in place (here
    # the heavy top's gravity, whose size |g| the pieces read) is seen at the next run
    system = lieint.HeavyTop(np.diag([1.0, 2.0, 3.0]), 1.0, [0.1, 0.0, 0.2], [0.0, 0.0, -9.81])
    before = system.compiled()
    system.gravity[2] = -19.62
    after = system.compiled()
    assert after is not before
    assert not np.array_equal(after.params, before.params) and after.params[-1] == 19.62
    assert system.compiled() is after


def _numbers(system) -> list[str]:
    """The system's float arrays and numbers, by attribute name (what a user might edit)."""
    return sorted(
        name
        for name, value in vars(system).items()
        if (isinstance(value, np.ndarray) and value.dtype == float and value.size)
        or (isinstance(value, float) and not isinstance(value, bool))
    )


@pytest.mark.parametrize("label", sorted(_pieces_bodies()))
def test_a_pieces_declaration_reused_holds_the_numbers_of_every_array_and_number_of_the_system(label):
    # the declaration is reused while a key of the system's numbers is unchanged: whatever array
    # is edited in place, or number set, the declaration the next call returns must be the one
    # made afresh from the system as it now is (the key must hold every number the form is made of)
    system = _pieces_bodies()[label]
    names = _numbers(system)
    assert {"gravity", "B_C", "mass", "radius"} & set(names), names
    for name in names:
        system.compiled()
        value = getattr(system, name)
        if isinstance(value, np.ndarray):
            value.ravel()[0] += 0.125  # in place: the same array object
        else:
            setattr(system, name, value * 1.25)
        reused = system.compiled()
        vars(system).pop("_declared_form")
        fresh = system.compiled()
        np.testing.assert_array_equal(reused.params, fresh.params, err_msg=name)
        assert (reused.lanes is None) == (fresh.lanes is None), name
        if fresh.lanes is not None:
            for field, number in vars(fresh.lanes).items():
                np.testing.assert_array_equal(getattr(reused.lanes, field), number, err_msg=f"{name}: {field}")
