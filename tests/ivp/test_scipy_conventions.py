"""scipy's conventions in lieint.integrate: argument order, bare method names, t_eval inside the
span, first_step, status, and scipy's ``y`` layout checked against solve_ivp itself."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import lieint

SCIPY_NAMES = ["RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA"]
MOMENTS = np.array([1.0, 2.0, 3.0])
W0 = [0.3, 1.0, 0.4]


@pytest.fixture
def top():
    return lieint.EulerTop.from_principal_moments(MOMENTS)


@pytest.fixture
def y0(top):
    return top.initial_state(angular_velocity=W0)


def euler_poisson_rhs(t, z):
    """The free top's equations written out here, independently of lieint: with the documented
    convention ``A = −(BΩ + ΩB)``, B = diag(b), ``A_ij = −(b_i + b_j) Ω_ij = −I_k Ω_ij``;
    ``Ȧ = [A, Ω]``, ``Ṙ = R Ω``, on ``z = (A.ravel(), R.ravel())``."""
    A, R = z[:9].reshape(3, 3), z[9:].reshape(3, 3)
    Omega = -A / PAIR_MOMENTS
    return np.concatenate([(A @ Omega - Omega @ A).ravel(), (R @ Omega).ravel()])


#: I_k at the entry (i, j) of the pair {i, j, k} (the diagonal of a bivector is zero anyway)
PAIR_MOMENTS = np.array([[1.0, MOMENTS[2], MOMENTS[1]], [MOMENTS[2], 1.0, MOMENTS[0]], [MOMENTS[1], MOMENTS[0], 1.0]])


def test_the_hand_written_equations_are_the_tops(top, y0):
    # the reference above describes the same body as lieint's state
    z0 = np.concatenate([y0["A"].ravel(), y0["R"].ravel()])
    field = top.vector_field(0.0, y0)
    assert np.allclose(euler_poisson_rhs(0.0, z0), np.concatenate([field["A"].ravel(), field["R"].ravel()]), atol=1e-15)


# -- argument order and keywords ----------------------------------------------------------------


def test_keywords_in_any_order(top, y0):
    a = lieint.integrate(top, y0, (0.0, 1.0), 0.1, "rkmk4")
    b = lieint.integrate(method="rkmk4", h=0.1, t_span=(0.0, 1.0), y0=y0, system=top)
    assert np.array_equal(a.states["A"], b.states["A"]) and np.array_equal(a.t, b.t)


def test_scipy_positional_order_is_refused_with_what_to_do(top, y0):
    with pytest.raises(TypeError, match=r"takes \(system, y0, t_span\).*scipy's order.*Swap them"):
        lieint.integrate(top, (0.0, 5.0), y0)
    flat = np.concatenate([y0["A"].ravel(), y0["R"].ravel()])
    with pytest.raises(TypeError, match=r"got the time span \(0.0, 5.0\) second.*scipy's order"):
        lieint.integrate(top, (0.0, 5.0), flat)
    with pytest.raises(TypeError, match=r"lieint integrates systems, not a right-hand side fun\(t, y\)"):
        lieint.integrate(euler_poisson_rhs, (0.0, 5.0), flat)
    with pytest.raises(TypeError, match=r"`h` \(the 4th positional argument.*got 'RK45'.*method='RK45'"):
        lieint.integrate(top, y0, (0.0, 5.0), "RK45")


def test_a_fixed_step_method_without_h_says_how_to_choose(top, y0):
    with pytest.raises(ValueError, match=r"`h` \(the step size\) is required") as info:
        lieint.integrate(top, y0, (0.0, 5.0))
    text = str(info.value)
    assert "method='rkmk45'" in text and "'RK45'" in text and "halve it" in text
    # the fastest rotation at y0: |w| of this top's body angular velocity
    assert f"turns at {np.linalg.norm(W0):.3g} rad per unit time" in text


# -- bare scipy names ----------------------------------------------------------------------------


@pytest.mark.parametrize("name", SCIPY_NAMES)
def test_bare_scipy_names_are_the_scipy_methods(top, y0, name):
    kw = dict(t_span=(0.0, 2.0), h=0.5, rtol=1e-8, atol=1e-10)
    bare = lieint.integrate(top, y0, method=name, **kw)
    prefixed = lieint.integrate(top, y0, method=f"scipy:{name}", **kw)
    assert bare.method == f"scipy:{name}" and bare.success
    assert np.array_equal(bare.y, prefixed.y) and bare.nfev == prefixed.nfev
    assert lieint.get_method(name) is lieint.get_method(f"scipy:{name}")


def test_names_are_case_sensitive_as_scipys(top, y0):
    with pytest.raises(ValueError, match=r"unknown method 'rk45'.*scipy's also bare: 'RK45'"):
        lieint.integrate(top, y0, (0.0, 1.0), method="rk45")


# -- scipy's layout, against solve_ivp ------------------------------------------------------------


@pytest.mark.parametrize("name", ["RK45", "DOP853", "Radau"])
def test_y_is_solve_ivps_y_on_the_same_equations(top, y0, name):
    t_eval = np.linspace(0.5, 7.5, 15)
    kw = dict(method=name, t_eval=t_eval, rtol=1e-9, atol=1e-11)
    sol = lieint.integrate(top, y0, (0.0, 8.0), **kw)
    ref = solve_ivp(euler_poisson_rhs, (0.0, 8.0), np.concatenate([y0["A"].ravel(), y0["R"].ravel()]), **kw)
    assert ref.success and sol.status == ref.status == 0
    assert np.array_equal(sol.t, ref.t)
    assert sol.y.shape == ref.y.shape == (18, 15)
    # the same solver on the same equations: identical up to the round-off of the two right-hand sides
    assert np.max(np.abs(sol.y - ref.y)) < 1e-11


def test_y_of_a_lie_group_method_agrees_with_solve_ivp(top, y0):
    t_eval = [1.0, 2.5, 6.0]
    sol = lieint.integrate(top, y0, (0.0, 6.0), method="rkmk853", rtol=1e-12, atol=1e-14, t_eval=t_eval)
    z0 = np.concatenate([y0["A"].ravel(), y0["R"].ravel()])
    ref = solve_ivp(euler_poisson_rhs, (0.0, 6.0), z0, method="DOP853", rtol=1e-13, atol=1e-15, t_eval=t_eval)
    assert np.max(np.abs(sol.y - ref.y)) < 1e-9


def test_y_layout_of_an_ensemble(top, rng):
    y0 = top.initial_state(angular_velocity=rng.normal(size=(2, 3)))
    sol = lieint.integrate(top, y0, (0.0, 1.0), h=0.25, method="rkmk4")
    y = sol.y
    assert y.shape == (2 * 9 + 2 * 9, 5)
    for k in range(sol.t.size):  # fields in order, each flattened over (*batch, n, n) in C order
        assert np.array_equal(y[:18, k], sol.states["A"][k].ravel())
        assert np.array_equal(y[18:, k], sol.states["R"][k].ravel())
        assert np.array_equal(y[9:18, k], sol.states["A"][k, 1].ravel())


# -- t_eval inside the span -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("method", "kw", "tol"),
    [
        ("rkmk4", {"h": 0.01}, 1e-7),
        ("rkmk45", {"rtol": 1e-10, "atol": 1e-12}, 1e-7),
        ("rkmk853+energy", {"rtol": 1e-10, "atol": 1e-12}, 1e-7),
        ("moser_veselov", {"h": 0.005}, 1e-4),
        ("RK45", {"rtol": 1e-10, "atol": 1e-12}, 1e-7),
        ("LSODA", {"rtol": 1e-10, "atol": 1e-12}, 1e-6),
    ],
)
def test_t_eval_inside_the_span(top, y0, method, kw, tol):
    t_eval = np.array([1.0, 2.0, 2.5, 3.0])
    sol = lieint.integrate(top, y0, (0.0, 5.0), method=method, t_eval=t_eval, **kw)
    assert sol.success and sol.status == 0
    assert np.array_equal(sol.t, t_eval)
    exact = top.exact_solution(t_eval, y0)
    assert np.max(np.abs(sol.states["A"] - exact["A"])) < tol
    assert np.max(np.abs(sol.states["R"] - exact["R"])) < 10 * tol
    assert sol.invariants["energy"].shape == (4,)


def test_t_eval_ending_at_t1_or_starting_at_t0(top, y0):
    for t_eval in ([0.0, 1.0], [4.0, 5.0], [5.0], [0.0]):
        for method in ("rkmk45", "RK45"):
            sol = lieint.integrate(top, y0, (0.0, 5.0), method=method, t_eval=t_eval, rtol=1e-10, atol=1e-12)
            assert np.array_equal(sol.t, t_eval)
            assert np.allclose(sol.states["A"], top.exact_solution(sol.t, y0)["A"], atol=1e-7)
            if t_eval[0] == 0.0:
                assert np.array_equal(sol.states["A"][0], y0["A"])


@pytest.mark.parametrize("method", ["rkmk45", "rkmk4", "RK45"])
def test_t_eval_with_a_terminal_event_keeps_only_t_eval_rows(top, y0, method):
    def flip(t, y):
        return y["A"][0, 2]  # the middle component of the body momentum

    flip.terminal = True
    sol = lieint.integrate(
        top, top.initial_state(angular_velocity=[0.01, 1.0, 0.01]), (0.0, 50.0), method=method, h=0.01,
        events=flip, t_eval=np.arange(1.0, 21.0),
    )  # fmt: skip
    t_flip = sol.t_events[0][0]
    assert 10.0 < t_flip < 11.0 and sol.status == 1
    assert np.array_equal(sol.t, np.arange(1.0, 11.0))  # as solve_ivp: t_eval rows before the event


@pytest.mark.parametrize(
    ("t_eval", "match"),
    [
        ([1.0, 6.0], r"`t_eval` must lie inside t_span = \(0.0, 5.0\); got times from 1.0 to 6.0"),
        ([-0.5, 1.0], r"must lie inside t_span"),
        ([1.0, 3.0, 2.0], r"`t_eval` must increase strictly; got t_eval\[1\] = 3.0 followed by 2.0"),
        ([1.0, 1.0], r"must increase strictly"),
        ([], r"at least one finite time"),
        ([[1.0, 2.0]], r"1-D array"),
        ([1.0, np.nan], r"finite"),
        ("later", r"`t_eval` must be a 1-D array of times"),
    ],
)
def test_bad_t_eval(top, y0, t_eval, match):
    for method in ("rkmk45", "RK45"):
        with pytest.raises(ValueError, match=match):
            lieint.integrate(top, y0, (0.0, 5.0), method=method, t_eval=t_eval)


# -- first_step ------------------------------------------------------------------------------------


def test_first_step_is_the_first_trial_step_of_lieint_pairs(top, y0):
    for method in ("rkmk45", "rkmk23+energy"):
        a = lieint.integrate(top, y0, (0.0, 3.0), method=method, first_step=1e-3)
        b = lieint.integrate(top, y0, (0.0, 3.0), method=method, h=1e-3)
        c = lieint.integrate(top, y0, (0.0, 3.0), method=method)
        assert np.array_equal(a.t, b.t) and np.array_equal(a.states["A"], b.states["A"])
        assert a.t[1] == pytest.approx(1e-3)  # the first step, accepted as it is
        assert c.t[1] != a.t[1]


def test_first_step_reaches_scipys_solver(top, y0):
    z0 = np.concatenate([y0["A"].ravel(), y0["R"].ravel()])
    for first in (1e-4, 0.3):
        sol = lieint.integrate(top, y0, (0.0, 3.0), method="RK45", first_step=first, rtol=1e-6, atol=1e-9)
        ref = solve_ivp(euler_poisson_rhs, (0.0, 3.0), z0, method="RK45", first_step=first, rtol=1e-6, atol=1e-9)
        # the same steps (to the round-off of the two right-hand sides, which the error norms see)
        assert sol.t.size == ref.t.size and np.allclose(sol.t, ref.t, rtol=1e-7, atol=0)
        assert sol.t[1] == pytest.approx(ref.t[1], rel=1e-12)  # 1e-4 is taken as it is, 0.3 rejected first
        assert (sol.t[1] == first) == (first < 0.1)
        default = lieint.integrate(top, y0, (0.0, 3.0), method="RK45", rtol=1e-6, atol=1e-9)
        assert default.t[1] != pytest.approx(sol.t[1], rel=1e-3)  # scipy's own estimate is another


@pytest.mark.parametrize(
    ("kw", "exc", "match"),
    [
        ({"method": "rkmk45", "first_step": 0.0}, ValueError, r"`first_step` must be a positive finite number"),
        ({"method": "RK45", "first_step": -1e-3}, ValueError, r"`first_step` must be a positive finite number"),
        ({"method": "rkmk45", "first_step": "small"}, TypeError, r"`first_step` must be a positive finite number"),
        ({"method": "rkmk45", "first_step": 6.0}, ValueError, r"must not exceed the span t1 - t0 = 5"),
        ({"method": "rkmk45", "first_step": 0.1, "h": 0.2}, ValueError, r"`h` = 0.2 and `first_step` = 0.1 both"),
        ({"method": "rkmk4", "first_step": 0.1}, ValueError, r"`first_step` applies to adaptive methods; 'rkmk4'"),
    ],
)
def test_bad_first_step(top, y0, kw, exc, match):
    with pytest.raises(exc, match=match):
        lieint.integrate(top, y0, (0.0, 5.0), **kw)


def test_tolerances_are_scalars_and_the_message_says_so(top, y0):
    for name in ("rtol", "atol"):
        with pytest.raises(TypeError, match=rf"`{name}` must be one positive number \(per-component tolerances"):
            lieint.integrate(top, y0, (0.0, 1.0), method="RK45", **{name: np.full(18, 1e-8)})


# -- status ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("method", ["rkmk4", "rkmk45", "moser_veselov", "RK45"])
def test_status_of_a_finished_run_and_of_a_terminal_event(top, method):
    y0 = top.initial_state(angular_velocity=[0.01, 1.0, 0.01])
    done = lieint.integrate(top, y0, (0.0, 5.0), method=method, h=0.01)
    assert (done.status, done.success) == (0, True)

    def flip(t, y):
        return y["A"][0, 2]

    flip.terminal = True
    stopped = lieint.integrate(top, y0, (0.0, 50.0), method=method, h=0.01, events=flip)
    assert (stopped.status, stopped.success) == (1, True) and stopped.t[-1] == stopped.t_events[0][0] < 50.0
    flip.terminal = False  # an event that does not stop the run
    passed = lieint.integrate(top, y0, (0.0, 12.0), method=method, h=0.01, events=flip)
    assert passed.status == 0 and passed.t_events[0].size == 1


def test_status_of_a_failure():
    top = lieint.EulerTop(np.diag([1e-12, 1.0, 1.0]))
    y0 = top.initial_state(angular_velocity=[10.0, 10.0, 10.0])
    with pytest.warns(lieint.LieStepWarning):
        sol = lieint.integrate(top, y0, (0, 100), h=1.0, method="rk4")
    assert (sol.status, sol.success) == (-1, False) and "non-finite" in sol.message
    with pytest.warns(lieint.LieStepWarning):  # a failure before a terminal event stays a failure
        sol = lieint.integrate(top, y0, (0, 100), h=1.0, method="rk4", events=lambda t, y: 1.0)
    assert sol.status == -1
    assert "status=-1" in repr(sol)
