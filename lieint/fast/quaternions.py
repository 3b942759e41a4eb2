"""Unit quaternions ↔ rotation matrices for the SIMD-lanes kernel, compiled (loops over bodies).

The lanes kernel (:mod:`lieint.fast.lanes`) holds each body's orientation as a unit quaternion
``q = (w, x, y, z)`` in structure-of-arrays layout, ``(4, N)``; a run turns the caller's R into
quaternions once and the saved quaternions back into matrices. For large ensembles numpy's
stacked expressions cost about a millisecond per thousand bodies each way, a fifth of a
thousand-step call; these loops take a tenth of that.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["lanes_from_matrices", "matrices_from_lanes", "rotation_into"]


@njit(cache=True, inline="always")
def rotation_into(w, x, y, z, R):
    """``R = R(q)``, the rotation of the unit quaternion ``q = (w, x, y, z)``."""
    R[0, 0] = 1 - 2 * (y * y + z * z)
    R[0, 1] = 2 * (x * y - w * z)
    R[0, 2] = 2 * (x * z + w * y)
    R[1, 0] = 2 * (x * y + w * z)
    R[1, 1] = 1 - 2 * (x * x + z * z)
    R[1, 2] = 2 * (y * z - w * x)
    R[2, 0] = 2 * (x * z - w * y)
    R[2, 1] = 2 * (y * z + w * x)
    R[2, 2] = 1 - 2 * (x * x + y * y)


@njit(cache=True)
def _to_matrices(q, out):
    """``out[s, i] = R(q[s, :, i])`` for quaternions ``q`` (m, 4, N) and matrices ``out`` (m, N, 3, 3)."""
    for s in range(q.shape[0]):
        for i in range(q.shape[2]):
            rotation_into(q[s, 0, i], q[s, 1, i], q[s, 2, i], q[s, 3, i], out[s, i])


@njit(cache=True)
def _to_quaternions(R, out):
    """``out[:, i]`` = the unit quaternion of ``R[i]`` (N, 3, 3), by the largest of the four
    pivots ``1 + tr R``, ``1 + 2R₀₀ − tr R``, … (Shepperd's method: accurate for every rotation)."""
    for i in range(R.shape[0]):
        r = R[i]
        tr = r[0, 0] + r[1, 1] + r[2, 2]
        pivots = (1 + tr, 1 + 2 * r[0, 0] - tr, 1 + 2 * r[1, 1] - tr, 1 + 2 * r[2, 2] - tr)
        k = 0
        for j in range(1, 4):
            if pivots[j] > pivots[k]:
                k = j
        if k == 0:
            v = (1 + tr, r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1])
        elif k == 1:
            v = (r[2, 1] - r[1, 2], 1 + 2 * r[0, 0] - tr, r[0, 1] + r[1, 0], r[0, 2] + r[2, 0])
        elif k == 2:
            v = (r[0, 2] - r[2, 0], r[0, 1] + r[1, 0], 1 + 2 * r[1, 1] - tr, r[1, 2] + r[2, 1])
        else:
            v = (r[1, 0] - r[0, 1], r[0, 2] + r[2, 0], r[1, 2] + r[2, 1], 1 + 2 * r[2, 2] - tr)
        scale = 2 * np.sqrt(pivots[k])
        a, b, c, d = v[0] / scale, v[1] / scale, v[2] / scale, v[3] / scale
        norm = np.sqrt(a * a + b * b + c * c + d * d)
        out[0, i], out[1, i], out[2, i], out[3, i] = a / norm, b / norm, c / norm, d / norm


def matrices_from_lanes(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(m, N, 3, 3)`` of the lanes' quaternions ``q`` ``(m, 4, N)``
    (or ``(N, 3, 3)`` of ``(4, N)``)."""
    q = np.asarray(q, dtype=float)
    single = q.ndim == 2
    q = np.ascontiguousarray(q[None] if single else q)
    out = np.empty((q.shape[0], q.shape[2], 3, 3))
    _to_matrices(q, out)
    return out[0] if single else out


def lanes_from_matrices(R: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(4, N)`` of rotation matrices ``R`` ``(N, 3, 3)``."""
    R = np.ascontiguousarray(R, dtype=float)
    out = np.empty((4, R.shape[0]))
    _to_quaternions(R, out)
    return out
