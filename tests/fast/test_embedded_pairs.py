"""The compiled adaptive loop (lieint.fast.top3_adaptive) against the generic controller.

Whole runs take the same accepted and rejected steps; their times agree to the controller's
round-off floor (an error norm measured to relative round-off ε/(rtol·err) moves the next step
by that much over 1/(q+1): the generic path moves as far when y₀ changes by one ulp), and every
compiled step, replayed by the generic step from the same state and step size, agrees to 1e-13.
"""

import numpy as np
import pytest
from conftest import random_rotation

import lieint
from lieint.control import StepSizeController
from lieint.driver import Driver
from lieint.methods.registry import method_specs

PAIRS = [
    name
    for name, spec in method_specs().items()
    if spec.adaptive and spec.family != "scipy" and lieint.get_method(name).compiled() is not None
]
RTOL, ATOL, T = 1e-6, 1e-8, 4.0


def test_every_compiled_pair_is_covered():
    assert {"rkmk23", "rkmk45", "rkmk853"} <= set(PAIRS)


def top_and_state(rng, orientation, bodies):
    I = np.array([1.1, 1.7, 2.3])
    Q = random_rotation(rng, 3)
    Q[:, 0] *= -1  # an improper, non-diagonal eigenbasis: the error is measured in the user's frame
    top = lieint.EulerTop(Q @ np.diag((I.sum() - 2 * I) / 2) @ Q.T, orientation=orientation)
    shape = (bodies,) if bodies > 1 else ()
    w = rng.normal(size=shape + (3,))
    R = random_rotation(rng, 3, shape) if orientation else None
    return top, top.initial_state(angular_velocity=w, R=R)


@pytest.mark.parametrize("bodies", [1, 3])
@pytest.mark.parametrize("orientation", [True, False])
@pytest.mark.parametrize("method", PAIRS)
def test_compiled_adaptive_matches_the_generic_controller(rng, method, orientation, bodies):
    top, y0 = top_and_state(rng, orientation, bodies)
    kw = dict(t_span=(0.0, T), method=method, rtol=RTOL, atol=ATOL, save_every=1, project=bodies == 3)
    fast = lieint.integrate(top, y0, backend="numba", **kw)
    ref = lieint.integrate(top, y0, backend="numpy", **kw)
    assert (fast.stats.backend, ref.stats.backend) == ("numba", "numpy")
    assert "adaptive" in fast.stats.backend_reason
    assert (fast.nsteps, fast.stats.nrejected, fast.nfev) == (ref.nsteps, ref.stats.nrejected, ref.nfev)
    assert fast.t[-1] == ref.t[-1] == T and fast.success
    # the controller's round-off floor (module docstring), below the methods' own error: at
    # rtol 1e-6 measured up to 2e-6 over 36 cases, and the generic path moves by 1e-6 when y₀
    # changes by one ulp (docs/measurements/speed.md, "Adaptive steps, compiled")
    np.testing.assert_allclose(fast.t, ref.t, rtol=0, atol=10 * RTOL)
    for name in ref.states:
        np.testing.assert_allclose(fast.states[name], ref.states[name], rtol=0, atol=10 * RTOL)

    # every compiled step is the generic step from the same state and step size, to round-off
    method_obj = lieint.get_method(method)
    ctrl = StepSizeController(RTOL, ATOL)
    worst = 0.0
    for k in range(fast.t.size - 1):
        yk = {name: v[k] for name, v in fast.states.items()}
        step = method_obj.step(top, fast.t[k], yk, fast.t[k + 1] - fast.t[k])
        y1 = top.project(step.y) if kw["project"] else step.y
        assert ctrl.error_norm(yk, step.y, step.error) < 1.0  # the generic path accepts it too
        for name in y1:
            worst = max(worst, float(np.max(np.abs(fast.states[name][k + 1] - y1[name]))))
    assert worst < 1e-13 * max(1.0, float(np.abs(ref.states["A"]).max()))


@pytest.mark.parametrize("n", [3, 4])
@pytest.mark.parametrize("method", ["rkmk45", "rkmk853"])
@pytest.mark.slow
def test_segments_give_the_same_bits_as_one_call(rng, method, n):
    if n == 3:
        top, y0 = top_and_state(rng, True, 1)
    else:  # the n-dimensional top's own adaptive kernel (lieint.fast.topn_adaptive)
        Q = random_rotation(rng, n)
        top = lieint.EulerTop(Q @ np.diag([0.6, 0.8, 1.1, 1.3]) @ Q.T)
        X = rng.normal(size=(n, n))
        y0 = top.initial_state(Omega=X - X.T, R=random_rotation(rng, n))
    kw = dict(method=lieint.get_method(method), t_span=(0.0, 20.0), rtol=1e-9, atol=1e-11, save_every=3)
    whole = Driver(top, **kw)
    carry = whole.start(y0)
    one = whole.advance(carry)
    parts = Driver(top, **kw)
    c2 = parts.start(y0)
    segs = []
    while not parts.done(c2):
        segs.append(parts.advance(c2, 4))
        c2.state = {k: v.copy() for k, v in c2.state.items()}  # what a checkpoint holds
    assert whole.backend == parts.backend == "numba"
    assert np.array_equal(one.t, np.concatenate([s.t for s in segs]))
    for name in one.states:
        assert np.array_equal(one.states[name], np.concatenate([s.states[name] for s in segs]))
    assert (carry.k, carry.nrejected, carry.nfev, carry.h) == (c2.k, c2.nrejected, c2.nfev, c2.h)


SCENE = """
[scene]
name = "3D top, adaptive"

[body]
principal_moments = [1.0, 2.0, 3.0]

[support]
type = "fixed_point"

[initial]
angular_velocity = [0.01, 1.0, 0.01]

[integrator]
method = "rkmk853"
step = 0.01
t_end = 60.0
rtol = 1e-10
atol = 1e-12
project = true
save_every = 5

[output]
quantities = ["energy", "casimirs", "orientation"]
"""


def test_a_streamed_adaptive_run_resumes_bit_for_bit(tmp_path):
    from conftest import assert_identical, read_all

    scene = tmp_path / "top.toml"
    scene.write_text(SCENE)
    report = lieint.run(scene, tmp_path / "ref.h5", progress=False)
    assert report.status == "complete"
    reference, attrs = read_all(tmp_path / "ref.h5")
    assert attrs["backend"] == "numba" and attrs["nrejected"] >= 0 and attrs["steps_done"] > 100
    out = tmp_path / "run.h5"
    stopped = lieint.run(scene, out, progress=False, stop_after=37, checkpoint_every=11)
    assert stopped.status == "interrupted"
    assert lieint.run(scene, out, resume=True, progress=False, checkpoint_every=13).status == "complete"
    resumed, attrs2 = read_all(out)
    assert_identical(resumed, reference)
    assert (attrs2["steps_done"], attrs2["nfev"], attrs2["nrejected"]) == (
        attrs["steps_done"],
        attrs["nfev"],
        attrs["nrejected"],
    )


def test_backends_of_adaptive_runs(rng):
    top, y0 = top_and_state(rng, True, 1)
    kw = dict(t_span=(0.0, 1.0), method="rkmk45", rtol=1e-6)
    assert lieint.integrate(top, y0, **kw).stats.backend == "numba"
    cayley = lieint.integrate(top, y0, coordinates="cayley", **kw).stats  # through the generic kernel
    assert cayley.backend == "numba" and "adaptive RKMK (Cayley)" in cayley.backend_reason
    assert lieint.integrate(top, y0, dexpinv_degree=None, **kw).stats.backend == "numpy"
    dense = lieint.integrate(top, y0, dense_output=True, backend="numba", **kw)  # served by the engine
    assert dense.stats.backend == "numba" and "adaptive RKMK" in dense.stats.backend_reason
    ball = lieint.ChaplyginBall(np.diag([0.1, 0.15, 0.2]), 1.0, 1.0)
    run = lieint.integrate(ball, ball.initial_state(angular_velocity=[1.0, 2.0, 0.5]), backend="numba", **kw)
    assert run.stats.backend == "numba" and "compiled pieces on se(3), adaptive" in run.stats.backend_reason
    flat = lieint.EulerTop(np.diag([1.0, 2.0]))
    with pytest.raises(ValueError, match=r"`backend='numba'`: no compiled kernel covers this run: EulerTop \(n = 2\)"):
        lieint.integrate(flat, flat.initial_state(Omega=[[0.0, -1.0], [1.0, 0.0]]), backend="numba", **kw)


def test_compiled_adaptive_rejects_steps_beyond_the_dexpinv_radius():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    fast = top.initial_state(angular_velocity=[0.0, 0.3, 20.0])
    kw = dict(t_span=(0, 1), h=2.0, method="rkmk853", rtol=1e-6, atol=1e-8)
    a = lieint.integrate(top, fast, backend="numba", **kw)
    b = lieint.integrate(top, fast, backend="numpy", **kw)
    assert a.success and a.stats.nrejected >= 1
    assert (a.nsteps, a.stats.nrejected, a.nfev) == (b.nsteps, b.stats.nrejected, b.nfev)


def test_a_step_size_below_h_min_fails_as_on_the_generic_path():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    kw = dict(t_span=(0, 1), method="rkmk45", rtol=1e-30, atol=1e-40)
    a = lieint.integrate(top, y0, backend="numba", **kw)
    b = lieint.integrate(top, y0, backend="numpy", **kw)
    assert not a.success and a.message == b.message and "the step size fell below" in a.message
    assert (a.nsteps, a.stats.nrejected, a.nfev, a.t[-1]) == (b.nsteps, b.stats.nrejected, b.nfev, b.t[-1])


@pytest.mark.parametrize("n", [4, 6])
@pytest.mark.parametrize("diagonal", [True, False])
@pytest.mark.parametrize("orientation", [True, False])
def test_the_nd_tops_compiled_first_trial_step_is_the_generic_one(rng, n, diagonal, orientation):
    """The n-D top's adaptive kernel takes the first trial step in machine code, in the principal
    frame: the generic controller's to the round-off of d₂ (the fields agree to a few ε, and d₂
    is a difference of nearly equal fields: tests/fast/test_pieces.py's bound), for every pair's
    error order, a batch, a body at rest, ordinary and absurd tolerances."""
    from bodies import first_step_round_off

    from lieint.loops import adaptive_loop

    b = np.linspace(0.6, 1.4, n)
    Q = random_rotation(rng, n) if not diagonal else np.eye(n)
    top = lieint.EulerTop(Q @ np.diag(b) @ Q.T, orientation=orientation)
    X = rng.normal(size=(3, n, n))
    R = random_rotation(rng, n, (3,)) if orientation else None
    states = {
        "one": top.initial_state(Omega=X[0] - X[0].T, R=None if R is None else R[0]),
        "batch": top.initial_state(Omega=X - np.swapaxes(X, -1, -2), R=R),
        "rest": top.initial_state(Omega=np.zeros((n, n))),
    }
    for label, y0 in states.items():
        for rtol, atol in ((1e-6, 1e-9), (1e-10, 1e-13), (1e-3, 1e-200), (1e-12, 1.0)):
            for method in PAIRS:
                run = Driver(top, lieint.get_method(method), (0.0, 2.0), rtol=rtol, atol=atol)
                y = top.validate_state(y0)
                loop = adaptive_loop(run, y)
                assert loop.name == "numba" and f"{n}D top (principal frame)" in loop.reason, loop.reason
                ctrl = StepSizeController(rtol, atol)
                expected = ctrl.initial_step(top, 0.0, y, 2.0, run.method.error_order)
                got = loop.start(y).h
                tol = first_step_round_off(top, y, ctrl)
                assert got == pytest.approx(expected, rel=tol, abs=0), (label, rtol, atol, method)
