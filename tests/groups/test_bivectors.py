import numpy as np
import pytest
from conftest import random_rotation, random_skew

from lieint.groups import (
    bivector_coordinates,
    commutator,
    from_bivector_coordinates,
    hat,
    inner,
    vee,
    wedge,
)


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6])
def test_wedge_acts_as_u_v_dot_x_minus_v_u_dot_x(rng, n):
    u, v, x = rng.normal(size=(3, 7, n))
    lhs = (wedge(u, v) @ x[..., None])[..., 0]
    rhs = u * np.sum(v * x, -1, keepdims=True) - v * np.sum(u * x, -1, keepdims=True)
    np.testing.assert_allclose(lhs, rhs, atol=1e-13)


@pytest.mark.parametrize("n", [2, 3, 4, 6])
def test_wedge_is_equivariant_under_rotations_and_reflections(rng, n):
    u, v = rng.normal(size=(2, n))
    Q = random_rotation(rng, n)
    Q[:, 0] *= -1  # an improper orthogonal matrix too
    np.testing.assert_allclose(wedge(Q @ u, Q @ v), Q @ wedge(u, v) @ Q.T, atol=1e-13)


def test_hat_is_cross_product_and_bivector_sign(rng):
    w, x = rng.normal(size=(2, 5, 3))
    np.testing.assert_allclose((hat(w) @ x[..., None])[..., 0], np.cross(w, x), atol=1e-14)
    np.testing.assert_allclose(vee(hat(w)), w)
    # docs/theory.md §1: the bivector of ŵ is −(w₁ e₂∧e₃ + w₂ e₃∧e₁ + w₃ e₁∧e₂).
    e = np.eye(3)
    w1 = np.array([0.7, -1.3, 2.1])
    expected = -(w1[0] * wedge(e[1], e[2]) + w1[1] * wedge(e[2], e[0]) + w1[2] * wedge(e[0], e[1]))
    np.testing.assert_allclose(hat(w1), expected)


def test_hat_bracket_is_cross_product(rng):
    u, v = rng.normal(size=(2, 3))
    np.testing.assert_allclose(commutator(hat(u), hat(v)), hat(np.cross(u, v)), atol=1e-14)


@pytest.mark.parametrize("n", [2, 3, 5])
def test_coordinates_round_trip_and_basis(rng, n):
    X = random_skew(rng, n, (4,))
    c = bivector_coordinates(X)
    assert c.shape == (4, n * (n - 1) // 2)
    np.testing.assert_allclose(from_bivector_coordinates(c, n), X)
    # entry [i, j], i < j, is the coefficient of e_i ∧ e_j
    e = np.eye(n)
    np.testing.assert_allclose(bivector_coordinates(wedge(e[0], e[n - 1]))[n - 2], 1.0)


def test_inner_is_minus_trace_of_product(rng):
    X, Y = random_skew(rng, 4, (2,)), random_skew(rng, 4, (2,))
    np.testing.assert_allclose(inner(X, Y), -np.trace(X @ Y, axis1=-2, axis2=-1))


def test_bad_shapes_raise_named_errors():
    with pytest.raises(ValueError, match=r"`w` must have shape \(\.\.\., 3\)"):
        hat(np.zeros(4))
    with pytest.raises(ValueError, match=r"`c` must have shape \(\.\.\., 6\)"):
        from_bivector_coordinates(np.zeros(5), 4)
