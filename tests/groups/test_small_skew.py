"""The n-dimensional top's unrolled skew operations (:mod:`lieint.fast.small_skew`): generated,
not edited; exactly skew; the full products' results to round-off, in place too."""

from __future__ import annotations

import numpy as np
import pytest

from lieint.fast import _generate_skew
from lieint.fast.small_skew import bracket_skew_into, congruence_skew_into, dcayinv_skew_into

EPS = np.finfo(float).eps


def test_the_module_is_the_generators_output():
    assert _generate_skew.TARGET.read_text() == _generate_skew.source()


def _skew(rng, n, scale=1.0):
    x = rng.normal(size=(n, n))
    return (x - x.T) * scale


def _exactly_skew(X):
    return np.array_equal(X, -X.T) and not np.any(np.diag(X))


def test_the_step_uses_them_for_exactly_the_generated_sizes():
    import inspect

    from lieint.fast import topn_step

    first, last = _generate_skew.SIZES[0], _generate_skew.SIZES[-1]
    assert f"unrolled = {first} <= n <= {last}" in inspect.getsource(topn_step._lie_step.py_func)


@pytest.mark.parametrize("n", list(_generate_skew.SIZES))
def test_each_size_is_the_full_products_to_round_off_and_exactly_skew(n):
    rng = np.random.default_rng(n)
    for scale in (1e-8, 1.0, 1e6):
        A, u, xi = _skew(rng, n, scale), _skew(rng, n), _skew(rng, n, scale)
        Q = np.linalg.qr(rng.normal(size=(n, n)))[0]
        M = rng.normal(size=(n, n))
        M = M + M.T
        A1, Om = np.full((n, n), np.nan), np.full((n, n), np.nan)
        assert congruence_skew_into(Q, A, M, A1, Om)
        exact = Q.T @ A @ Q
        bound = 4 * n * EPS * (np.abs(Q.T) @ np.abs(A) @ np.abs(Q))  # two products' round-off
        assert np.all(np.abs(A1 - exact) <= bound) and _exactly_skew(A1) and _exactly_skew(Om)
        assert np.array_equal(Om, A1 * np.where(np.eye(n, dtype=bool), 0.0, M))
        out = np.full((n, n), np.nan)
        assert dcayinv_skew_into(u, xi, out)
        exact = xi + 0.5 * (u @ xi - xi @ u) - 0.25 * u @ xi @ u
        size = np.abs(xi) + np.abs(u) @ np.abs(xi) + np.abs(xi) @ np.abs(u) + np.abs(u) @ np.abs(xi) @ np.abs(u)
        assert np.all(np.abs(out - exact) <= 4 * n * EPS * size) and _exactly_skew(out)
        # dcay⁻¹_{−u}(ξ) = (I + u/2) ξ (I − u/2): the same map, factored
        one = np.eye(n)
        np.testing.assert_allclose(out, (one + u / 2) @ xi @ (one - u / 2), rtol=0, atol=8 * n * EPS * size.max())
        assert bracket_skew_into(u, xi, out)
        bound = 4 * n * EPS * (np.abs(u) @ np.abs(xi) + np.abs(xi) @ np.abs(u))
        assert np.all(np.abs(out - (u @ xi - xi @ u)) <= bound) and _exactly_skew(out)


@pytest.mark.parametrize("n", list(_generate_skew.SIZES))
def test_an_output_may_be_an_input(n):
    rng = np.random.default_rng(100 + n)
    A, u, xi = _skew(rng, n), _skew(rng, n), _skew(rng, n)
    Q = np.linalg.qr(rng.normal(size=(n, n)))[0]
    M = np.abs(rng.normal(size=(n, n)))
    M = M + M.T
    A1, Om = np.empty((n, n)), np.empty((n, n))
    congruence_skew_into(Q, A, M, A1, Om)
    in_place = A.copy()
    congruence_skew_into(Q, in_place, M, in_place, Om)  # the step's last action: Ã ← QᵀÃQ
    assert np.array_equal(in_place, A1)
    expected = np.empty((n, n))
    dcayinv_skew_into(u, xi, expected)
    for which in ("u", "xi"):
        uu, xx = u.copy(), xi.copy()
        dcayinv_skew_into(uu, xx, uu if which == "u" else xx)
        assert np.array_equal(uu if which == "u" else xx, expected)
    bracket_skew_into(u, xi, expected)
    xx = xi.copy()
    bracket_skew_into(u, xx, xx)
    assert np.array_equal(xx, expected)
    # a transposed (Fortran-ordered) view is read by its strides
    congruence_skew_into(np.asfortranarray(Q), np.asfortranarray(A), M, in_place, Om)
    assert np.array_equal(in_place, A1)


@pytest.mark.parametrize("n", [1, 2, 3, 7, 9])
def test_other_sizes_are_refused_and_left_untouched(n):
    out, other = np.full((n, n), 7.0), np.full((n, n), 7.0)
    X = np.ones((n, n))
    assert not congruence_skew_into(X, X, X, out, other)
    assert not dcayinv_skew_into(X, X, out)
    assert not bracket_skew_into(X, X, out)
    assert np.all(out == 7.0) and np.all(other == 7.0)


def test_a_non_finite_entry_reaches_the_result():
    n = 6
    rng = np.random.default_rng(0)
    A, u = _skew(rng, n), _skew(rng, n)
    A[1, 4], A[4, 1] = np.nan, np.nan
    out, Om = np.empty((n, n)), np.empty((n, n))
    congruence_skew_into(np.eye(n), A, np.ones((n, n)), out, Om)
    assert np.isnan(out[1, 4]) and np.isnan(Om[4, 1])
    dcayinv_skew_into(u, A, out)
    assert np.isnan(out).any()
