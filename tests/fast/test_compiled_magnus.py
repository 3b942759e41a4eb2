"""The Magnus methods on prescribed rotations, compiled (:mod:`lieint.fast.magnus`): the numpy
path's numbers on every front end — a plain run, events, dense output, ``t_eval``, a batch,
backward in time, projected, in segments — for rates given as a function and as samples, in 3
and 4 dimensions; what stays on the generic path says so."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import lieint
from lieint.driver import Driver
from lieint.methods.magnus import Magnus


def _rates3(t):
    return np.array([np.sin(t), 0.5, np.cos(2.0 * t)])


def _rates4(t):
    X = np.array([[0.0, np.sin(t), 0.3, 0.1], [0.0, 0.0, np.cos(t), 0.2 * t], [0.0, 0.0, 0.0, 0.4], [0.0] * 4])
    return X - X.T


def _systems():
    times = np.linspace(-1.0, 12.0, 300)
    return {
        "function n=3": lieint.PrescribedRotation(_rates3),
        "samples n=3": lieint.PrescribedRotation(np.array([_rates3(t) for t in times]), times),
        "function n=4": lieint.PrescribedRotation(_rates4, n=4),
        "samples n=4": lieint.PrescribedRotation(np.array([_rates4(t) for t in times]), times, n=4),
    }


def _start(system, batch=()):
    rng = np.random.default_rng(4)
    n = system.n
    Q, _ = np.linalg.qr(rng.normal(size=(*batch, n, n)))
    Q[..., :, 0] *= np.sign(np.linalg.det(Q))[..., None]  # det +1
    return system.initial_state(R=Q)


def system_nodes(method: str):
    return lieint.get_method(method).nodes


def _front_ends(system):
    # an event where R₂₂ crosses the middle of its range over the run (found on the numpy path)
    y0 = _start(system)
    r22 = lieint.integrate(system, y0, (0.0, 3.0), h=0.02, method="magnus4", backend="numpy").states["R"][:, 2, 2]
    level = 0.5 * (r22.min() + r22.max())

    def event(t, y):
        return np.asarray(y["R"])[..., 2, 2] - level

    yield "plain", {}, y0
    yield "events", {"events": event}, y0
    yield "dense output", {"dense_output": True}, _start(system)
    yield "t_eval", {"t_eval": np.linspace(0.0, 3.0, 7)}, _start(system)
    yield "batch", {}, _start(system, (2,))
    yield "projected", {"project": True}, _start(system)


@pytest.mark.parametrize("label", sorted(_systems()))
@pytest.mark.parametrize("method", ["magnus4", "magnus6"])
def test_every_front_end_runs_compiled_with_the_numpy_path_s_numbers(label, method):
    system = _systems()[label]
    for front, options, y0 in _front_ends(system):
        compiled = lieint.integrate(system, y0, (0.0, 3.0), h=0.02, method=method, **options)
        generic = lieint.integrate(system, y0, (0.0, 3.0), h=0.02, method=method, backend="numpy", **options)
        assert compiled.stats.backend == "numba" and "Magnus" in compiled.stats.backend_reason, front
        assert compiled.stats.nsteps == generic.stats.nsteps, front
        if not ({"events", "dense_output", "t_eval"} & set(options)):  # the steps' own evaluations
            assert compiled.stats.nfev == generic.stats.nfev == len(system_nodes(method)) * compiled.stats.nsteps
        np.testing.assert_allclose(compiled.t, generic.t, rtol=0, atol=1e-13, err_msg=front)
        np.testing.assert_allclose(compiled.states["R"], generic.states["R"], rtol=0, atol=1e-13, err_msg=front)
        if front == "events":
            assert len(compiled.t_events[0]) == len(generic.t_events[0]) > 0
            np.testing.assert_allclose(compiled.t_events[0], generic.t_events[0], rtol=0, atol=1e-11)
        if front == "dense output":
            t = np.linspace(0.0, 3.0, 41)
            np.testing.assert_allclose(compiled.sol(t)["R"], generic.sol(t)["R"], rtol=0, atol=1e-13)


@pytest.mark.parametrize("method", ["magnus4", "magnus6"])
def test_backward_and_in_segments_as_in_one_call(method):
    system = _systems()["samples n=3"]
    y0 = _start(system)
    back = lieint.integrate(system, y0, (3.0, 0.5), h=0.02, method=method)
    generic = lieint.integrate(system, y0, (3.0, 0.5), h=0.02, method=method, backend="numpy")
    assert back.stats.backend == "numba"
    np.testing.assert_allclose(back.states["R"], generic.states["R"], rtol=0, atol=1e-13)
    # a run advanced in segments (as a streamed run goes) reads each segment's nodes: the same bits
    whole = lieint.integrate(system, y0, (0.0, 3.0), h=0.02, method=method)
    driver = Driver(system, lieint.get_method(method), (0.0, 3.0), h=0.02)
    carry = driver.start(y0)
    rows = [driver.advance(carry, 17) for _ in range(20) if not driver.done(carry)]
    assert driver.backend == "numba" and driver.done(carry)
    np.testing.assert_array_equal(rows[-1].states["R"][-1], whole.states["R"][-1])


def test_a_rotation_about_a_fixed_axis_is_exact_compiled():
    # rates along one axis commute, and Gauss's nodes integrate ω(t) = 1 + t/2 exactly: the Magnus
    # step is the exact flow, R = exp(θ(t) ẑ) with θ = t + t²/4 (3 at t = 2)
    system = lieint.PrescribedRotation(lambda t: np.array([0.0, 0.0, 1.0 + 0.5 * t]))
    y0 = system.initial_state()
    exact = np.array([[np.cos(3.0), -np.sin(3.0), 0.0], [np.sin(3.0), np.cos(3.0), 0.0], [0.0, 0.0, 1.0]])
    for method in ("magnus4", "magnus6"):
        run = lieint.integrate(system, y0, (0.0, 2.0), h=0.1, method=method)
        assert run.stats.backend == "numba" and np.max(np.abs(run.states["R"][-1] - exact)) < 1e-13, method


def test_rates_outside_the_samples_are_refused_as_on_the_numpy_path():
    system = lieint.PrescribedRotation(np.zeros((5, 3)), np.arange(5.0))
    # (the compiled run samples every node first and names the first outside; the numpy path the
    # time at which it asked)
    for backend in ("auto", "numpy"):
        with pytest.raises(ValueError, match=r"the body rates are sampled on \[0.0, 4.0\]; asked for t = 4\."):
            lieint.integrate(system, system.initial_state(), (0.0, 6.0), h=0.5, method="magnus4", backend=backend)


def test_what_is_not_the_magnus_methods_own_dynamics_runs_on_the_generic_path_and_says_so():
    system = _systems()["function n=3"]
    y0 = _start(system)
    rkmk = lieint.integrate(system, y0, (0.0, 0.5), h=0.05, method="rkmk4")
    assert (
        rkmk.stats.backend == "numpy" and "has no compiled form for a prescribed rotation" in rkmk.stats.backend_reason
    )

    @dataclasses.dataclass(frozen=True)
    class Halved(Magnus):
        def step(self, system, t, y, h, state=None):
            return super().step(system, t, y, 0.5 * h, state)

    assert lieint.integrate(system, y0, (0.0, 0.5), h=0.05, method=Halved("magnus4")).stats.backend == "numpy"

    class Faster(lieint.PrescribedRotation):
        def generator(self, t, y):
            return 2.0 * super().generator(t, y)

    other = Faster(_rates3)
    assert lieint.integrate(other, y0, (0.0, 0.5), h=0.05, method="magnus4").stats.backend == "numpy"
