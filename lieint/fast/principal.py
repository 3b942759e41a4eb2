"""The n-dimensional top's change of frame, compiled (numba, cached on disk).

The kernels of the n-D top (:mod:`lieint.fast.topn`, :mod:`lieint.fast.topn_adaptive`) step
``(Ã, R̃) = (PᵀAP, RP)`` in the principal frame of ``B = P diag(b) Pᵀ``, where the inertia
operator is an entrywise product. A run converts the user's state in once and every saved row
out; for one body the numpy expressions (``P.T @ A @ P`` on a stack, a skew part, copies) cost
about ten microseconds a conversion, more than the arithmetic, so the rows are converted here,
two products a matrix (:func:`lieint.fast.products.mm_small_into`), the momentum made exactly skew as
the generic action makes it (``skew_part``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .products import mm_small_into

__all__ = ["to_principal", "to_user"]


@njit(cache=True)
def _conjugate_skew(left, X, right, out, tmp):
    """``out = skew(left · X · right)``, ``skew(C) = (C − Cᵀ)/2``."""
    mm_small_into(left, X, tmp)
    mm_small_into(tmp, right, out)
    n = out.shape[0]
    for a in range(n):
        for c in range(a, n):
            d = 0.5 * (out[a, c] - out[c, a])
            out[a, c] = d
            out[c, a] = -d


@njit(cache=True, nogil=True)
def _convert(A, R, P, inward, out_A, out_R):
    """Every matrix of A (m, n, n) and R (m, n, n) or (m, 0, 0): inward ``skew(PᵀAP)``, ``RP``;
    outward ``skew(PAPᵀ)``, ``RPᵀ``."""
    n = P.shape[0]
    tmp = np.empty((n, n))
    Pt = np.ascontiguousarray(P.T)
    left, right = (Pt, P) if inward else (P, Pt)
    for m in range(A.shape[0]):
        _conjugate_skew(left, A[m], right, out_A[m], tmp)
    if R.shape[1] > 0:
        for m in range(R.shape[0]):
            mm_small_into(R[m], right, out_R[m])


def _run(A: np.ndarray, R: np.ndarray | None, P: np.ndarray, inward: bool):
    n = P.shape[0]
    A = np.ascontiguousarray(A, dtype=float).reshape(-1, n, n)
    R_in = np.empty((A.shape[0], 0, 0)) if R is None else np.ascontiguousarray(R, dtype=float).reshape(-1, n, n)
    out_A, out_R = np.empty_like(A), np.empty_like(R_in)
    _convert(A, R_in, P, inward, out_A, out_R)
    return out_A, (None if R is None else out_R)


def to_principal(A: np.ndarray, R: np.ndarray | None, P: np.ndarray):
    """``(skew(PᵀAP), RP)`` of stacks of n × n matrices (flattened to ``(m, n, n)``; R may be
    None): the state in the principal frame, Ã exactly skew."""
    return _run(A, R, P, True)


def to_user(A: np.ndarray, R: np.ndarray | None, P: np.ndarray):
    """``(skew(PÃPᵀ), R̃Pᵀ)`` of stacks of n × n matrices (flattened to ``(m, n, n)``; R may be
    None): the user's frame, A exactly skew."""
    return _run(A, R, P, False)
