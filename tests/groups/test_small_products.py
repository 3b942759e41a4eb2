"""The unrolled small products (:mod:`lieint.fast.small_products`): generated, not edited, and
bit for bit the loops they replace."""

from __future__ import annotations

import numpy as np
import pytest

from lieint.fast import _generate_cayley, _generate_products
from lieint.fast.products import _loops_into
from lieint.fast.small_products import square_into


def test_the_module_is_the_generators_output():
    assert _generate_products.TARGET.read_text() == _generate_products.source()
    assert _generate_cayley.TARGET.read_text() == _generate_cayley.source()


@pytest.mark.parametrize("n", list(_generate_products.SIZES))
def test_each_size_gives_the_loops_bits_also_in_place_and_on_a_transposed_view(n):
    rng = np.random.default_rng(n)
    A, B = rng.normal(size=(n, n)), rng.normal(size=(n, n)) * 10.0 ** rng.integers(-8, 8, size=(n, n))
    expected = np.empty((n, n))
    _loops_into(A, B, expected)
    out = np.full((n, n), np.nan)
    assert square_into(A, B, out)
    assert np.array_equal(out, expected)
    # and the product: within the classical bound n ε |A||B| of the exact one
    assert np.all(np.abs(out - A @ B) <= 2 * n * np.finfo(float).eps * (np.abs(A) @ np.abs(B)))
    # out may be either operand (each is read before it is written)
    left, right = A.copy(), B.copy()
    assert square_into(left, B, left) and np.array_equal(left, expected)
    assert square_into(A, right, right) and np.array_equal(right, expected)
    # a transposed (Fortran-ordered) view, as the kernels pass Qᵀ
    _loops_into(A.T, B, expected)
    assert square_into(A.T, B, out) and np.array_equal(out, expected)


@pytest.mark.parametrize("shape", [(1, 1, 1), (2, 2, 2), (9, 9, 9), (3, 4, 4), (4, 4, 3), (4, 3, 4)])
def test_other_shapes_are_refused_and_left_untouched(shape):
    n, k, m = shape
    out = np.full((n, m), 7.0)
    assert not square_into(np.ones((n, k)), np.ones((k, m)), out)
    assert np.all(out == 7.0)


def test_a_non_finite_entry_reaches_its_column_of_the_product():
    A, B = np.eye(5), np.eye(5)
    B[2, 3] = np.nan  # 0 · NaN is NaN: the whole column
    out = np.empty((5, 5))
    square_into(A, B, out)
    assert np.isnan(out[:, 3]).all() and np.isfinite(np.delete(out, 3, axis=1)).all()


@pytest.mark.parametrize("n", [3, 4, 6, 8, 9])
def test_the_unrolled_exponential_gives_the_loops_bits(n):
    # the n-D top's compiled copy of the Taylor exponential (skew._with_product) against the
    # original, every Taylor degree and squarings; and against scipy's expm to round-off
    from scipy.linalg import expm

    from lieint.fast.skew import expm_skew, expm_skew_small_into

    rng = np.random.default_rng(n)
    for scale in (1e-6, 0.01, 0.3, 1.0, 3.0):
        u = rng.normal(size=(n, n))
        u = (u - u.T) * scale / np.linalg.norm(u - u.T, 2)
        out = np.empty((n, n))
        expm_skew_small_into(u, out, np.empty((5, n, n)))
        assert np.array_equal(out, expm_skew(u))
        np.testing.assert_allclose(out, expm(u), rtol=0, atol=1e-14 * max(1.0, scale))
