"""lieint.rotations: scipy's Rotation and quaternions in and out; the frame convention checked
against scipy's own Rotation.apply."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import lieint
from lieint import rotations
from lieint.groups.bivectors import vee


def edge_rotations():
    """Random rotations and the hard cases of the conversions: the identity, half turns
    (w = 0) about the axes and a diagonal, turns just short of and beyond π."""
    axes = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1], [1, -2, 0.5]], dtype=float)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = np.array([0.0, 1e-9, np.pi - 1e-9, np.pi, 2.0, 3.0])
    rotvecs = (axes[:, None, :] * angles[None, :, None]).reshape(-1, 3)
    randoms = Rotation.random(2000, random_state=7).as_matrix()
    return np.concatenate([randoms, Rotation.from_rotvec(rotvecs).as_matrix()])


@pytest.mark.parametrize("scalar_first", [True, False])
def test_matrix_quaternion_matrix_round_trip(scalar_first):
    R = edge_rotations()
    q = rotations.to_quaternion(R, scalar_first=scalar_first, continuous=False)
    assert q.shape == (R.shape[0], 4)
    assert np.max(np.abs(np.linalg.norm(q, axis=-1) - 1.0)) <= 1e-15
    back = rotations.from_quaternion(q, scalar_first=scalar_first)
    assert np.max(np.abs(back - R)) <= 1e-15


@pytest.mark.parametrize("scalar_first", [True, False])
def test_quaternion_matrix_quaternion_round_trip(scalar_first, rng):
    q = rng.normal(size=(2000, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    q[:4] = np.eye(4)  # the identity and the half turns about the axes, in either order
    R = rotations.from_quaternion(q, scalar_first=scalar_first)
    back = rotations.to_quaternion(R, scalar_first=scalar_first, continuous=False)
    sign = np.where(np.sum(back * q, axis=-1, keepdims=True) < 0, -1.0, 1.0)  # q and −q: one rotation
    assert np.max(np.abs(sign * back - q)) <= 1e-15


def test_scipy_rotation_round_trip():
    R = edge_rotations()
    assert np.max(np.abs(rotations.from_scipy(rotations.to_scipy(R)) - R)) <= 1e-15
    one = rotations.to_scipy(R[5])
    assert one.single and np.max(np.abs(rotations.from_scipy(one) - R[5])) <= 1e-15


def test_the_component_orders_are_the_stated_ones():
    c = np.cos(np.pi / 8)
    s = np.sin(np.pi / 8)
    quarter_z = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90° about e3, right-handed
    eighth_x = Rotation.from_rotvec([np.pi / 4, 0.0, 0.0]).as_matrix()
    h = np.sqrt(0.5)
    assert np.allclose(rotations.to_quaternion(quarter_z, scalar_first=True), [h, 0, 0, h], atol=1e-16)
    assert np.allclose(rotations.to_quaternion(quarter_z, scalar_first=False), [0, 0, h, h], atol=1e-16)
    assert np.allclose(rotations.to_quaternion(eighth_x, scalar_first=True), [c, s, 0, 0], atol=1e-16)
    assert np.allclose(rotations.from_quaternion([c, s, 0, 0], scalar_first=True), eighth_x, atol=1e-16)
    assert np.allclose(rotations.from_quaternion([s, 0, 0, c], scalar_first=False), eighth_x, atol=1e-16)
    # scipy's scalar-last quaternion is ours with scalar_first=False
    R = Rotation.random(50, random_state=3)
    assert np.allclose(rotations.from_quaternion(R.as_quat(), scalar_first=False), R.as_matrix(), atol=1e-15)


def test_quaternion_series_are_sign_continuous():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    sol = lieint.integrate(top, top.initial_state(angular_velocity=[0.3, 2.0, 0.4]), (0, 40), h=0.05)
    q = rotations.to_quaternion(sol.states["R"], scalar_first=True)
    assert q[0, 0] >= 0 and np.min(np.sum(q[1:] * q[:-1], axis=-1)) > 0.99
    raw = rotations.to_quaternion(sol.states["R"], scalar_first=True, continuous=False)
    assert np.min(np.sum(raw[1:] * raw[:-1], axis=-1)) < 0  # scipy's own signs jump
    assert np.allclose(np.abs(np.sum(q * raw, axis=-1)), 1.0, atol=1e-14)  # the same rotations
    batch = rotations.to_quaternion(np.stack([sol.states["R"], sol.states["R"]], axis=1), scalar_first=False)
    assert batch.shape == (sol.t.size, 2, 4) and np.array_equal(batch[:, 1], np.roll(q, -1, axis=-1))


# -- the frame convention against Rotation.apply ----------------------------------------------------


def test_body_points_go_to_space_as_rotation_apply():
    # the atoms' positions are q_i = q_G + R X_i (lieint's construction from R); scipy's apply
    # of the same rotation to the body coordinates must give them
    X = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, -1, -1], [0.5, -0.3, 0.2]], dtype=float)
    body = lieint.AtomsBody([1.0, 2.0, 1.5, 1.0, 0.7], X)
    start = Rotation.from_euler("ZYX", [40.0, -25.0, 70.0], degrees=True)
    y0 = body.initial_state(angular_velocity=[0.3, 1.0, 0.4], R=start)
    assert np.allclose(y0["q"], start.apply(body.body_positions), atol=1e-15)
    # and it stays so along the motion: the atoms' own rotation output, against scipy
    sol = lieint.integrate(body, y0, (0.0, 2.0), h=0.01, method="rk4")
    centre = body.masses @ sol.states["q"][-1] / body.total_mass
    R_end = sol.rotation("R")[-1]
    assert np.allclose(sol.states["q"][-1] - centre, R_end.apply(body.body_positions), atol=1e-9)


def test_a_spin_about_a_body_axis_composes_on_the_right():
    # Ṙ = R Ω: a steady spin w about a principal axis gives R(t) = R(0) exp(t ŵ), in scipy's
    # terms start * Rotation.from_rotvec(t w) (the body turns, then the start places it)
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    start = Rotation.from_rotvec([0.4, -1.1, 0.3])
    w = np.array([0.0, 1.7, 0.0])
    sol = lieint.integrate(top, top.initial_state(angular_velocity=w, R=start), (0.0, 3.0), h=0.01, method="rkmk4")
    expected = start * Rotation.from_rotvec(sol.t[:, None] * w)
    assert np.max(np.abs(sol.rotation().as_matrix() - expected.as_matrix())) < 1e-12
    wrong = Rotation.from_rotvec(sol.t[:, None] * w) * start
    assert np.max(np.abs(sol.rotation().as_matrix() - wrong.as_matrix())) > 0.1


def test_the_space_momentum_is_the_body_momentum_applied():
    # a tumbling top: the space momentum vector R L_body is constant; through scipy's apply of
    # the result's rotations to the exact body momentum it must be (R⁻¹ applied is not)
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4], R=Rotation.from_rotvec([0.2, 0.5, -0.7]))
    sol = lieint.integrate(top, y0, (0.0, 10.0), h=0.005, method="rkmk6")
    L_body = vee(top.exact_solution(sol.t, y0)["A"])
    L_space = sol.rotation().apply(L_body)
    assert np.max(np.abs(L_space - L_space[0])) < 1e-10
    assert np.max(np.abs(sol.rotation().inv().apply(L_body) - L_body[0])) > 0.1


# -- inputs and results ---------------------------------------------------------------------------------


def test_initial_state_takes_rotations_and_stacks():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    stack = Rotation.random(4, random_state=2)
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4], R=stack)
    assert y0["R"].shape == (4, 3, 3) and np.array_equal(y0["R"], stack.as_matrix())
    q = stack.as_quat(canonical=False)
    from_wxyz = rotations.from_quaternion(np.roll(q, 1, axis=-1), scalar_first=True)
    y1 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4], R=from_wxyz)
    assert np.max(np.abs(y1["R"] - y0["R"])) <= 1e-15
    ball = lieint.ChaplyginBall(np.diag([0.1, 0.2, 0.3]), mass=1.0, radius=1.0)
    assert np.allclose(ball.initial_state(angular_velocity=[0.1, 0.2, 0.3], R=stack[0])["R"], stack[0].as_matrix())
    heavy = lieint.HeavyTop(np.diag([1.0, 2.0, 3.0]), 1.0, [0.0, 0.0, 0.5], [0.0, 0.0, -9.81])
    assert np.allclose(heavy.initial_state(angular_velocity=[0.1, 0.2, 0.3], R=stack[1])["R"], stack[1].as_matrix())


def test_a_result_as_rotations():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=np.array([[0.3, 1.0, 0.4], [0.0, 0.5, 2.0]]))
    sol = lieint.integrate(top, y0, (0.0, 1.0), h=0.25)
    rot = lieint.rotations.from_solution(sol)
    assert len(rot) == 5 * 2  # time first, then the members
    assert np.allclose(rot.as_matrix().reshape(5, 2, 3, 3), sol.states["R"], atol=1e-15)


@pytest.mark.parametrize(
    ("call", "exc", "match"),
    [
        (
            lambda: rotations.from_quaternion([0.0, 0.0, 0.0, 0.0], scalar_first=True),
            ValueError,
            r"nonzero quaternions",
        ),
        (
            lambda: rotations.from_quaternion([1.0, 0.0, 0.0], scalar_first=True),
            ValueError,
            r"shape \(..., 4\); got shape \(3,\)",
        ),
        (
            lambda: rotations.from_quaternion([1.0, 0.0, 0.0, 0.0], scalar_first="yes"),
            TypeError,
            r"`scalar_first` must be True or False",
        ),
        (lambda: rotations.to_quaternion(np.eye(3)), TypeError, r"scalar_first"),
        (
            lambda: rotations.to_quaternion(np.eye(4), scalar_first=True),
            ValueError,
            r"shape \(..., 3, 3\).*got shape \(4, 4\)",
        ),
        (lambda: rotations.to_scipy(np.diag([1.0, 1.0, -1.0])), ValueError, r"`R`"),
        (lambda: rotations.to_scipy(2.0 * np.eye(3)), ValueError, r"`R`"),
        (
            lambda: rotations.from_scipy(np.eye(3)),
            TypeError,
            r"must be a scipy.spatial.transform.Rotation; got ndarray",
        ),
    ],
)
def test_bad_rotation_inputs(call, exc, match):
    with pytest.raises(exc, match=match):
        call()


def test_a_result_without_orientation_is_refused_by_name():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0], orientation=False)
    sol = lieint.integrate(top, top.initial_state(angular_velocity=[0.3, 1.0, 0.4]), (0.0, 1.0), h=0.5)
    with pytest.raises(ValueError, match=r"`field` = 'R' is neither a state field \['A'\]"):
        sol.rotation()
    four = lieint.EulerTop(np.diag([1.0, 2.0, 3.0, 4.0]))
    rng = np.random.default_rng(0)
    X = rng.normal(size=(4, 4))
    sol4 = lieint.integrate(four, four.initial_state(Omega=X - X.T), (0.0, 0.5), h=0.25)
    with pytest.raises(ValueError, match=r"three-dimensional\); got shape \(3, 4, 4\)"):
        sol4.rotation()


def test_results_off_so3_are_refused_with_what_to_do():
    # scipy's RK45 does not keep R on SO(3): its result is converted only on request
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.01, 1.0, 0.01])
    raw = lieint.integrate(top, y0, (0.0, 10.0), method="RK45", t_eval=[1.0, 2.0, 10.0])
    defect = float(np.max(raw.invariants["orthogonality"]))
    assert defect > 1e-9
    with pytest.raises(ValueError, match=r"`R` must be a rotation in SO\(3\).*project=True, or pass a larger `atol`"):
        raw.rotation()
    nearest = raw.rotation(atol=10 * defect)  # scipy's nearest rotations
    assert np.max(np.abs(nearest.as_matrix() - raw.states["R"])) < 10 * defect
    projected = lieint.integrate(top, y0, (0.0, 10.0), method="RK45", t_eval=[1.0, 2.0, 10.0], project=True)
    assert len(projected.rotation()) == 3
    with pytest.raises(ValueError, match=r"`atol` must be a positive finite number"):
        rotations.to_quaternion(np.eye(3), scalar_first=True, atol=-1.0)
