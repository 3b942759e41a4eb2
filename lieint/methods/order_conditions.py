"""Runge–Kutta order conditions from rooted trees (Butcher's theory).

A tableau has order p iff ``Φ(τ) = 1/γ(τ)`` for every rooted tree τ with at most p
vertices, where the elementary weight ``Φ(τ) = bᵀ g(τ)`` uses ``g(•) = 1`` and
``g([τ₁, …, τ_m]) = Π_i A g(τ_i)`` (componentwise product), and the density
``γ([τ₁, …, τ_m]) = |τ| Π_i γ(τ_i)``. RKMK inherits the order of its tableau when
dexp⁻¹ is truncated at degree ≥ p − 2 (Munthe-Kaas 1999).
"""

from __future__ import annotations

from functools import cache
from itertools import combinations_with_replacement

import numpy as np

__all__ = ["order_residuals", "rooted_trees", "tree_density", "tree_string"]

Tree = tuple  # a tree is the sorted tuple of its subtrees; the single vertex is ()


@cache
def rooted_trees(order: int) -> tuple[Tree, ...]:
    """All rooted trees with exactly ``order`` vertices, canonical form (order ≥ 1)."""
    if order == 1:
        return ((),)
    trees: set[Tree] = set()
    for partition in _partitions(order - 1):
        # children: one tree of each size in the partition, chosen with repetition
        for children in _children_for(partition):
            trees.add(tuple(sorted(children)))
    return tuple(sorted(trees))


def _partitions(n: int, largest: int | None = None):
    largest = n if largest is None else largest
    if n == 0:
        yield ()
        return
    for k in range(min(n, largest), 0, -1):
        for rest in _partitions(n - k, k):
            yield (k,) + rest


def _children_for(partition: tuple[int, ...]):
    groups: dict[int, int] = {}
    for k in partition:
        groups[k] = groups.get(k, 0) + 1
    choices = [list(combinations_with_replacement(rooted_trees(size), count)) for size, count in groups.items()]
    yield from _product_concat(choices)


def _product_concat(choices):
    if not choices:
        yield ()
        return
    for first in choices[0]:
        for rest in _product_concat(choices[1:]):
            yield tuple(first) + rest


def tree_size(tree: Tree) -> int:
    return 1 + sum(tree_size(c) for c in tree)


def tree_density(tree: Tree) -> int:
    """γ(τ) = |τ| Π γ(τ_i)."""
    out = tree_size(tree)
    for child in tree:
        out *= tree_density(child)
    return out


def tree_string(tree: Tree) -> str:
    """Bracket notation: ``•`` for a vertex, ``[τ₁ τ₂]`` for a root with children."""
    if not tree:
        return "•"
    return "[" + " ".join(tree_string(c) for c in tree) + "]"


def _stage_vector(tree: Tree, A: np.ndarray) -> np.ndarray:
    g = np.ones(A.shape[0])
    for child in tree:
        g = g * (A @ _stage_vector(child, A))
    return g


def order_residuals(A: np.ndarray, b: np.ndarray, order: int) -> list[tuple[Tree, float]]:
    """``(τ, Φ(τ) − 1/γ(τ))`` for every rooted tree with at most ``order`` vertices."""
    out = []
    for p in range(1, order + 1):
        for tree in rooted_trees(p):
            out.append((tree, float(b @ _stage_vector(tree, A)) - 1.0 / tree_density(tree)))
    return out
