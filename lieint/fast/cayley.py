"""The Cayley map of so(n) and its exact inverse differential, written into held arrays
(numba, cached on disk): the Cayley coordinates of the n-dimensional top's kernels
(:mod:`lieint.fast.topn`, :mod:`lieint.fast.topn_adaptive`).

* :func:`cayley_into`: ``cay(u) = (I − u/2)⁻¹(I + u/2)`` by Gaussian elimination with partial
  pivoting (``I − u/2`` has singular values ≥ 1 and condition ``(1 + θ₁²/4)^{1/2}``: the result
  is orthogonal to ``ε·θ₁/2``), NaN for a non-finite u or a zero pivot;
* :func:`dcayinv_into`: ``dcay⁻¹_{−u}(ξ) = ξ + ½[u, ξ] − ¼ uξu`` in two products.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._jit import NO_REFCOUNT
from .products import mm_small_into
from .skew import _column_dominant, _finite, orthogonal_polish
from .small_cayley import cayley_square_into

__all__ = ["cayley_into", "dcayinv_into"]


@njit(cache=True, **NO_REFCOUNT)
def cayley_into(u, Q, L, T):
    """``Q = cay(u) = (I − u/2)⁻¹(I + u/2)``, or NaN when u is not finite (or so large that
    the unit diagonal is lost and the elimination meets a zero pivot); ``L`` and ``T`` are
    scratch.

    ``I − u/2`` is invertible for skew u (eigenvalues ``1 ∓ iθ_k/2``, singular values ≥ 1):
    Gaussian elimination with partial pivoting on it, the right-hand side ``I + u/2`` carried
    along, then back substitution — about 4n³/3 multiply-adds, two thirds of a product. The
    usual step (``I − u/2`` column diagonally dominant, :func:`_column_dominant`) skips the
    pivot search, which would not swap: the same operations, so the same bits — for
    4 ≤ n ≤ 6 in the unrolled code of :mod:`lieint.fast.small_cayley`. Beyond the dominant
    steps the condition ``(1 + θ₁²/4)^{1/2}`` grows with u, and a huge u (a stage of a step far
    too large) leaves Q off the orthogonal matrices: it is then brought back onto them, or made
    NaN when it is too far off to be the map (:func:`lieint.fast.skew.orthogonal_polish`), so
    that the attitude stays a rotation."""
    if _column_dominant(u):  # θ₁ < 2: condition below √2, orthogonal to a few ε
        if not cayley_square_into(u, Q):  # unrolled for 4 ≤ n ≤ 6 (the same operations)
            _eliminate(u, Q, L, False)
        return
    if not _finite(u):
        Q[:, :] = np.nan
        return
    _eliminate(u, Q, L, True)
    orthogonal_polish(Q, L, 0, T, 0)


@njit(cache=True, **NO_REFCOUNT)
def _eliminate(u, Q, L, pivot):
    """``Q = (I − u/2)⁻¹(I + u/2)`` by elimination (u finite), with partial pivoting when
    ``pivot``; NaN on a zero pivot."""
    n = u.shape[0]
    for a in range(n):
        for c in range(n):
            L[a, c] = -0.5 * u[a, c]
            Q[a, c] = 0.5 * u[a, c]
        L[a, a] += 1.0
        Q[a, a] += 1.0
    for c in range(n):
        if pivot:
            p = c
            for r in range(c + 1, n):
                if abs(L[r, c]) > abs(L[p, c]):
                    p = r
            if L[p, c] == 0.0:  # u ≳ 1e16: the unit diagonal lost, the elimination cancels — NaN
                Q[:, :] = np.nan
                return
            if p != c:
                for j in range(c, n):
                    L[c, j], L[p, j] = L[p, j], L[c, j]
                for j in range(n):
                    Q[c, j], Q[p, j] = Q[p, j], Q[c, j]
        for r in range(c + 1, n):
            f = L[r, c] / L[c, c]
            for j in range(c + 1, n):
                L[r, j] -= f * L[c, j]
            for j in range(n):
                Q[r, j] -= f * Q[c, j]
    for r in range(n - 1, -1, -1):
        for k in range(r + 1, n):
            f = L[r, k]
            for j in range(n):
                Q[r, j] -= f * Q[k, j]
        inverse = 1.0 / L[r, r]
        for j in range(n):
            Q[r, j] *= inverse


# inlined into its callers, not called: a product here may fall back on BLAS (which copies),
# so it cannot drop reference counts, and a call would pay them (lieint.fast._jit)
@njit(cache=True, inline="always")
def dcayinv_into(u, xi, out, W, tmp):
    """``out = dcay⁻¹_{−u}(ξ) = ξ + ½[u, ξ] − ¼ uξu`` (exact), for skew u, ξ: with ``W = uξ``,
    ``[u, ξ] = W − Wᵀ`` and ``uξu = Wu`` — two products; W and tmp are scratch."""
    mm_small_into(u, xi, W)
    mm_small_into(W, u, tmp)
    n = out.shape[0]
    for a in range(n):
        for c in range(n):
            out[a, c] = xi[a, c] + 0.5 * (W[a, c] - W[c, a]) - 0.25 * tmp[a, c]
