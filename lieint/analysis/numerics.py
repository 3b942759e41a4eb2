"""Numerical ranks: central-difference Jacobians and SVD ranks with a stated threshold.

A rank is the number of singular values above ``threshold × (largest singular value)``; the
reports keep the smallest kept and the largest dropped singular value, so the gap that decides
the rank is visible.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["NumericalRank", "central_jacobian", "numerical_rank"]

#: default relative threshold of the SVD ranks
RANK_THRESHOLD = 1e-7
#: default step of the central differences (error O(step²) + O(ε/step) ≈ 1e-10 relative)
DIFFERENCE_STEP = 1e-5


@dataclass(frozen=True)
class NumericalRank:
    """The rank of a matrix by SVD with a relative threshold.

    Attributes
    ----------
    rank : int
    threshold : float
        Relative threshold: singular values ``s > threshold · s_max`` count.
    kept : float
        Smallest counted singular value over ``s_max`` (1.0 when the rank is 0 or full-size).
    dropped : float
        Largest discarded singular value over ``s_max`` (0.0 when none is discarded).
    """

    rank: int
    threshold: float
    kept: float
    dropped: float

    @property
    def gap(self) -> float:
        """``kept / dropped`` (inf when nothing is dropped): how clear the decision is."""
        return np.inf if self.dropped == 0 else self.kept / self.dropped


def numerical_rank(M: np.ndarray, threshold: float = RANK_THRESHOLD) -> NumericalRank:
    """Rank of ``M`` by SVD with a relative threshold (see :class:`NumericalRank`).

    Parameters
    ----------
    M : ndarray
        The matrix (a vector is one row).
    threshold : float
        Singular values above ``threshold`` times the largest count.

    Returns
    -------
    NumericalRank
        The rank with the smallest kept and largest dropped relative singular values.
    """
    M = np.atleast_2d(np.asarray(M, dtype=float))
    if M.size == 0:
        return NumericalRank(0, threshold, 1.0, 0.0)
    s = np.linalg.svd(M, compute_uv=False)
    if s[0] == 0:
        return NumericalRank(0, threshold, 1.0, 0.0)
    rel = s / s[0]
    r = int(np.sum(rel > threshold))
    kept = float(rel[r - 1]) if r > 0 else 1.0
    dropped = float(rel[r]) if r < rel.size else 0.0
    return NumericalRank(r, threshold, kept, dropped)


def central_jacobian(f: Callable[[np.ndarray], np.ndarray], dim: int, step: float = DIFFERENCE_STEP) -> np.ndarray:
    """``∂f/∂z`` at ``z = 0`` by central differences, shape ``(len(f(0)), dim)``."""
    cols = []
    for k in range(dim):
        e = np.zeros(dim)
        e[k] = step
        cols.append((np.ravel(f(e)) - np.ravel(f(-e))) / (2.0 * step))
    return np.stack(cols, axis=-1)


def normalised_rows(J: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Rows of J scaled to unit length, so that integrals of different sizes weigh alike (this
    keeps the rank). A row below ``1e-6 |f(0)|`` is a constant seen through round-off
    (``ε|f|/step ≈ 1e-11 |f|``) and is dropped."""
    norms = np.linalg.norm(J, axis=1)
    keep = norms > 1e-6 * np.abs(np.ravel(values))
    keep &= norms > 0
    return J[keep] / norms[keep, None]
