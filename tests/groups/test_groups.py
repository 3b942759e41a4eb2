"""Group axioms and the maps of docs/theory.md §6, for n = 2…6 and batch shapes."""

import itertools

import numpy as np
import pytest
from conftest import random_rotation, random_skew
from scipy.linalg import expm, expm_frechet, polar

from lieint.groups import SE, SO, DexpinvRangeError, bernoulli_dexpinv_coefficients, hat, se_join

NS = [2, 3, 4, 5, 6]
BATCHES = [(), (3,), (2, 2)]


def random_se(rng, n, batch, scale=1.0):
    return se_join(random_skew(rng, n, batch, scale), scale * rng.normal(size=(*batch, n)), algebra=True)


@pytest.mark.parametrize("n", NS)
@pytest.mark.parametrize("batch", BATCHES)
def test_so_exp_matches_expm_and_log_inverts_it(rng, n, batch):
    G = SO(n)
    X = random_skew(rng, n, batch, 0.8)
    R = G.exp(X)
    assert R.shape == (*batch, n, n)
    np.testing.assert_allclose(R, expm(X), atol=2e-14)
    np.testing.assert_allclose(G.log(R), X, atol=1e-12)
    Rr = random_rotation(rng, n, batch)
    np.testing.assert_allclose(G.exp(G.log(Rr)), Rr, atol=1e-12)


@pytest.mark.parametrize("n", NS)
def test_group_axioms(rng, n):
    G = SO(n)
    g, h, k = (random_rotation(rng, n, (4,)) for _ in range(3))
    np.testing.assert_allclose(G.multiply(G.multiply(g, h), k), G.multiply(g, G.multiply(h, k)), atol=1e-14)
    np.testing.assert_allclose(G.multiply(g, G.inverse(g)), G.identity((4,)), atol=1e-14)
    np.testing.assert_allclose(G.multiply(G.identity(), g), g)


def test_so3_closed_forms_near_zero_and_pi(rng):
    G = SO(3)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    for theta in [0.0, 1e-9, 1e-4, 1e-3, 0.5, np.pi - 1e-6, np.pi - 1e-9]:
        X = hat(theta * axis)
        np.testing.assert_allclose(G.exp(X), expm(X), atol=1e-15)
        np.testing.assert_allclose(G.log(G.exp(X)), X, atol=1e-7 if theta > 3 else 1e-14)


def test_so3_exp_of_one_matrix_is_the_batched_one_to_the_bit(rng):
    """One matrix takes a scalar path; it must be the batched arithmetic exactly (batched and
    looped runs are compared bit for bit), at angles on both sides of the Taylor switch."""
    from lieint.groups.so import so3_exp

    for scale in (0.0, 1e-5, 0.999e-3, 1e-3, 1.001e-3, 0.5, 3.0, 40.0):
        X = random_skew(rng, 3, (200,))
        X *= scale / np.maximum(np.sqrt(np.sum(X * X, axis=(-2, -1)) / 2), 1e-300)[:, None, None]
        batched = so3_exp(X)
        assert all(np.array_equal(so3_exp(x), b) for x, b in zip(X, batched, strict=True))


@pytest.mark.parametrize("n", NS)
def test_cayley_is_orthogonal_and_inverted(rng, n):
    G = SO(n)
    X = random_skew(rng, n, (5,), 3.0)
    Q = G.cay(X)
    np.testing.assert_allclose(np.swapaxes(Q, -1, -2) @ Q, np.broadcast_to(np.eye(n), Q.shape), atol=1e-13)
    assert np.all(np.linalg.det(Q) > 0)
    np.testing.assert_allclose(G.cay_inv(Q), X, atol=1e-11)


def dexp_reference(u, w):
    """Left-trivialised dexp_u(w) = (d/dε exp(u + εw)) exp(−u), from scipy's Fréchet derivative."""
    flat_u, flat_w = u.reshape(-1, *u.shape[-2:]), w.reshape(-1, *w.shape[-2:])
    out = [expm_frechet(a, b, compute_expm=False) @ expm(-a) for a, b in zip(flat_u, flat_w, strict=True)]
    return np.array(out).reshape(u.shape)


@pytest.mark.parametrize("n", NS)
def test_dexpinv_inverts_dexp_exact_and_series(rng, n):
    G = SO(n)
    u = random_skew(rng, n, (3,), 0.3)
    w = random_skew(rng, n, (3,))
    v = dexp_reference(u, w)
    np.testing.assert_allclose(G.dexpinv(u, v), w, atol=1e-13)  # exact closed form
    np.testing.assert_allclose(G.dexpinv(u, v, degree=16), w, atol=1e-12)  # Bernoulli series


@pytest.mark.parametrize("n", [2, 3, 4])
def test_se_dexpinv_series_inverts_dexp(rng, n):
    G = SE(n)
    u, w = random_se(rng, n, (2,), 0.3), random_se(rng, n, (2,))
    np.testing.assert_allclose(G.dexpinv(u, dexp_reference(u, w), degree=18), w, atol=1e-12)
    np.testing.assert_allclose(G.dexpinv(u, dexp_reference(u, w)), w, atol=1e-12)


def test_series_truncation_error_shrinks_with_degree(rng):
    G = SO(4)
    u, v = random_skew(rng, 4, (), 0.2), random_skew(rng, 4)
    exact = G.dexpinv(u, v)
    errs = [np.abs(G.dexpinv(u, v, degree=d) - exact).max() for d in (0, 2, 4, 6)]
    assert all(a > 10 * b for a, b in itertools.pairwise(errs))


def test_bernoulli_coefficients():
    c = bernoulli_dexpinv_coefficients(6)
    np.testing.assert_allclose(c, [1, -1 / 2, 1 / 12, 0, -1 / 720, 0, 1 / 30240])


def test_so3_series_converges_beyond_pi_up_to_2pi(rng):
    # ad_u on so(3) has eigenvalues 0, ±iθ: the series converges for θ < 2π (not only θ < π).
    G = SO(3)
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    u = hat(1.5 * np.pi * axis)
    v = hat(rng.normal(size=3))
    np.testing.assert_allclose(G.dexpinv(u, v, degree=400), G.dexpinv(u, v), atol=1e-9)
    with pytest.raises(DexpinvRangeError, match=r"spectral radius of ad_u is 6\.283 >= 2\*pi"):
        G.dexpinv(hat(2.0 * np.pi * axis), v, degree=4)


def test_so4_convergence_limit_is_sum_of_two_largest_angles():
    G = SO(4)
    u = np.zeros((4, 4))
    u[0, 1], u[1, 0] = -3.5, 3.5  # θ₁ = 3.5 > π, alone: radius 3.5 < 2π
    assert np.isclose(G.ad_spectral_radius(u), 3.5)
    G.dexpinv(u, u, degree=4)
    u[2, 3], u[3, 2] = -3.0, 3.0  # θ₁ + θ₂ = 6.5 >= 2π
    with pytest.raises(DexpinvRangeError, match="Reduce the step `h`"):
        G.dexpinv(u, u, degree=4)


@pytest.mark.parametrize("n", NS)
def test_projection_returns_the_nearest_rotation(rng, n):
    G = SO(n)
    R = random_rotation(rng, n, (6,))
    M = R + 1e-3 * rng.normal(size=R.shape)
    P = G.project(M)
    np.testing.assert_allclose(np.swapaxes(P, -1, -2) @ P, np.broadcast_to(np.eye(n), P.shape), atol=1e-14)
    assert np.all(np.linalg.det(P) > 0)
    for i in range(6):
        np.testing.assert_allclose(P[i], polar(M[i])[0], atol=1e-13)  # det > 0 here: polar factor
        # no other rotation is closer (random competitors near P)
        comp = G.exp(random_skew(rng, n, (20,), 1e-2)) @ P[i]
        assert np.linalg.norm(M[i] - P[i]) <= np.min(np.linalg.norm(M[i] - comp, axis=(-2, -1)))


def test_projection_of_a_reflection_is_a_rotation(rng):
    M = np.diag([1.0, 1.0, -1.0]) + 1e-3 * rng.normal(size=(3, 3))
    assert np.linalg.det(SO(3).project(M)) > 0


@pytest.mark.parametrize("n", [2, 3, 4, 5])
@pytest.mark.parametrize("batch", BATCHES)
def test_se_exp_log_inverse_project(rng, n, batch):
    G = SE(n)
    X = random_se(rng, n, batch, 0.7)
    g = G.exp(X)
    np.testing.assert_allclose(g, expm(X), atol=1e-13)
    np.testing.assert_allclose(G.log(g), X, atol=1e-12)
    np.testing.assert_allclose(G.multiply(g, G.inverse(g)), G.identity(batch), atol=1e-13)
    c = G.cay(X)
    np.testing.assert_allclose(c[..., n, :], np.broadcast_to(np.eye(n + 1)[n], (*batch, n + 1)), atol=1e-15)
    noisy = g + 1e-6 * rng.normal(size=g.shape)
    p = G.project(noisy)
    Q = p[..., :n, :n]
    np.testing.assert_allclose(np.swapaxes(Q, -1, -2) @ Q, np.broadcast_to(np.eye(n), Q.shape), atol=1e-14)


def test_bad_group_dimension():
    with pytest.raises(ValueError, match="`n` must be an integer >= 2; got 1"):
        SO(1)


@pytest.mark.parametrize("n", [3, 4, 5])
def test_dcayinv_inverts_the_differential_of_cayley(rng, n):
    # dcay_X(v) = (d/dε cay(X + εv)) cay(X)⁻¹, by central differences (an independent truth)
    G = SO(n)
    X, v = random_skew(rng, n, (), 1.5), random_skew(rng, n)
    eps = 1e-6
    d = (G.cay(X + eps * v) - G.cay(X - eps * v)) / (2 * eps) @ G.cay(X).T
    np.testing.assert_allclose(G.dcayinv(X, d), v, atol=1e-8)


def test_so3_cayley_closed_form_matches_the_linear_solve(rng):
    X = random_skew(rng, 3, (5,), 4.0)
    eye = np.eye(3)
    np.testing.assert_allclose(SO(3).cay(X), np.linalg.solve(eye - X / 2, eye + X / 2), atol=1e-14)
