"""Dense output on the group, t_eval for every method, and events with scipy's semantics."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import fitted_slope
from scipy.integrate import solve_ivp

import lieint
from lieint.groups.bivectors import vee
from lieint.methods import RKMK, tableaux
from lieint.methods.scipy_ivp import StateLayout
from lieint.systems.euler_top_exact import euler_top_flip_times

TOP = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
Y0 = TOP.initial_state(angular_velocity=[0.3, 1.0, 0.4])


@pytest.mark.parametrize("coordinates", ["exp", "cayley"])
def test_dense_states_lie_on_the_group(rng, coordinates):
    sol = lieint.integrate(TOP, Y0, (0.0, 10.0), h=0.2, method="rkmk4", coordinates=coordinates, dense_output=True)
    times = rng.uniform(0.0, 10.0, 10_000)
    states = sol.sol(times)
    R = states["R"]
    defect = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max()
    assert defect <= 1e-14, defect
    # the spectrum of A (|A|) is that of A₀: the interpolant moves along the orbit
    assert np.allclose(np.linalg.norm(states["A"], axis=(-2, -1)), np.linalg.norm(Y0["A"]), rtol=1e-14, atol=0)
    # the interpolant passes through the steps
    at_steps = sol.sol(sol.t)
    assert np.array_equal(at_steps["A"], sol.states["A"])


def dense_error(method, h, T=2.0, where="between", skip=0):
    sol = lieint.integrate(TOP, Y0, (0.0, T), h=h, method=method, dense_output=True, backend="numpy")
    n = round(T / h)
    times = (np.arange(skip, n) + 0.37) * h if where == "between" else np.arange(skip + 1, n + 1) * h
    exact = TOP.exact_solution(times, Y0)["A"]
    return np.max(np.abs(sol.sol(times)["A"] - exact))


@pytest.mark.parametrize(("method", "order"), [("lie_euler", 1), ("rkmk2", 2), ("rkmk3", 3), ("rkmk4", 4)])
def test_dense_output_has_the_order_of_the_method(method, order):
    hs = [0.1, 0.05, 0.025]
    between = [dense_error(method, h) for h in hs]
    at_steps = [dense_error(method, h, where="steps") for h in hs]
    assert abs(fitted_slope(hs, between) - order) <= 0.2, between
    assert abs(fitted_slope(hs, at_steps) - order) <= 0.2, at_steps
    # between the steps the error is of the size it has at the steps
    assert between[-1] <= 5 * at_steps[-1] + 1e-13


@pytest.mark.parametrize(
    ("method", "order", "hs"),
    [
        ("rkmk6", 6, [0.1, 0.05, 0.025]),
        (RKMK("dp8", tableaux.DORMAND_PRINCE853.tableau, dexpinv_degree=6), 8, [0.4, 0.2, 0.1]),
    ],
)
def test_high_order_dense_output_matches_earlier_step_ends(method, order, hs):
    """Order 6 and 8 from a Hermite curve through one or two earlier step ends as well (the
    first steps of a run, with fewer earlier ends, are left out here)."""
    between = [dense_error(method, h, skip=2) for h in hs]
    at_steps = [dense_error(method, h, where="steps", skip=2) for h in hs]
    assert abs(fitted_slope(hs, between) - order) <= 0.35, between
    assert abs(fitted_slope(hs, at_steps) - order) <= 0.35 or at_steps[-1] < 1e-14, at_steps


def test_dense_output_of_steps_that_turn_the_body_by_radians_follows_the_steps():
    """A fast top (|ω| = 3) at loose rtol: rkmk853's steps turn the body by up to 3.3 rad. The
    curve through two earlier step ends needs the logarithm of the chain of steps back, whose
    principal value stops following the path past π: there the curve now keeps fewer ends
    (dense error ≤ 3.6× the steps'; through the wrong branch it was 0.64–1.5, the steps'
    3e-3–4e-2)."""
    y0 = TOP.initial_state(angular_velocity=[0.05, 3.0, 0.05])
    t = np.linspace(0.0, 6.0, 601)
    exact = TOP.exact_solution(t, y0)["R"]
    for rtol in (1e-3, 1e-4, 1e-5):
        sol = lieint.integrate(TOP, y0, (0.0, 6.0), method="rkmk853", rtol=rtol, backend="numpy", dense_output=True)
        at_steps = np.abs(sol.states["R"] - TOP.exact_solution(sol.t, y0)["R"]).max()
        assert np.abs(sol.sol(t)["R"] - exact).max() <= 5 * at_steps


@pytest.mark.parametrize("method", lieint.method_names())
@pytest.mark.slow
def test_t_eval_works_for_every_method(method):
    t_eval = np.linspace(0.0, 1.0, 7)
    try:
        lieint.get_method(method).check_system(TOP)
    except ValueError:
        pytest.skip("Magnus methods apply to generators of t only (tests/methods/test_magnus.py)")
    sol = lieint.integrate(TOP, Y0, (0.0, 1.0), h=0.01, method=method, rtol=1e-10, atol=1e-12, t_eval=t_eval)
    assert np.array_equal(sol.t, t_eval)
    exact = TOP.exact_solution(t_eval, Y0)["A"]
    order = lieint.methods.registry.method_specs()[method].order or 5
    tol = {1: 0.02, 2: 1e-3}.get(order, 1e-5)  # an O(h^p) error at h = 0.01
    assert np.max(np.abs(sol.states["A"] - exact)) < tol
    assert sol.invariants["energy"].shape == (7,)


def test_dense_output_is_refused_outside_the_span():
    sol = lieint.integrate(TOP, Y0, (0.0, 1.0), h=0.1, dense_output=True)
    with pytest.raises(ValueError, match="integrated span"):
        sol.sol(1.5)
    assert lieint.integrate(TOP, Y0, (0.0, 1.0), h=0.1, backend="numpy").sol is None


def middle_axis_rate(t, y):
    """w₂, the angular velocity about the middle principal axis: it changes sign at each flip."""
    return vee(TOP.P.T @ TOP.angular_velocity(y["A"]) @ TOP.P)[1]


def test_first_ten_flips_of_the_dzhanibekov_top():
    w0 = [0.01, 1.0, 0.01]
    y0 = TOP.initial_state(angular_velocity=w0)
    exact = euler_top_flip_times([1.0, 2.0, 3.0], w0, 200.0)
    assert exact.size >= 10
    # rtol 1e-14: with DOP853's estimate the pair takes scipy's steps, and near the separatrix its
    # energy error (the Casimir kept) shifts the flips ~15× more per rtol than DOP853's (docs/theory.md
    # §13, docs/measurements/adaptive.md); 1e-12 gave 2.5e-7 s at the tenth flip
    sol = lieint.integrate(TOP, y0, (0.0, 200.0), method="rkmk853", rtol=1e-14, atol=1e-17, events=middle_axis_rate)
    found = sol.t_events[0]
    assert found.size == exact.size
    assert np.max(np.abs(found[:10] - exact[:10])) <= 1e-8
    # the event states lie on the group and have w₂ = 0
    R = sol.y_events[0]["R"]
    assert np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max() <= 1e-13
    assert all(abs(middle_axis_rate(0.0, {"A": A})) < 1e-10 for A in sol.y_events[0]["A"])


def scipy_event(fn, layout):
    """The same event for scipy's flat vector, with its settings."""

    def wrapped(t, z):
        return fn(t, layout.unpack(z))

    wrapped.terminal = getattr(fn, "terminal", False)
    wrapped.direction = getattr(fn, "direction", 0.0)
    return wrapped


@pytest.mark.parametrize("method", ["rkmk4", "rk4", "rkmk45", "scipy:RK45"])
def test_terminal_and_direction_as_in_scipy(method):
    """The same events as scipy's solve_ivp on the embedded equations (to the accuracy of both)."""

    def up(t, y):
        return y["A"][0, 1] - 1.5

    up.direction = 1.0

    def down(t, y):
        return y["A"][0, 1] - 1.5

    down.direction = -1.0
    down.terminal = 2

    layout = StateLayout(Y0)
    ref = solve_ivp(
        lambda t, z: layout.pack(TOP.vector_field(t, layout.unpack(z))),
        (0.0, 40.0),
        layout.pack(Y0),
        method="DOP853",
        rtol=1e-12,
        atol=1e-14,
        events=[scipy_event(up, layout), scipy_event(down, layout)],
    )
    assert ref.status == 1 and ref.t_events[1].size == 2 and ref.t_events[0].size >= 1
    sol = lieint.integrate(TOP, Y0, (0.0, 40.0), h=0.01, method=method, rtol=1e-10, atol=1e-12, events=[up, down])
    assert sol.success and "terminal event" in sol.message
    for found, expected in zip(sol.t_events, ref.t_events, strict=True):
        assert found.shape == expected.shape
        assert np.max(np.abs(found - expected)) < 1e-6
    # the run ends at the terminal event, on the event's state
    assert sol.t[-1] == sol.t_events[1][-1] and np.all(np.diff(sol.t) > 0)
    assert sol.states["A"][-1][0, 1] == pytest.approx(1.5, abs=1e-11)
    assert sol.y_events[1]["A"].shape == (2, 3, 3)


def test_bad_events_are_refused():
    with pytest.raises(TypeError, match="`events`"):
        lieint.integrate(TOP, Y0, (0.0, 1.0), h=0.1, events=3)

    def g(t, y):
        return 1.0

    g.terminal = "yes"
    with pytest.raises(ValueError, match="terminal"):
        lieint.integrate(TOP, Y0, (0.0, 1.0), h=0.1, events=g)
    batch = TOP.initial_state(angular_velocity=[[0.3, 1.0, 0.4], [0.1, 1.0, 0.2]])
    with pytest.raises(ValueError, match="one number"):
        lieint.integrate(TOP, batch, (0.0, 1.0), h=0.1, events=lambda t, y: y["A"][..., 0, 1])


def test_watched_runs_stay_compiled_and_evaluate_only_the_interpolants_they_use():
    """Dense output, events and t_eval run on the compiled engine; the generic path's observer
    evaluates ξ at every step's end (one per step), the engine's only at the ends of the steps
    whose interpolant is asked for (here the two steps holding 0.45 and 1.0 is a step end)."""
    sol = lieint.integrate(TOP, Y0, (0.0, 1.0), h=0.1, backend="numba", t_eval=[0.0, 0.45, 1.0])
    assert sol.stats.backend == "numba"
    plain = lieint.integrate(TOP, Y0, (0.0, 1.0), h=0.1, backend="numpy")
    generic = lieint.integrate(TOP, Y0, (0.0, 1.0), h=0.1, backend="numpy", t_eval=[0.0, 0.45, 1.0])
    assert generic.nfev == plain.nfev + plain.nsteps + 1  # one extra evaluation per step
    assert sol.nfev == plain.nfev + 2  # the two ends of the one step interpolated
    np.testing.assert_allclose(sol.states["A"], generic.states["A"], rtol=0, atol=1e-14)
