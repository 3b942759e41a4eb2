"""The compiled tangent steps (:mod:`lieint.tangent.compiled`, :mod:`lieint.fast.top3_tangent`,
:mod:`lieint.fast.topn_tangent`, :mod:`lieint.fast.heavy3_tangent`,
:mod:`lieint.fast.chaplygin3_tangent`, :mod:`lieint.fast.rolling3_tangent`): the 3D top's RKMK
methods, splittings and Moser–Veselov maps, the RKMK methods of the n-D top, the 3D heavy top, the
3D Chaplygin ball and the 3D rolling ball (offset centre of mass, gravity, incline).

Truths: the generic path's complex step (``backend="numpy"``), which shares no step code with the
compiled forward mode; the plain compiled run of :func:`lieint.integrate` (the state, bit for bit);
central finite differences of whole runs (``tangent_cases``); the symplectic form of the free top's
phase space for the symplectic maps. The other bodies' compiled states are stepped by code of
their own, their plain runs' by the plain kernels: they agree to round-off, not to the bit."""

from __future__ import annotations

import numpy as np
import pytest

import lieint
from lieint.methods.registry import get_method, method_specs
from lieint.tangent.compiled import COMPILED_REASON, compiled_reason
from lieint.tangent.flow import BACKEND_REASON, TangentStepper, tangent_backend

TOP = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])


def _tops():
    rng = np.random.default_rng(5)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return {
        "principal frame": TOP,
        "tilted frame": lieint.EulerTop(Q @ np.diag([0.6, 0.8, 1.0]) @ Q.T),
        "no R": lieint.EulerTop.from_principal_moments([1.0, 1.5, 2.5], orientation=False),
    }


def _cases() -> list[tuple[str, str]]:
    """(top, method): every compiled method on the tilted top (the frame the steps turn through),
    and one method of each family on the others (the principal frame, a top without attitude)."""
    names = _compiled_methods()
    families = {}
    for name in names:
        families.setdefault(get_method(name).compiled().family, name)
    return [("tilted frame", name) for name in names] + [
        (label, name) for label in ("principal frame", "no R") for name in families.values()
    ]


def _compiled_methods() -> list[str]:
    """Every method of the registry with compiled tangent steps on the 3D top."""
    names = []
    for name in method_specs():
        method = get_method(name)
        try:
            TangentStepper(TOP, method)
        except ValueError:
            continue
        if not compiled_reason(TOP, method):
            names.append(name)
    return names


def test_the_registry_s_rkmk_methods_splittings_and_moser_veselov_maps_have_compiled_tangent_steps():
    names = _compiled_methods()
    for expected in ("lie_euler", "rkmk2", "rkmk4", "rkmk6", "splitting2", "splitting4", "splitting6",
                     "moser_veselov", "moser_veselov_composed4"):  # fmt: skip
        assert expected in names
    assert not compiled_reason(TOP, get_method("splitting2"))
    assert not compiled_reason(TOP, get_method("rkmk4"))
    for products in ("cf3", "cf4", "cg3", "cg4a"):  # the commutator-free and Crouch–Grossman methods
        assert products in names and not compiled_reason(TOP, get_method(products))
    assert "no compiled tangent steps" in compiled_reason(TOP, get_method("lie_midpoint"))
    assert "no compiled tangent steps" in compiled_reason(TOP, get_method("rkmk4", coordinates="cayley"))
    heavy = lieint.HeavyTop(np.diag([1.0, 2.0, 3.0]), 1.0, [0.1, 0.0, 0.2], [0.0, 0.0, -9.81])
    assert not compiled_reason(heavy, get_method("rkmk4"))
    assert not compiled_reason(heavy, get_method("cf4")) and not compiled_reason(heavy, get_method("cg4a"))
    assert not compiled_reason(heavy, get_method("rkmk45")) and not compiled_reason(heavy, get_method("rkmk853"))
    for refused in (get_method("rkmk4", coordinates="cayley"), get_method("lie_midpoint"), get_method("rkmk45+energy")):
        assert "no compiled tangent steps on the 3D heavy top" in compiled_reason(heavy, refused)
    ball = lieint.RollingBall(np.diag([0.1, 0.15, 0.2]), 1.0, 1.0, [0.0, 0.1, -0.2])
    assert not compiled_reason(ball, get_method("rkmk4"))
    assert not compiled_reason(ball, get_method("cg4a"))
    assert "no compiled tangent steps on the 3D rolling ball" in compiled_reason(ball, get_method("lie_midpoint"))
    ball4 = lieint.ChaplyginBall(np.diag([0.1, 0.15, 0.2, 0.25]), 1.0, 1.0)
    assert "the 3D rolling ball only" in compiled_reason(ball4, get_method("rkmk4"))
    assert not compiled_reason(lieint.EulerTop(np.diag([1.0, 2.0, 3.0, 4.0])), get_method("rkmk4"))


@pytest.mark.parametrize(("label", "method"), _cases())
def test_compiled_tangent_map_is_the_complex_step_s_and_its_state_the_plain_run_s(label, method):
    top = _tops()[label]
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    compiled = lieint.tangent_flow(top, y0, (0.0, 3.0), h=0.03, method=method)
    generic = lieint.tangent_flow(top, y0, (0.0, 3.0), h=0.03, method=method, backend="numpy")
    assert compiled.backend_reason == COMPILED_REASON and generic.backend_reason == BACKEND_REASON
    # the paths step in different frames (the principal one, the user's): their runs differ by
    # round-off (up to 5e-12 after 100 steps of splitting6 in a tilted frame, whose generic path
    # turns the frame at every rotation), and their tangent maps as much, not more
    runs_apart = max(np.max(np.abs(compiled.y[k] - generic.y[k])) for k in compiled.y)
    scale = np.max(np.abs(generic.vectors))
    assert np.max(np.abs(compiled.vectors - generic.vectors)) <= (1e-14 + 3 * runs_apart) * scale, method
    if get_method(method).adaptive:  # an embedded pair: its propagated solution, the generic path's
        for name in compiled.y:
            np.testing.assert_allclose(compiled.y[name], generic.y[name], rtol=0, atol=1e-12, err_msg=method)
        return
    plain = lieint.integrate(top, y0, (0.0, 3.0), h=0.03, method=method)
    assert plain.stats.backend == "numba"
    for name in compiled.y:  # the same operations in the same order as the plain compiled step
        np.testing.assert_array_equal(compiled.y[name], plain.states[name][-1], err_msg=method)


@pytest.mark.parametrize("method", ["splitting2", "moser_veselov_composed4", "rkmk4"])
def test_compiled_tangent_map_is_the_derivative_of_the_run_by_central_differences(method):
    import tangent_cases  # finite differences written apart from lieint.tangent

    y0 = TOP.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    run = lieint.tangent_flow(TOP, y0, (0.0, 2.0), h=0.02, method=method, backend="numba")

    def flow(y):
        return {k: v[-1] for k, v in lieint.integrate(TOP, y, (0.0, 2.0), h=0.02, method=method).states.items()}

    for j in range(6):
        fd, _spread = tangent_cases.central_difference(flow, TOP, y0, np.eye(6)[j])
        np.testing.assert_allclose(run.vectors[j], fd, rtol=1e-6, atol=1e-7 * np.abs(fd).max())


def test_a_batch_of_tops_steps_each_as_alone():
    y0 = TOP.initial_state(angular_velocity=[[0.3, 1.0, 0.4], [1.0, 0.2, 0.1]])
    both = lieint.tangent_flow(TOP, y0, (0.0, 1.0), h=0.01, method="moser_veselov")
    for b in range(2):
        alone = lieint.tangent_flow(TOP, {k: v[b] for k, v in y0.items()}, (0.0, 1.0), h=0.01, method="moser_veselov")
        np.testing.assert_allclose(both.vectors[:, b], alone.vectors, rtol=0, atol=1e-13 * np.abs(alone.vectors).max())


@pytest.mark.parametrize("method", _compiled_methods())
def test_steps_of_any_sizes_run_compiled_and_give_the_complex_step_s_tangent_map(method):
    # a schedule of steps (an adaptive run's accepted steps held fixed): the loop reads each step's
    # size; the map and its derivative are the generic path's on the same steps
    top = _tops()["tilted frame"]
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    steps = 0.01 * (1.0 + 0.5 * np.sin(np.arange(40)))  # 40 steps, every size its own
    span = (0.0, float(steps.sum()))
    compiled = lieint.tangent_flow(top, y0, span, steps=steps, method=method)
    generic = lieint.tangent_flow(top, y0, span, steps=steps, method=method, backend="numpy")
    assert compiled.backend_reason == COMPILED_REASON and generic.backend_reason == BACKEND_REASON
    # the paths step in different frames: their runs differ by round-off (the splittings' generic
    # path turns the frame at every rotation), and their tangent maps as much, not more
    runs_apart = max(np.max(np.abs(compiled.y[k] - generic.y[k])) for k in compiled.y)
    scale = np.max(np.abs(generic.vectors))
    assert runs_apart < 1e-11, method  # up to 5e-12 on the grid (the test above)
    assert np.max(np.abs(compiled.vectors - generic.vectors)) <= (1e-14 + 3 * runs_apart) * scale, method


def test_methods_without_compiled_tangent_steps_take_the_generic_path_and_say_so():
    y0 = TOP.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    assert lieint.tangent_flow(TOP, y0, (0.0, 0.1), h=0.01, method="lie_midpoint").backend_reason == BACKEND_REASON
    assert "no compiled tangent steps" in tangent_backend(TOP, "lie_midpoint")
    assert tangent_backend(TOP, "splitting2") == tangent_backend(TOP, "rkmk4") == tangent_backend(TOP, "cf4")
    assert tangent_backend(TOP, "rkmk4") == COMPILED_REASON
    with pytest.raises(ValueError, match=r"backend=.numba.*lie_midpoint"):
        lieint.tangent_flow(TOP, y0, (0.0, 0.1), h=0.01, method="lie_midpoint", backend="numba")
    with pytest.raises(ValueError, match="`backend` must be one of"):
        lieint.tangent_flow(TOP, y0, (0.0, 0.1), h=0.01, method="splitting2", backend="gpu")


@pytest.mark.parametrize(("label", "method"), _cases())
def test_lyapunov_and_megno_run_whole_in_the_engine_as_the_generic_path_runs_them(label, method):
    # a batch of two bodies; every = 7 does not divide the 160 steps (the last QR is after the last step)
    top = _tops()[label]
    y0 = top.initial_state(angular_velocity=[[0.3, 1.0, 0.4], [1.0, 0.3, 0.2]])
    # how far the two paths' plain runs part by round-off (the generic splitting turns a tilted
    # frame at every rotation: up to 1e-11 over 400 steps): the indicators part no more
    ends = [lieint.integrate(top, y0, (0.0, 8.0), h=0.05, method=method, backend=b).states for b in ("numba", "numpy")]
    tol = 1e-12 + 3 * max(np.max(np.abs(ends[0][k][-1] - ends[1][k][-1])) for k in ends[0])
    fast = lieint.lyapunov(top, y0, (0.0, 8.0), h=0.05, method=method, every=7)
    slow = lieint.lyapunov(top, y0, (0.0, 8.0), h=0.05, method=method, every=7, backend="numpy")
    assert fast.backend_reason == COMPILED_REASON and slow.backend_reason == BACKEND_REASON
    np.testing.assert_array_equal(fast.t, slow.t)
    np.testing.assert_allclose(fast.history, slow.history, rtol=0, atol=tol)
    for name in slow.y:
        np.testing.assert_allclose(fast.y[name], slow.y[name], rtol=0, atol=tol)
    fast_m = lieint.megno(top, y0, (0.0, 8.0), h=0.05, method=method, save_every=3)
    slow_m = lieint.megno(top, y0, (0.0, 8.0), h=0.05, method=method, save_every=3, backend="numpy")
    assert fast_m.backend_reason == COMPILED_REASON and slow_m.backend_reason == BACKEND_REASON
    np.testing.assert_array_equal(fast_m.t, slow_m.t)
    # MEGNO weights each step's log-growth by its time (up to T = 8) and sums 160 of them: the
    # tangent vectors' round-off apart (tilted frame: up to 1e-12 a step) adds up in Y
    for field in ("y_history", "mean_history", "lyapunov_history", "lyapunov", "mean"):
        np.testing.assert_allclose(
            getattr(fast_m, field), getattr(slow_m, field), rtol=0, atol=160 * tol, err_msg=field
        )


def test_a_tangent_vector_that_stops_being_finite_is_refused_on_the_compiled_path_too():
    y0 = TOP.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    with pytest.raises(FloatingPointError, match="non-finite"):
        lieint.megno(TOP, y0, (0.0, 1.0), h=0.05, method="splitting2", vector=np.zeros(6) * np.nan)


def test_a_parameter_sensitivity_runs_on_the_generic_path():
    # the complex step through a parameter makes the system's numbers complex: no compiled steps
    y0 = TOP.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    top = lieint.EulerTop(np.diag([0.6, 0.8, 1.0]))
    moved, _ = top.with_parameter_step("B", np.diag([1.0, 0.0, 0.0]), 1e-30j, top.validate_state(y0))
    assert "complex" in TangentStepper(moved, "moser_veselov").compiled_reason
    sens = lieint.sensitivity(TOP, y0, (0.0, 0.5), h=0.05, method="moser_veselov")
    assert np.all(np.isfinite(sens.jacobian)) and sens.backend_reason == BACKEND_REASON


# -- the n-dimensional top, the 3D heavy top, the 3D Chaplygin ball and the 3D rolling ball --------


def _bodies():
    """The bodies with compiled tangent steps of RKMK besides the free 3D top, in frames the steps
    turn through (a tilted principal frame, a tilted contact tensor) and with fields left out."""
    rng = np.random.default_rng(5)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    B = Q @ np.diag([1.0, 1.5, 2.0]) @ Q.T
    centre, g = [0.1, 0.05, 0.08], [0.0, 0.0, -9.81]
    incline = 9.81 * np.array([np.sin(0.3), 0.0, -np.cos(0.3)])
    B_C = Q @ np.diag([0.08, 0.12, 0.16]) @ Q.T
    Q4, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    Q5, _ = np.linalg.qr(rng.normal(size=(5, 5)))
    return {
        "4D top, tilted": lieint.EulerTop(Q4 @ np.diag([0.6, 0.8, 1.0, 1.3]) @ Q4.T),
        "4D top, no R": lieint.EulerTop(np.diag([0.6, 0.8, 1.0, 1.3]), orientation=False),
        "5D top, tilted": lieint.EulerTop(Q5 @ np.diag([0.6, 0.7, 0.9, 1.1, 1.4]) @ Q5.T),
        "heavy top, tilted frame": lieint.HeavyTop(B, 1.0, centre, g),
        "heavy top, no R": lieint.HeavyTop(np.diag([1.0, 1.5, 2.0]), 1.0, centre, g, orientation=False),
        "Chaplygin ball, tilted": lieint.ChaplyginBall(B_C, 1.0, 1.0),
        "Chaplygin ball, no centre": lieint.ChaplyginBall(B_C, 1.0, 1.0, track_center=False),
        "Chaplygin ball, no R": lieint.ChaplyginBall(B_C, 1.0, 1.0, orientation=False, track_center=False),
        "rolling ball on an incline, tilted": lieint.RollingBall(B_C, 1.0, 1.0, [0.0, 0.1, -0.2], incline),
        "rolling ball, gravity along the normal": lieint.RollingBall(B_C, 1.2, 0.8, centre, g),
        "rolling ball, no gravity, no centre": lieint.RollingBall(B_C, 1.0, 1.0, centre, track_center=False),
        "rolling ball, no R": lieint.RollingBall(B_C, 1.0, 1.0, centre, g, orientation=False, track_center=False),
    }


def _start(body, second=False):
    if isinstance(body, lieint.EulerTop):  # n ≥ 4
        X = np.arange(body.n * body.n, dtype=float).reshape(body.n, body.n) / body.n**2 + np.eye(body.n, k=1)
        return body.initial_state(Omega=(0.3 if second else 0.6) * (X - X.T))
    if second:
        return body.initial_state(angular_velocity=[1.0, 0.3, 0.2])
    spin = [1.0, 2.0, 1.5] if isinstance(body, lieint.HeavyTop) else [0.3, 1.0, 0.4]
    return body.initial_state(angular_velocity=spin)


def _plain_run(body, y0, method: str, generic) -> dict:
    """The final state of the run whose tangent map is taken (0 → 3, h = 0.03): the plain compiled
    run of a fixed-step method; an embedded pair's propagated solution on those steps (which
    ``integrate`` does not take: it runs the pair adaptively) from the generic path's real part."""
    if get_method(method).adaptive:
        return generic.y
    plain = lieint.integrate(body, y0, (0.0, 3.0), h=0.03, method=method)
    assert plain.stats.backend == "numba"
    return {k: v[-1] for k, v in plain.states.items()}


def _body_methods(body) -> list[str]:
    """Every method of the registry with compiled tangent steps on ``body``."""
    names = []
    for name in method_specs():
        method = get_method(name)
        try:
            TangentStepper(body, method)
        except ValueError:
            continue
        if not compiled_reason(body, method):
            names.append(name)
    return names


def _body_cases() -> list[tuple[str, str]]:
    """(body, method): every compiled method on the tilted bodies, rkmk4 on the others."""
    out = []
    for label, body in _bodies().items():
        out += [(label, name) for name in (_body_methods(body) if "tilted" in label else ["rkmk4"])]
    return out


@pytest.mark.parametrize("label", sorted(_bodies()))
def test_the_rkmk_methods_of_the_n_d_top_the_heavy_top_and_the_balls_have_compiled_tangent_steps(label):
    names = _body_methods(_bodies()[label])
    for expected in ("lie_euler", "rkmk2", "rkmk3", "rkmk4", "rkmk6"):
        assert expected in names
    # the 3D bodies' products of exponentials too (commutator-free, Crouch–Grossman); not the n-D tops'
    assert ("cf4" in names) == ("cg4a" in names) == (_bodies()[label].n == 3)
    # the embedded pairs (their propagated solution on the steps given); not the energy pairs
    assert "rkmk45" in names and "rkmk853" in names and "rkmk45+energy" not in names and "lie_midpoint" not in names


@pytest.mark.parametrize(("label", "method"), _body_cases())
def test_body_compiled_tangent_map_is_the_complex_step_s_and_its_state_the_plain_run_s(label, method):
    body = _bodies()[label]
    y0 = _start(body)
    compiled = lieint.tangent_flow(body, y0, (0.0, 3.0), h=0.03, method=method)
    generic = lieint.tangent_flow(body, y0, (0.0, 3.0), h=0.03, method=method, backend="numpy")
    assert compiled.backend_reason == COMPILED_REASON and generic.backend_reason == BACKEND_REASON
    dim = lieint.tangent.chart_of(body).dim
    assert compiled.vectors.shape == generic.vectors.shape == (dim, dim)
    # vectors against matrices (and the principal frame against the user's): round-off apart
    # (5e-14 after 100 steps of rkmk6), and the tangent maps as much, entry by entry
    plain = _plain_run(body, y0, method, generic)
    runs_apart = max(np.max(np.abs(compiled.y[k] - plain[k])) for k in compiled.y)
    assert runs_apart < 1e-12, runs_apart
    scale = np.max(np.abs(generic.vectors))
    np.testing.assert_allclose(compiled.vectors, generic.vectors, rtol=1e-10, atol=1e-13 * scale, err_msg=method)


@pytest.mark.parametrize(
    "label",
    ["heavy top, tilted frame", "Chaplygin ball, tilted", "rolling ball on an incline, tilted", "4D top, tilted"],
)
def test_body_compiled_tangent_map_is_the_derivative_of_the_run_by_central_differences(label):
    import tangent_cases  # finite differences written apart from lieint.tangent

    body = _bodies()[label]
    y0 = _start(body)
    dim = lieint.tangent.chart_of(body).dim
    run = lieint.tangent_flow(body, y0, (0.0, 2.0), h=0.02, method="rkmk4", backend="numba")

    def flow(y):
        return {k: v[-1] for k, v in lieint.integrate(body, y, (0.0, 2.0), h=0.02, method="rkmk4").states.items()}

    for j in range(dim):
        fd, _spread = tangent_cases.central_difference(flow, body, y0, np.eye(dim)[j])
        np.testing.assert_allclose(run.vectors[j], fd, rtol=1e-6, atol=1e-7 * np.abs(fd).max())


_INDICATOR_CASES = [(label, method) for label in sorted(_bodies()) for method in ("lie_euler", "rkmk4")] + [
    (label, method)
    for label in ("heavy top, tilted frame", "heavy top, no R", "Chaplygin ball, tilted", "rolling ball, no R",
                  "rolling ball on an incline, tilted")
    for method in ("cf4", "cg4a")
]  # fmt: skip


@pytest.mark.parametrize(("label", "method"), _INDICATOR_CASES)
def test_body_lyapunov_and_megno_run_whole_in_the_engine_as_the_generic_path_runs_them(label, method):
    body = _bodies()[label]
    one = _start(body)
    two = _start(body) if isinstance(body, lieint.HeavyTop) else _start(body, second=True)
    y0 = {k: np.stack([one[k], two[k]]) for k in one}
    fast = lieint.lyapunov(body, y0, (0.0, 8.0), h=0.05, method=method, every=7)
    slow = lieint.lyapunov(body, y0, (0.0, 8.0), h=0.05, method=method, every=7, backend="numpy")
    assert fast.backend_reason == COMPILED_REASON and slow.backend_reason == BACKEND_REASON
    np.testing.assert_array_equal(fast.t, slow.t)
    np.testing.assert_allclose(fast.history, slow.history, rtol=0, atol=1e-13)
    for name in slow.y:  # round-off of the state's size (the ball on the incline spins up to |ω| ≈ 25)
        scale = max(1.0, float(np.max(np.abs(slow.y[name]))))
        np.testing.assert_allclose(fast.y[name], slow.y[name], rtol=0, atol=1e-12 * scale, err_msg=name)
    fast_m = lieint.megno(body, y0, (0.0, 8.0), h=0.05, method=method, save_every=3)
    slow_m = lieint.megno(body, y0, (0.0, 8.0), h=0.05, method=method, save_every=3, backend="numpy")
    assert fast_m.backend_reason == COMPILED_REASON and slow_m.backend_reason == BACKEND_REASON
    np.testing.assert_array_equal(fast_m.t, slow_m.t)
    for field in ("y_history", "mean_history", "lyapunov_history", "lyapunov", "mean"):
        np.testing.assert_allclose(getattr(fast_m, field), getattr(slow_m, field), rtol=0, atol=1e-12, err_msg=field)


@pytest.mark.parametrize("label", sorted(_bodies()))
def test_a_body_s_non_finite_tangent_vector_is_refused_on_the_compiled_path_too(label):
    body = _bodies()[label]
    dim = lieint.tangent.chart_of(body).dim
    assert not compiled_reason(body, get_method("rkmk4"))
    with pytest.raises(FloatingPointError, match="non-finite"):
        lieint.megno(body, _start(body), (0.0, 1.0), h=0.05, method="rkmk4", vector=np.zeros(dim) * np.nan)


def test_one_sine_and_cosine_for_a_turn_give_rodrigues_and_the_coefficients_bit_for_bit():
    # se3_tangent.exponential shares one sine and cosine between exp(û) and β, γ and their
    # derivatives (θ ≥ 0.1): the numbers must be those of _rodrigues and coefficients computed apart
    from lieint.fast.se3_tangent import coefficients, exponential
    from lieint.fast.top3 import _rodrigues

    rng = np.random.default_rng(5)
    for theta in (0.0, 1e-9, 0.05, 0.0999, 0.1, 0.1001, 0.3, 1.0, 2.5, 3.1):
        axis = rng.normal(size=3)
        u = np.concatenate([theta * axis / np.linalg.norm(axis), rng.normal(size=3)])
        Q, Q_apart = np.empty((3, 3)), np.empty((3, 3))
        shared = exponential(u, Q)
        _rodrigues(u, Q_apart)
        apart = coefficients(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
        assert np.array_equal(Q, Q_apart) and shared == apart, theta
