"""Bivectors of R^n stored as skew matrices (docs/theory.md §1).

Conventions
-----------
* A bivector is a skew ``(..., n, n)`` array; entry ``[i, j]`` with ``i < j`` is the
  coefficient of ``e_i ∧ e_j`` and ``dim so(n) = n(n-1)/2``.
* ``u ∧ v = u vᵀ − v uᵀ``, so ``(u ∧ v) x = u⟨v, x⟩ − v⟨u, x⟩``.
* n = 3: the hat map ``ŵ x = w × x``; the bivector of ``ŵ`` is
  ``−(w₁ e₂∧e₃ + w₂ e₃∧e₁ + w₃ e₁∧e₂)`` (mind the minus sign).
* ``⟨X, Y⟩ = tr(Xᵀ Y) = −tr(XY)``.

Every function accepts leading batch dimensions.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "bivector_coordinates",
    "bivector_dimension",
    "commutator",
    "from_bivector_coordinates",
    "hat",
    "inner",
    "skew_part",
    "vee",
    "wedge",
]


def _floats(x) -> np.ndarray:
    """``x`` as a float array, a complex one kept complex: the complex-step derivatives of
    :mod:`lieint.tangent` carry complex states through every function of the groups."""
    x = np.asarray(x)
    return x.astype(np.result_type(x.dtype, np.float64), copy=False)


def bivector_dimension(n: int) -> int:
    """``dim so(n) = n (n − 1) / 2``."""
    return n * (n - 1) // 2


def wedge(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Wedge product of vectors, ``u ∧ v = u vᵀ − v uᵀ`` (shape ``(..., n, n)``)."""
    u = _floats(u)
    v = _floats(v)
    outer = u[..., :, None] * v[..., None, :]
    return outer - np.swapaxes(outer, -1, -2)


def commutator(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Commutator ``[X, Y] = XY − YX``."""
    return X @ Y - Y @ X


def inner(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Frobenius inner product ``⟨X, Y⟩ = tr(Xᵀ Y)`` over the last two axes."""
    return np.einsum("...ij,...ij->...", X, Y)


def skew_part(X: np.ndarray) -> np.ndarray:
    """``(X − Xᵀ) / 2``."""
    X = np.asarray(X)
    return 0.5 * (X - X.swapaxes(-1, -2))  # the method: np.swapaxes adds a Python wrapper


def hat(w: np.ndarray) -> np.ndarray:
    """n = 3 hat map: ``(..., 3) → (..., 3, 3)`` with ``hat(w) @ x = w × x``."""
    w = _floats(w)
    if w.shape[-1:] != (3,):
        raise ValueError(f"`w` must have shape (..., 3); got shape {w.shape}.")
    out = np.zeros(w.shape[:-1] + (3, 3), dtype=w.dtype)
    out[..., 0, 1], out[..., 0, 2] = -w[..., 2], w[..., 1]
    out[..., 1, 0], out[..., 1, 2] = w[..., 2], -w[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -w[..., 1], w[..., 0]
    return out


def vee(X: np.ndarray) -> np.ndarray:
    """Inverse of :func:`hat`: ``(..., 3, 3) → (..., 3)`` (uses the skew part)."""
    X = _floats(X)
    if X.shape[-2:] != (3, 3):
        raise ValueError(f"`X` must have shape (..., 3, 3); got shape {X.shape}.")
    return 0.5 * np.stack(
        [X[..., 2, 1] - X[..., 1, 2], X[..., 0, 2] - X[..., 2, 0], X[..., 1, 0] - X[..., 0, 1]],
        axis=-1,
    )


def bivector_coordinates(X: np.ndarray) -> np.ndarray:
    """Coordinates of a bivector on ``e_i ∧ e_j`` (``i < j``, row-major order).

    Returns shape ``(..., n(n−1)/2)``: entries ``X[i, j]`` for ``i < j``.
    """
    X = _floats(X)
    n = X.shape[-1]
    i, j = np.triu_indices(n, k=1)
    return X[..., i, j]


def from_bivector_coordinates(c: np.ndarray, n: int) -> np.ndarray:
    """Skew ``(..., n, n)`` matrix from coordinates on ``e_i ∧ e_j`` (``i < j``)."""
    c = _floats(c)
    d = bivector_dimension(n)
    if c.shape[-1:] != (d,):
        raise ValueError(f"`c` must have shape (..., {d}) for n = {n} (n(n-1)/2 coordinates); got shape {c.shape}.")
    i, j = np.triu_indices(n, k=1)
    out = np.zeros(c.shape[:-1] + (n, n), dtype=c.dtype)
    out[..., i, j] = c
    out[..., j, i] = -c
    return out
