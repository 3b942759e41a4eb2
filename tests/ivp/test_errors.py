"""Bad input gets a clear error naming the argument, the expectation and what was received."""

import numpy as np
import pytest

import lieint
from lieint.groups import hat


@pytest.fixture
def top():
    return lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])


@pytest.fixture
def y0(top):
    return top.initial_state(angular_velocity=[0.1, 1.0, 0.1])


@pytest.mark.parametrize(
    ("B", "match"),
    [
        ([[1.0, 0.5], [0.0, 1.0]], r"`B` must be symmetric .* got max \|B - Bᵀ\| = 0.5"),
        (np.diag([1.0, -1.0, 2.0]), r"`B` must have b_i \+ b_j > 0 for every pair .* got eigenvalues \[-1, 1, 2\]"),
        (np.diag([0.0, 0.0, 1.5]), r"at most one zero eigenvalue; got eigenvalues \[0, 0, 1.5\] \(a rod"),
        (np.diag([1.0, np.nan, 1.0]), r"`B` must be finite; got nan at index \(1, 1\)"),
        (np.ones((2, 3)), r"`B` must have shape \(\.\.\., n, n\); got shape \(2, 3\)"),
        (np.ones((2, 3, 3)), r"`B` must be one \(n, n\) mass tensor; got shape \(2, 3, 3\)"),
        ("abc", r"`B` must be an array of real numbers; got dtype <U3"),
        ([[1.0]], r"n >= 2"),
    ],
)
def test_bad_mass_tensor(B, match):
    with pytest.raises((ValueError, TypeError), match=match):
        lieint.EulerTop(B)


def test_flat_body_is_fine_but_not_a_physical_violation():
    lieint.EulerTop(np.diag([0.0, 1.0, 2.0]))  # a plate: one zero eigenvalue
    # the free top takes any positive moments (tests/systems/test_euler_top_moments.py); a heavy top needs a body
    with pytest.raises(ValueError, match="triangle inequality"):
        lieint.HeavyTop.lagrange(1.0, 3.0, mass=1.0, length=1.0)
    with pytest.raises(ValueError, match=r"`moments` must be three principal moments"):
        lieint.EulerTop.from_principal_moments([1.0, 2.0])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"Omega": np.ones((3, 3))}, r"`Omega` must be skew-symmetric .* got max \|X \+ X\^T\| = 2"),
        ({"A": np.eye(3)}, r"`A` must be skew-symmetric"),
        ({"Omega": np.zeros((4, 4))}, r"`Omega` must have shape \(\.\.\., 3, 3\) for this system of dimension n = 3"),
        ({"angular_velocity": [1.0, np.inf, 0.0]}, r"`angular_velocity` must be finite; got inf at index \(1,\)"),
        ({"angular_velocity": [1.0, 0.0, 0.0], "R": np.diag([1.0, 1.0, -1.0])}, r"det R = \+1; got det R = -1"),
        ({"angular_velocity": [1.0, 0.0, 0.0], "R": 2 * np.eye(3)}, r"`R` must be a rotation in SO\(3\)"),
        (
            {"angular_velocity": [1, 0, 0], "Omega": hat([1, 0, 0])},
            r"exactly one of `Omega`, `A` or `angular_velocity`",
        ),
        ({}, r"exactly one of .* got none"),
        (
            {"angular_velocity": np.zeros((2, 3)), "R": np.broadcast_to(np.eye(3), (3, 3, 3))},
            r"Batch shapes of `angular_velocity` \(2,\) and `R` \(3,\) do not broadcast",
        ),
    ],
)
def test_bad_initial_state(top, kwargs, match):
    with pytest.raises(ValueError, match=match):
        top.initial_state(**kwargs)


@pytest.mark.parametrize(
    ("defect", "match"),
    [
        (np.diag([1.0, 1.0, -1.0]), r"det R = \+1; got det R = -1"),
        (np.diag([1.0, 1.0, 1.0 + 1e-6]), r"got \|\|R\^T R - I\|\| = 2e-06"),  # (1 + 1e-6)² − 1
        (np.diag([1.0, 1.0, np.nan]), r"`R` must be finite"),
    ],
)
@pytest.mark.parametrize("bodies", [3, 200])  # numpy's det and matmul / the column sums for many 3 × 3
def test_one_bad_rotation_in_an_ensemble_is_found(top, defect, match, bodies):
    R = np.broadcast_to(np.eye(3), (bodies, 3, 3)).copy()
    R[bodies - 2] = defect
    with pytest.raises(ValueError, match=match):
        top.initial_state(angular_velocity=np.ones((bodies, 3)), R=R)


@pytest.mark.parametrize("bodies", [3, 200])  # numpy / the compiled check of many 3 × 3
def test_one_bad_bivector_in_an_ensemble_is_found(top, bodies):
    A = np.broadcast_to(hat([0.1, 1.0, 0.1]), (bodies, 3, 3)).copy()
    A[bodies - 2, 0, 1] += 0.5
    with pytest.raises(
        ValueError, match=r"`A` must be skew-symmetric .* got max \|X \+ X\^T\| = 0.5 for max \|X\| = 1\."
    ):
        top.initial_state(A=A)


def test_the_compiled_checks_of_many_3x3_measure_what_numpy_measures(rng):
    """The largest ``‖RᵀR − I‖_F``, the smallest det and the skew defect of a stack, against
    stacked matmul, LAPACK's det and numpy's reductions; a NaN or inf anywhere makes them NaN."""
    from scipy.spatial.transform import Rotation

    from lieint.fast.checks import rotation_defects_3, skew_defect_3

    R = Rotation.random(300, random_state=4).as_matrix() + 1e-9 * rng.normal(size=(300, 3, 3))
    R[17] = np.diag([1.0, 1.0, -1.0])
    D = np.swapaxes(R, -1, -2) @ R - np.eye(3)
    worst, smallest_det = rotation_defects_3(R.reshape(3, 100, 3, 3))
    assert worst == pytest.approx(np.linalg.norm(D, axis=(-2, -1)).max(), rel=1e-12)
    assert smallest_det == pytest.approx(np.linalg.det(R).min(), rel=1e-12)
    X = hat(rng.normal(size=(300, 3))) + 1e-7 * rng.normal(size=(300, 3, 3))
    err, scale = skew_defect_3(X[:, ::-1])  # a strided view is checked as it is
    assert err == np.abs(X[:, ::-1] + np.swapaxes(X[:, ::-1], -1, -2)).max()
    assert scale == np.abs(X).max()
    for bad in (np.nan, np.inf, -np.inf):
        Rb, Xb = R.copy(), X.copy()
        Rb[250, 2, 1], Xb[250, 1, 2] = bad, bad
        assert all(np.isnan(v) for v in (*rotation_defects_3(Rb), *skew_defect_3(Xb)))


def test_the_compiled_finiteness_check_finds_every_nan_and_inf():
    from lieint.fast.finite import all_finite

    arrays = [(1.7e308 * np.linspace(-1.0, 1.0, 1500)).reshape(3, 500), np.array([5e-324, -0.0, 0.0]), np.zeros(0)]
    assert all_finite(arrays)
    assert all_finite([arrays[0][:, ::3]])  # strided views are checked as they are
    for bad in (np.nan, -np.nan, np.inf, -np.inf):
        for where in (0, 511, 512, 1499):  # the first, the chunks' edges, the last
            damaged = [a.copy() for a in arrays]
            damaged[0].ravel()[where] = bad
            assert not all_finite(damaged)


def test_the_finiteness_check_of_a_few_entries_finds_every_nan_and_inf_and_survives_overflow():
    # up to 256 entries in all the check sums them as Python floats; a sum that overflows to
    # infinity (finite entries) must still pass, through the compiled pass
    from lieint.fast.finite import all_finite

    arrays = [np.array([[1.7e308, 1.7e308], [-0.0, 5e-324]]), np.array([1.7e308]), np.zeros(0), np.ones((3, 3))[:, ::2]]
    assert all_finite(arrays)
    assert all_finite([np.full(256, 1.7e308)]) and all_finite([np.full(257, 1.7e308)])
    for bad in (np.nan, -np.nan, np.inf, -np.inf):
        for a in range(3):
            for where in range(arrays[a].size):
                damaged = [x.copy() for x in arrays]
                damaged[a].ravel()[where] = bad
                assert not all_finite(damaged), (a, where, bad)
        base = np.ones((3, 3))
        base[1, 1] = bad  # outside the strided view
        assert all_finite([base[:, ::2]])
        base[1, 2] = bad
        assert not all_finite([base[:, ::2]])
        assert not all_finite([np.ones(200), np.full(100, bad)])  # over the limit, in the compiled pass


def test_a_small_float_array_is_taken_as_it_is_and_a_non_finite_entry_named():
    from lieint._validation import as_float_array

    big = np.array([1.7e308, 1.7e308, -1.7e308])  # finite, though its sum overflows
    assert as_float_array(big, "x") is big
    for bad in (np.nan, np.inf, -np.inf):
        arr = np.zeros((3, 3))
        arr[1, 2] = bad
        with pytest.raises(ValueError, match=rf"`y0\['A'\]` must be finite; got {bad} at index \(1, 2\)"):
            as_float_array(arr, "y0['A']")
    assert as_float_array(np.arange(3), "x").dtype == np.float64


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"h": 0.0}, ValueError, r"`h` must be a positive finite number; got 0.0"),
        ({"h": -0.1}, ValueError, r"`h` must be a positive finite number; got -0.1"),
        ({"h": float("nan")}, ValueError, r"`h` must be a positive finite number; got nan"),
        ({"h": "0.1"}, TypeError, r"`h` must be a positive finite number; got '0.1'"),
        ({"h": None}, ValueError, r"`h` \(the step size\) is required"),
        ({"t_span": (0.0, 0.0)}, ValueError, r"`t_span` = \(t0, t1\) must have t1 != t0 .* got \(0.0, 0.0\)"),
        ({"t_span": (0.0, np.inf)}, ValueError, r"`t_span` must be finite"),
        ({"t_span": 5.0}, ValueError, r"`t_span` must be a pair \(t0, t1\)"),
        ({"method": "rk5"}, ValueError, r"`method`: unknown method 'rk5'; valid names are \['lie_euler', 'rkmk2'"),
        ({"method": 4}, TypeError, r"`method` must be a method name or a method object; got int"),
        ({"coordinates": "quat"}, ValueError, r"`coordinates` must be one of \['exp', 'cayley'\]; got 'quat'"),
        (
            {"method": "rk4", "coordinates": "cayley"},
            ValueError,
            r"`coordinates` = 'cayley' does not apply to 'rk4', which has no coordinate map",
        ),
        ({"save_every": 0}, ValueError, r"`save_every` must be a positive integer; got 0"),
        ({"project": "yes"}, TypeError, r"`project` must be True or False; got 'yes'"),
        ({"dexpinv_degree": 1}, ValueError, r"`dexpinv_degree` = 1 caps an order-4 RKMK method at order 3"),
    ],
)
def test_bad_integrate_arguments(top, y0, kwargs, exc, match):
    args = {"t_span": (0.0, 1.0), "h": 0.1, "method": "rkmk4"} | kwargs
    with pytest.raises(exc, match=match):
        lieint.integrate(top, y0, **args)


def test_bad_state_dict(top, y0):
    with pytest.raises(ValueError, match=r"`y0` must have exactly the keys \['A', 'R'\]; missing \['R'\]"):
        lieint.integrate(top, {"A": y0["A"]}, (0, 1), h=0.1)
    with pytest.raises(TypeError, match=r"`y0` must be a state dict"):
        lieint.integrate(top, y0["A"], (0, 1), h=0.1)
    bad = dict(y0, A=np.full((3, 3), np.nan))
    with pytest.raises(ValueError, match=r"`y0\['A'\]` must be finite; got nan"):
        lieint.integrate(top, bad, (0, 1), h=0.1)
    with pytest.raises(ValueError, match=r"All fields of `y0` must share one batch shape"):
        lieint.integrate(top, dict(y0, R=np.broadcast_to(np.eye(3), (2, 3, 3))), (0, 1), h=0.1)
    with pytest.raises(TypeError, match=r"`system` must be a lieint system"):
        lieint.integrate("top", y0, (0, 1), h=0.1)


def test_a_step_too_large_for_the_dexpinv_series_is_refused(top):
    y0 = top.initial_state(angular_velocity=[0.0, 0.3, 20.0])
    with pytest.raises(lieint.DexpinvRangeError, match=r"Reduce the step `h`, or use `coordinates='cayley'`"):
        lieint.integrate(top, y0, (0, 10), h=0.5, method="rkmk4")
    # Cayley coordinates have an exact dcay⁻¹ and stay orthogonal at such a step (‖hΩ‖ ≈ 10)
    with pytest.warns(lieint.LieStepWarning, match=r"h = 0.5 is too large for this motion"):
        sol = lieint.integrate(top, y0, (0, 10), h=0.5, method="rkmk4", coordinates="cayley")
    assert sol.success and np.max(sol.invariants["orthogonality"]) < 1e-13


def test_a_far_too_large_cayley_step_stays_orthogonal_and_shows_its_error(top):
    # ‖hΩ‖ ≈ 20: far out of any method's range. Cayley stays on SO(3) (closed form), and the
    # garbage shows in the energy instead of hiding.
    y0 = top.initial_state(angular_velocity=[0.0, 0.3, 20.0])
    with pytest.warns(lieint.LieStepWarning, match="not an accurate solution"):
        sol = lieint.integrate(top, y0, (0, 10), h=1.0, method="rkmk4", coordinates="cayley")
    assert sol.success and np.max(sol.invariants["orthogonality"]) < 1e-13
    assert sol.drift("energy") > 0.1


def test_a_resolved_step_gives_no_warning(top, recwarn):
    y0 = top.initial_state(angular_velocity=[0.0, 0.3, 20.0])
    lieint.integrate(top, y0, (0, 1), h=0.01, method="rkmk4", coordinates="cayley")
    assert not [w for w in recwarn if issubclass(w.category, lieint.LieStepWarning)]


class _Exploding(lieint.EulerTop):
    """A top whose generator overflows after t = 0.5 (stands for any diverging model)."""

    def generator(self, t, y):
        xi = super().generator(t, y)
        return xi * np.inf if t > 0.5 else xi


@pytest.mark.parametrize("coordinates", ["exp", "cayley"])
def test_an_overflowing_run_stops_with_a_message_not_a_traceback(coordinates):
    top = _Exploding(np.diag([1.0, 2.0, 3.0, 4.0]))
    y0 = top.initial_state(Omega=np.triu(np.ones((4, 4)), 1) - np.tril(np.ones((4, 4)), -1))
    sol = lieint.integrate(top, y0, (0, 2), h=0.1, method="rkmk2", coordinates=coordinates)
    assert not sol.success
    assert "Reduce" in sol.message
    assert np.all(np.isfinite(sol.states["A"])) and sol.t[-1] <= 0.6
