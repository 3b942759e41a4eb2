"""Matrix products for the compiled kernels (numba, cached on disk), by size.

* up to :data:`_SMALL`, loops (:func:`mm`, :func:`mm_loops`, :func:`mm_into`): a BLAS call costs
  more than the arithmetic; above, BLAS;
* :func:`mm_small_into`: the unrolled n × n products of :mod:`lieint.fast.small_products` for
  3 ≤ n ≤ 8, :func:`mm_into` otherwise — the n-dimensional top's product;
* :func:`mm_unrolled_into`: the same without the BLAS fallback, so that it allocates nothing and
  runs without reference counts (:mod:`lieint.fast._jit`);
* :func:`mv`, a matrix times a vector by loops.

Every entry of a product is a dot product summed over j in order from 0, whichever path
computes it: the same additions in the same order, so the same bits.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._jit import NO_REFCOUNT
from .small_products import square_into

__all__ = [
    "copy_matrix_into",
    "copy_vector_into",
    "mm",
    "mm_into",
    "mm_loops",
    "mm_small_into",
    "mm_unrolled_into",
    "mv",
]

#: up to this size, matrix products run as loops: a BLAS call costs more than the arithmetic
_SMALL = 8


@njit(cache=True)
def mm(A, B):
    """``A B``: loops for matrices up to :data:`_SMALL`, BLAS above."""
    n, k = A.shape
    m = B.shape[1]
    if n > _SMALL or k > _SMALL or m > _SMALL:
        return np.ascontiguousarray(A) @ np.ascontiguousarray(B)
    return mm_loops(A, B)


@njit(cache=True)
def mm_loops(A, B):
    """``A B`` by loops only (no BLAS: the small matrices of the generic kernel's pieces, and
    much less to compile)."""
    out = np.empty((A.shape[0], B.shape[1]))
    _loops_into(A, B, out)
    return out


@njit(cache=True)
def mm_into(A, B, out):
    """``out = A B``: loops up to :data:`_SMALL`, BLAS above (out must not share memory with
    A or B; ``A`` may be a transposed view, ``mm_into(Q.T, X, out)`` for ``QᵀX``)."""
    n, k = A.shape
    m = B.shape[1]
    if n > _SMALL or k > _SMALL or m > _SMALL:
        copy_matrix_into(np.ascontiguousarray(A) @ np.ascontiguousarray(B), out)
    else:
        _loops_into(A, B, out)


# The copies below by loops, never by slice assignment (``out[:, :] = X``): numba's slice
# assignment of an array compiles its shape-mismatch message (string formatting), about 2 s of
# CPU time in every process that compiles a kernel for the first time, for a copy a loop does.
@njit(cache=True, **NO_REFCOUNT)
def copy_matrix_into(X, out):
    """``out[:, :] = X`` by loops (X and out of one shape; out may not overlap X)."""
    for a in range(X.shape[0]):
        for c in range(X.shape[1]):
            out[a, c] = X[a, c]


@njit(cache=True, **NO_REFCOUNT)
def copy_vector_into(x, out):
    """``out[:] = x`` by a loop (x and out of one length)."""
    for a in range(x.shape[0]):
        out[a] = x[a]


# inlined into its callers, not called: a product here may fall back on BLAS (which copies),
# so it cannot drop reference counts, and a call would pay them (lieint.fast._jit)
@njit(cache=True, inline="always")
def mm_small_into(A, B, out):
    """:func:`mm_into` with the unrolled n × n products of :mod:`lieint.fast.small_products`
    for 3 ≤ n ≤ 8 (the same bits; 73 against 125 ns at n = 6), the product of the n-dimensional
    top's kernels, whose step is matrix products, and of their exponential
    (:data:`expm_skew_small_into`). Other shapes go to :func:`mm_into`."""
    if not square_into(A, B, out):
        mm_into(A, B, out)


@njit(cache=True, **NO_REFCOUNT)
def mm_unrolled_into(A, B, out):
    """``out = A B`` without BLAS: the unrolled products for 3 ≤ n ≤ 8, loops otherwise — so it
    allocates nothing and runs without reference counts (:mod:`lieint.fast._jit`); the
    n-dimensional top's small-n stage functions (:func:`lieint.fast.topn_step._act_small`, …)."""
    if not square_into(A, B, out):
        _loops_into(A, B, out)


@njit(cache=True, **NO_REFCOUNT)
def _loops_into(A, B, out):
    """``out = A B`` by loops, each entry a dot product summed over j in order from 0.

    The sum sits in a register: accumulated in ``out`` (row by row, ``out[i, :] += a B[j, :]``),
    every term was a load and a store, since out might share memory with B for the compiler.
    The same additions in the same order, so the same bits; 1.5× faster at n = 6, 1.3× at n = 8,
    1.15× at n = 4."""
    n, k = A.shape
    m = B.shape[1]
    for i in range(n):
        for c in range(m):
            acc = 0.0
            for j in range(k):
                acc += A[i, j] * B[j, c]
            out[i, c] = acc


@njit(cache=True)
def mv(A, x):
    """``A x`` by loops."""
    n, k = A.shape
    out = np.zeros(n)
    for i in range(n):
        acc = 0.0
        for j in range(k):
            acc += A[i, j] * x[j]
        out[i] = acc
    return out
