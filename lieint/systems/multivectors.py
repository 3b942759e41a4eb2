"""Trivectors of Rⁿ as components, and their indices (bivectors are skew matrices, docs/theory.md §1).

A trivector ``u ∧ v ∧ w`` is stored by its coefficients on ``e_i ∧ e_j ∧ e_k`` for
``i < j < k`` (lexicographic order): the 3 × 3 minors of the matrix with rows u, v, w. For
n = 3 it has the one component ``det[u, v, w]``.
"""

from __future__ import annotations

from functools import cache
from itertools import combinations

import numpy as np

__all__ = ["trivector", "trivector_dimension", "trivector_labels"]


@cache
def _indices(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    triples = np.array(list(combinations(range(n), 3)), dtype=int).reshape(-1, 3)
    return triples[:, 0], triples[:, 1], triples[:, 2]


def trivector_dimension(n: int) -> int:
    """``C(n, 3)``, the dimension of the trivectors of Rⁿ."""
    return n * (n - 1) * (n - 2) // 6


def trivector_labels(n: int) -> list[tuple[int, int, int]]:
    """The ``(i, j, k)`` of each component, ``i < j < k``."""
    return list(combinations(range(n), 3))


def trivector(u: np.ndarray, v: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Components of ``u ∧ v ∧ w`` (batched over leading axes), shape ``(..., C(n, 3))``."""
    n = np.shape(u)[-1]
    i, j, k = _indices(n)
    ui, uj, uk = u[..., i], u[..., j], u[..., k]
    vi, vj, vk = v[..., i], v[..., j], v[..., k]
    wi, wj, wk = w[..., i], w[..., j], w[..., k]
    return ui * (vj * wk - vk * wj) - uj * (vi * wk - vk * wi) + uk * (vi * wj - vj * wi)
