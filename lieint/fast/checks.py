"""The input checks of many 3 × 3 matrices (a batch of 3D bodies), compiled.

:func:`lieint._validation.check_skew` and :func:`lieint._validation.check_rotation` check every
matrix of a batch. For thousands of 3 × 3 matrices numpy's stacked expressions make a temporary
per term and cost about 0.1 ms per thousand matrices for each check (half a millisecond for
4,096 tops' ``A`` and ``R``, two per cent of a thousand-step ensemble call); one pass over the
nine entries of each matrix costs a tenth of that. The checks' tolerances and messages stay in
:mod:`lieint._validation`; these return only the measures.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["rotation_defects_3", "skew_defect_3"]


@njit(cache=True)
def _skew_defect_3(X):
    err = 0.0
    scale = 0.0
    nonfinite = 0.0  # stays 0 unless an entry is NaN or ±inf: then NaN, as numpy's maximum
    for m in range(X.shape[0]):
        x = X[m]
        for i in range(3):
            for j in range(3):
                scale = max(scale, abs(x[i, j]))
                err = max(err, abs(x[i, j] + x[j, i]))
                nonfinite += 0.0 * x[i, j]
    return err + nonfinite, scale + nonfinite


@njit(cache=True)
def _rotation_defects_3(R):
    worst = 0.0
    smallest_det = np.inf
    nonfinite = 0.0  # stays 0 unless an entry is NaN or ±inf: then NaN, as numpy's maximum
    for m in range(R.shape[0]):
        r = R[m]
        total = 0.0
        for i in range(3):  # RᵀR − I from the columns' dot products
            for j in range(3):
                g = r[0, i] * r[0, j] + r[1, i] * r[1, j] + r[2, i] * r[2, j] - (1.0 if i == j else 0.0)
                total += g * g
        worst = max(worst, total)
        nonfinite += 0.0 * total
        det = (
            r[0, 0] * (r[1, 1] * r[2, 2] - r[1, 2] * r[2, 1])
            - r[0, 1] * (r[1, 0] * r[2, 2] - r[1, 2] * r[2, 0])
            + r[0, 2] * (r[1, 0] * r[2, 1] - r[1, 1] * r[2, 0])
        )
        smallest_det = min(smallest_det, det)
    return np.sqrt(worst + nonfinite), smallest_det + nonfinite


def skew_defect_3(X: np.ndarray) -> tuple[float, float]:
    """``max |X + Xᵀ|`` and ``max |X|`` over the finite 3 × 3 matrices of ``X`` (..., 3, 3)."""
    err, scale = _skew_defect_3(np.ascontiguousarray(X, dtype=np.float64).reshape(-1, 3, 3))
    return float(err), float(scale)


def rotation_defects_3(R: np.ndarray) -> tuple[float, float]:
    """The largest ``‖RᵀR − I‖_F`` and the smallest ``det R`` over the finite 3 × 3 matrices of
    ``R`` (..., 3, 3)."""
    worst, smallest_det = _rotation_defects_3(np.ascontiguousarray(R, dtype=np.float64).reshape(-1, 3, 3))
    return float(worst), float(smallest_det)
