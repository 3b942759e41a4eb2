"""Backward integration, ``t_span = (t0, t1)`` with ``t1 < t0``, for every method of the registry.

Truths that do not depend on lieint's integrators: the free top's exact solution (Jacobi elliptic
functions, ``EulerTop.exact_solution``) and exact flip times (``euler_top_flip_times``); a closed-form
prescribed rotation; the flow property ``φ₋ₜ ∘ φₜ = id`` (a run forward to T and back to 0 returns
to y0 up to the method's error, to round-off for a symmetric method, whose step map of −h is the
inverse of that of h); and scipy's own ``solve_ivp`` on the top's equations written out by hand
(the direction of a crossing in a backward run).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from conftest import EVERY_FORM, fitted_slope
from scipy.integrate import solve_ivp
from scipy.linalg import expm

import lieint
from lieint.groups.bivectors import hat
from lieint.methods.registry import method_specs
from lieint.systems.euler_top_exact import euler_top_flip_times
from lieint.systems.surfaces import Sphere

MOMENTS = np.array([1.0, 2.0, 3.0])
TOP = lieint.EulerTop.from_principal_moments(MOMENTS)
Y0 = TOP.initial_state(angular_velocity=[0.3, 1.0, 0.4])
T = 2.0
SPECS = method_specs()

# -- the systems of the methods that do not step the top ------------------------------------------

# R(t) = exp(a(t) Â) exp(b(t) B̂): body rate Ω = RᵀṘ = exp(−bB̂) ȧÂ exp(bB̂) + ḃB̂ (non-autonomous)
A_HAT, B_HAT = hat(np.array([0.3, -0.5, 0.8])), hat(np.array([0.6, 0.2, -0.4]))


def prescribed_exact(t: float) -> dict:
    return {"R": expm((0.7 * np.sin(t) + 0.3 * t) * A_HAT) @ expm(0.5 * t * t * B_HAT)}


def prescribed_rate(t):
    E = expm(0.5 * t * t * B_HAT)
    return E.T @ ((0.7 * np.cos(t) + 0.3) * A_HAT) @ E + t * B_HAT


PRESCRIBED = lieint.PrescribedRotation(prescribed_rate)
SPHERE = lieint.SurfaceParticle(1.0, Sphere(3))
OSCILLATOR = lieint.CentralForceParticle(1.0, [0.0, 0.0], "harmonic", strength=4.0)


def system_of(name: str):
    """``(system, y0)`` a method of the registry steps here."""
    if name.startswith("magnus"):
        return PRESCRIBED, PRESCRIBED.initial_state()
    if name == "rattle":
        return SPHERE, SPHERE.initial_state(position=[1.0, 0.0, 0.0], velocity=[0.0, 0.8, 0.3])
    if name == "verlet":
        return OSCILLATOR, OSCILLATOR.initial_state(position=[1.0, 0.0], velocity=[0.0, 0.5])
    return TOP, Y0


def exact_top(times, y0: dict = Y0) -> dict:
    """The top's exact states (A, R) at ``times`` from ``y0`` (Jacobi elliptic functions)."""
    exact = TOP.exact_solution(np.asarray(times, dtype=float), y0)
    return {"A": exact["A"], "R": exact["R"]}


def exact_at(name: str, t: float) -> dict:
    if name.startswith("magnus"):
        return prescribed_exact(t)
    assert system_of(name)[0] is TOP, name
    return {k: v[0] for k, v in exact_top([t]).items()}


def kind(name: str) -> str:
    method = lieint.get_method(name)
    if method.self_controlled:
        return "scipy"
    return "adaptive" if SPECS[name].adaptive else "fixed"


#: the step maps that are their own adjoint, Φ₋ₕ = Φₕ⁻¹: Moser–Veselov's discrete Lagrangian
#: maps and their symmetric compositions, the Lie–Poisson midpoint, the symmetric (Strang and
#: composed) splittings, the Gauss–Magnus integrators, RATTLE and Störmer–Verlet; and the exact flow
SYMMETRIC = {
    "exact_flow", "lie_midpoint", "moser_veselov", "moser_veselov4", "moser_veselov_composed4",
    "moser_veselov6", "moser_veselov_composed6", "moser_veselov8", "moser_veselov10",
    "splitting2", "splitting4", "splitting6", "magnus4", "magnus6", "rattle", "verlet",
}  # fmt: skip
FIXED = [n for n in lieint.method_names() if kind(n) == "fixed"]
ADAPTIVE = [n for n in lieint.method_names() if kind(n) != "fixed"]


def last(sol) -> dict:
    return {k: v[-1] for k, v in sol.states.items()}


def distance(a: dict, b: dict) -> float:
    return max(float(np.abs(np.asarray(a[k]) - np.asarray(b[k])).max()) for k in b)


def on_group(system, y: dict) -> dict:
    """The state as a start (methods on the embedding space leave R off SO(3) by their error)."""
    return system.project(y) if system is TOP else y


def round_trip(name: str, T_end: float = T, **options):
    """The forward run to T, and the backward run from its end state to 0."""
    system, y0 = system_of(name)
    forward = lieint.integrate(system, y0, (0.0, T_end), method=name, **options)
    backward = lieint.integrate(system, on_group(system, last(forward)), (T_end, 0.0), method=name, **options)
    return forward, backward


def test_every_method_of_the_registry_is_checked_here():
    """A method added to the registry lands in one of the groups below (or this fails)."""
    for name in lieint.method_names():
        lieint.get_method(name).check_system(system_of(name)[0])  # raises if the method does not step it
        assert name in FIXED or name in ADAPTIVE
    assert SYMMETRIC <= set(FIXED)


@pytest.mark.parametrize("name", [n for n in FIXED if n in SYMMETRIC])
def test_a_symmetric_method_runs_back_to_y0_to_round_off(name):
    """Φ₋ₕ ∘ Φₕ = id: forward 40 steps and back returns to y0 within round-off, while the
    run's own error (methods of order ≤ 6, measurable at this step) is orders larger."""
    y0 = system_of(name)[1]
    forward, backward = round_trip(name, h=0.05, backend="numpy")
    assert np.all(np.diff(backward.t) < 0) and backward.t[0] == T and backward.t[-1] == 0.0
    assert backward.success and backward.status == 0 and backward.stats.nsteps == 40
    assert distance(last(backward), y0) <= 2e-14, distance(last(backward), y0)
    order = lieint.get_method(name).order
    if order is not None and order <= 6 and system_of(name)[0] in (TOP, PRESCRIBED):  # exact solutions
        assert distance(last(forward), exact_at(name, T)) > 1e-12


@pytest.mark.parametrize("name", [n for n in FIXED if n not in SYMMETRIC])
def test_a_fixed_step_method_runs_back_to_y0_to_its_order(name):
    """Forward to T and back: the distance to y0 is the size of the forward run's own error
    against the exact solution, and falls with h at least as the method's order p (p + 1 for
    even p: the leading error terms of Φₕ and Φ₋ₕ cancel when p is even)."""
    p = lieint.get_method(name).order
    hs = [0.1, 0.05] if p <= 4 else [0.2, 0.1]
    trips, errors = [], []
    for h in hs:
        forward, backward = round_trip(name, h=h, backend="numpy")
        assert backward.t[0] == T and backward.t[-1] == 0.0
        np.testing.assert_allclose(backward.t, T - h * np.arange(backward.t.size), rtol=0, atol=1e-14)
        trips.append(distance(last(backward), system_of(name)[1]))
        errors.append(distance(last(forward), exact_at(name, T)))
    assert trips[-1] <= 10 * errors[-1], (trips, errors)
    assert trips[-1] >= 1e-3 * errors[-1]  # not symmetric: the round trip has an error of its own
    assert fitted_slope(hs, trips) >= p - 0.3, (trips, fitted_slope(hs, trips))


@pytest.mark.parametrize("name", ADAPTIVE)
def test_an_adaptive_method_runs_back_to_y0_to_its_tolerance(name):
    """Forward to T and back at rtol 1e-8: y0 again within the forward run's own error level
    (10× its distance to the exact solution, and 100 rtol), the steps negative and landing on 0."""
    rtol = 1e-8
    forward, backward = round_trip(name, rtol=rtol, atol=1e-10)
    assert backward.success and backward.status == 0
    assert backward.t[0] == T and backward.t[-1] == 0.0 and np.all(np.diff(backward.t) < 0)
    trip = distance(last(backward), Y0)
    error = distance(last(forward), exact_at(name, T))
    assert trip <= max(10 * error, 10 * rtol) and trip <= 100 * rtol, (trip, error)


def test_a_backward_run_from_the_exact_state_meets_the_exact_solution():
    """Not only a round trip: from the exact y(T), the backward run's rows are the exact
    solution at their times (rkmk4, global error ~ h⁴), on both paths."""
    yT = exact_at("rkmk4", T)
    for backend in ("auto", "numpy"):
        sol = lieint.integrate(TOP, yT, (T, 0.0), h=0.01, method="rkmk4", backend=backend)
        exact = exact_top(sol.t)
        assert max(float(np.abs(sol.states[k] - exact[k]).max()) for k in exact) < 1e-9
        assert sol.stats.backend == ("numba" if backend == "auto" else "numpy")


# -- the compiled engine and the numpy path ----------------------------------------------------------


def compiled_names() -> list[str]:
    names = []
    for name in lieint.method_names():
        form = lieint.get_method(name).compiled()
        if getattr(form, "family", None) in EVERY_FORM and system_of(name)[0] is TOP:
            names.append(name)
    return names


@pytest.mark.parametrize("name", compiled_names())
def test_the_compiled_engine_and_the_numpy_path_agree_backward(name):
    """The same steps backward on both paths. Fixed steps: the same rows to round-off. Adaptive:
    the same accepted, rejected and evaluation counts and the same end state at the tolerance;
    the step times themselves may differ by more (forward as well: rkmk853 by 1e-7 at rtol 1e-9
    here) because the first steps' error estimates sit at round-off (the step grows by the
    controller's largest factor) and each path rounds them differently."""
    adaptive = kind(name) != "fixed"
    options = {"rtol": 1e-9, "atol": 1e-12} if adaptive else {"h": 0.02}
    yT = exact_at("rkmk4", T)
    fast = lieint.integrate(TOP, yT, (T, 0.0), method=name, **options)
    slow = lieint.integrate(TOP, yT, (T, 0.0), method=name, backend="numpy", **options)
    assert fast.stats.backend == "numba" and slow.stats.backend == "numpy"
    counts = (fast.stats.nsteps, fast.stats.nrejected, fast.nfev)
    assert counts == (slow.stats.nsteps, slow.stats.nrejected, slow.nfev)
    assert fast.t[-1] == slow.t[-1] == 0.0 and fast.t.shape == slow.t.shape
    if adaptive:
        assert distance(last(fast), last(slow)) <= 100 * options["rtol"]
    else:
        np.testing.assert_array_equal(fast.t, slow.t)
        for k in slow.states:
            np.testing.assert_allclose(fast.states[k], slow.states[k], rtol=0, atol=1e-13)


# -- t_eval, save_every, dense output --------------------------------------------------------------------


T_EVAL_CASES = [("rkmk4", "auto"), ("rkmk4", "numpy"), ("rkmk45", "auto"), ("rkmk45", "numpy"), ("splitting4", "numpy"),
                ("scipy:DOP853", "auto")]  # fmt: skip


@pytest.mark.parametrize(("name", "backend"), T_EVAL_CASES)
def test_t_eval_decreasing_inside_a_backward_span(name, backend):
    """Decreasing times inside (T, 0), as scipy: the rows at those times and only those, the
    exact solution there to the method's error."""
    t_eval = np.array([1.9, 1.3, 0.75, 0.2])
    options = {"h": 0.01} if kind(name) == "fixed" else {"rtol": 1e-10, "atol": 1e-12}
    sol = lieint.integrate(TOP, exact_at("rkmk4", T), (T, 0.0), method=name, t_eval=t_eval, backend=backend, **options)
    assert np.array_equal(sol.t, t_eval) and sol.states["A"].shape == (4, 3, 3)
    exact = exact_top(t_eval)
    assert max(float(np.abs(sol.states[k] - exact[k]).max()) for k in exact) < 1e-8


def test_t_eval_in_the_wrong_order_or_outside_the_span_is_refused():
    yT = exact_at("rkmk4", T)
    with pytest.raises(ValueError, match=r"`t_eval` must decrease strictly \(t1 < t0: a run backward in time\)"):
        lieint.integrate(TOP, yT, (T, 0.0), h=0.1, t_eval=[0.5, 1.0])
    with pytest.raises(ValueError, match=r"`t_eval` must increase strictly; got t_eval\[0\] = 1.0 followed by 0.5"):
        lieint.integrate(TOP, Y0, (0.0, T), h=0.1, t_eval=[1.0, 0.5])
    with pytest.raises(ValueError, match=r"`t_eval` must lie inside t_span = \(2.0, 0.0\)"):
        lieint.integrate(TOP, yT, (T, 0.0), h=0.1, t_eval=[2.5, 1.0])
    with pytest.raises(ValueError, match=r"must have t1 != t0"):
        lieint.integrate(TOP, Y0, (1.0, 1.0), h=0.1)


def test_a_negative_h_is_refused_with_the_way_to_go_backward():
    with pytest.raises(ValueError, match=r"`h` must be a positive finite number; got -0.1\. .*t_span=\(2.0, 0.0\)"):
        lieint.integrate(TOP, Y0, (0.0, T), h=-0.1)


@pytest.mark.parametrize("backend", ["auto", "numpy"])
def test_save_every_backward(backend):
    """Every k-th row of the backward grid t = T − j h and the last, the same rows as without."""
    yT = exact_at("rkmk4", T)
    every = lieint.integrate(TOP, yT, (T, 0.0), h=0.03, save_every=7, backend=backend)
    all_rows = lieint.integrate(TOP, yT, (T, 0.0), h=0.03, backend=backend)
    n = all_rows.t.size - 1  # 67 steps: 66 of 0.03 and a last one of 0.02
    assert n == 67 and all_rows.t[-1] == 0.0 and np.isclose(all_rows.t[-2] - all_rows.t[-1], 0.02)
    picks = [*range(0, n + 1, 7), n]
    np.testing.assert_array_equal(every.t, all_rows.t[picks])
    np.testing.assert_array_equal(every.states["R"], all_rows.states["R"][picks])


DENSE_CASES = [
    ("rkmk4", "auto"), ("rkmk4", "numpy"), ("rkmk853", "auto"), ("moser_veselov", "numpy"), ("lie_midpoint", "numpy"),
    ("rkmk45+energy", "numpy"), ("rk4", "auto"), ("scipy:RK45", "auto"),
]  # fmt: skip


@pytest.mark.parametrize(("name", "backend"), DENSE_CASES)
def test_dense_output_on_a_decreasing_grid(rng, name, backend):
    """sol.sol(t) of a backward run: the exact solution at random times inside [0, T] as well as
    the forward run's dense output (within 5×), on the group, the step ends returned as saved,
    times outside refused."""
    options = {"h": 0.01} if kind(name) == "fixed" else {"rtol": 1e-10, "atol": 1e-12}
    times = rng.uniform(0.0, T, 300)
    exact = exact_top(times)
    runs = [
        lieint.integrate(TOP, start, span, method=name, dense_output=True, backend=backend, **options)
        for start, span in ((Y0, (0.0, T)), (exact_at("rkmk4", T), (T, 0.0)))
    ]
    forward, backward = (distance(run.sol(times), exact) for run in runs)
    assert backward <= 5 * max(forward, 1e-12), (backward, forward)
    # second order at h = 0.01; rkmk853's 8 steps, the first ones interpolated by curves of degree 3 and 5
    assert backward < {"moser_veselov": 3e-4, "lie_midpoint": 3e-4, "rkmk853": 1e-7}.get(name, 1e-8), backward
    sol = runs[1]
    if not name.startswith("scipy") and name != "rk4":  # on the group
        R = sol.sol(times)["R"]
        assert np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max() < 1e-13
        j = sol.t.size // 2
        assert np.array_equal(sol.sol(sol.t[j])["A"], sol.states["A"][j])
        with pytest.raises(ValueError, match=r"`t` must lie in the integrated span \[0.0, 2.0\]"):
            sol.sol(2.5)


# -- events -------------------------------------------------------------------------------------------

FLIP_W0 = [0.01, 1.0, 0.01]
FLIP_TOP_Y0 = TOP.initial_state(angular_velocity=FLIP_W0)


def flip(direction: float, terminal: bool = False):
    def g(t, y):
        return y["A"][0, 2]  # −I₂ Ω₁₃: zero with the middle-axis component w₂ (the flips)

    g.direction, g.terminal = direction, terminal
    return g


def euler_poisson_rhs(t, z):
    """The free top written out by hand, independently of lieint: ``A_ij = −I_k Ω_ij`` for
    {i, j, k} = {1, 2, 3}, ``Ȧ = [A, Ω]``, ``Ṙ = R Ω``, on ``z = (A.ravel(), R.ravel())``."""
    I1, I2, I3 = MOMENTS
    pair = np.array([[1.0, I3, I2], [I3, 1.0, I1], [I2, I1, 1.0]])
    A, R = z[:9].reshape(3, 3), z[9:].reshape(3, 3)
    Omega = -A / pair
    return np.concatenate([(A @ Omega - Omega @ A).ravel(), (R @ Omega).ravel()])


@pytest.mark.parametrize("backend", ["auto", pytest.param("numpy", marks=pytest.mark.slow)])
def test_events_backward_are_the_forward_ones_met_in_reverse(backend):
    """Forward to 60 and back from there: the three flips at the exact times, met in reverse
    order; a crossing's direction is read in the run's order (scipy's), so the backward run's
    rising crossings are the forward run's falling ones and vice versa."""
    exact = euler_top_flip_times(MOMENTS, FLIP_W0, 60.0)
    options = {"h": 0.005, "method": "rkmk4", "backend": backend}
    forward = lieint.integrate(TOP, FLIP_TOP_Y0, (0.0, 60.0), events=[flip(1.0), flip(-1.0), flip(0.0)], **options)
    yT = last(forward)
    backward = lieint.integrate(TOP, yT, (60.0, 0.0), events=[flip(1.0), flip(-1.0), flip(0.0)], **options)
    assert backward.stats.backend == ("numba" if backend == "auto" else "numpy")
    np.testing.assert_allclose(np.sort(forward.t_events[2]), exact, rtol=0, atol=1e-6)
    np.testing.assert_allclose(backward.t_events[2], exact[::-1], rtol=0, atol=1e-6)
    assert forward.t_events[0].size and forward.t_events[1].size
    np.testing.assert_allclose(backward.t_events[0], forward.t_events[1][::-1], rtol=0, atol=1e-6)
    np.testing.assert_allclose(backward.t_events[1], forward.t_events[0][::-1], rtol=0, atol=1e-6)
    for i in range(3):  # the event states are the rows' states at those times
        assert np.abs(backward.y_events[i]["A"][:, 0, 2]).max() < 1e-10


def test_event_directions_backward_are_scipys():
    """scipy's solve_ivp on the hand-written equations, backward: the same crossings rising
    and falling as lieint's backward run (rkmk45, compiled), at the same times."""
    y_start = TOP.initial_state(angular_velocity=FLIP_W0)
    z0 = np.concatenate([y_start["A"].ravel(), y_start["R"].ravel()])

    def scipy_event(direction):
        def g(t, z):
            return z[2]

        g.direction = direction
        return g

    ref = solve_ivp(euler_poisson_rhs, (60.0, 0.0), z0, method="DOP853", rtol=1e-12, atol=1e-14,
                    events=[scipy_event(1.0), scipy_event(-1.0)])  # fmt: skip
    sol = lieint.integrate(TOP, y_start, (60.0, 0.0), method="rkmk853+energy", rtol=1e-11, atol=1e-13,
                           events=[flip(1.0), flip(-1.0)])  # fmt: skip
    assert ref.t_events[0].size >= 1 and ref.t_events[1].size >= 1
    for i in range(2):
        np.testing.assert_allclose(sol.t_events[i], ref.t_events[i], rtol=0, atol=1e-6)


@pytest.mark.parametrize(("name", "backend"), [("rkmk4", "auto"), ("rkmk4", "numpy"), ("rkmk45", "auto"),
                                               ("rkmk45", "numpy"), ("scipy:DOP853", "auto")])  # fmt: skip
def test_a_terminal_event_stops_a_backward_run(name, backend):
    """The run from 60 back stops at the last flip (the first met), status 1, its row last."""
    exact = euler_top_flip_times(MOMENTS, FLIP_W0, 60.0)
    y60 = {k: v[0] for k, v in exact_top([60.0], FLIP_TOP_Y0).items()}
    options = {"h": 0.005} if kind(name) == "fixed" else {"rtol": 1e-10, "atol": 1e-12, "max_step": 0.5}
    sol = lieint.integrate(TOP, y60, (60.0, 0.0), method=name, events=flip(0.0, terminal=True), backend=backend,
                           **options)  # fmt: skip
    assert sol.status == 1 and sol.success
    assert abs(sol.t[-1] - exact[-1]) < 1e-4 and sol.t[-1] == sol.t_events[0][0]
    assert np.all(np.diff(sol.t) < 0) and sol.t.min() == sol.t[-1]


@pytest.mark.parametrize("name", ["rkmk45", "rkmk853", "cf4", "rkmk4"])
def test_a_time_dependent_generator_backward(name):
    """The prescribed rotation (ξ depends on t): from the exact R(T) back to R(0) = I, each stage
    evaluated at its own (decreasing) time, to the method's error."""
    options = {"rtol": 1e-10, "atol": 1e-12} if kind(name) != "fixed" else {"h": 0.01}
    sol = lieint.integrate(PRESCRIBED, prescribed_exact(T), (T, 0.0), method=name, t_eval=[1.5, 0.5, 0.0], **options)
    for t, R in zip(sol.t, sol.states["R"], strict=True):
        assert np.abs(R - prescribed_exact(t)["R"]).max() < 1e-7, (t, name)
    assert sol.t.tolist() == [1.5, 0.5, 0.0]


def test_a_backward_run_is_not_warned_about_its_negative_step():
    """The step check reads |h|: a resolved backward run gives no LieStepWarning, an
    unresolved one does (h·|Ω| ≥ π)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lieint.integrate(TOP, exact_at("rkmk4", T), (T, 0.0), h=0.05)
    fast = TOP.initial_state(angular_velocity=[0.3, 40.0, 0.4])
    with pytest.warns(lieint.LieStepWarning):
        lieint.integrate(TOP, fast, (1.0, 0.0), h=0.1, method="rkmk4", coordinates="cayley")
