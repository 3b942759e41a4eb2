"""Torques and momenta built with the wedge product of clifford vectors (docs/theory.md §1)."""

from __future__ import annotations

import clifford
import numpy as np

from .algebra import _layout_of, algebra, to_values

__all__ = ["torque", "wedge_vectors"]


def _vectors(x, n: int | None):
    """Coefficient arrays ``(..., n)`` of clifford vectors, or plain arrays."""
    if isinstance(x, clifford.MultiVector) or (isinstance(x, np.ndarray) and x.dtype == object):
        values = to_values(x)
        dims = _layout_of(x).dims
        ga = algebra(dims)
        return values[..., ga.vector_index], dims
    arr = np.asarray(x, dtype=float)
    return arr, arr.shape[-1] if n is None else n


def wedge_vectors(u, v) -> np.ndarray:
    """``u ∧ v`` of clifford vectors (or arrays) as the skew matrix the systems use.

    Computed in Cl(n) as ``½(uv − vu)``; equals ``lieint.groups.wedge(u, v) = u vᵀ − v uᵀ``.
    """
    a, n = _vectors(u, None)
    b, _ = _vectors(v, n)
    ga = algebra(n)
    A, B = ga.vector(a), ga.vector(b)
    return ga.skew(0.5 * (ga.product(A, B) - ga.product(B, A)))


def torque(point, force, origin=None) -> np.ndarray:
    """Torque bivector ``(q − q₀) ∧ f`` of a force f applied at q about q₀ (default 0).

    Examples
    --------
    A constant force at a body point: the heavy top's torque ``M X_G ∧ Γ`` is
    ``torque(X_G, M Γ)``.
    """
    q, n = _vectors(point, None)
    f, _ = _vectors(force, n)
    if origin is not None:
        q0, _ = _vectors(origin, n)
        q = q - q0
    return wedge_vectors(q, f)
