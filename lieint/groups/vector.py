"""A vector space as an abelian Lie group (translations), and direct products of groups.

They let a Lie-group method move state fields that have no rotational structure -- the
body angular velocity of a rolling ball, the velocity of a free body's centre -- in the
same step as the fields moved by SO(n) or SE(n). On an abelian factor exp and cay are the
identity and dexp⁻¹ = dcay⁻¹ = id, so that part of RKMK is the classical RK scheme.
"""

from __future__ import annotations

import numpy as np

from .base import LieGroup

__all__ = ["ProductGroup", "VectorSpace"]


class VectorSpace(LieGroup):
    """``(Rᵈ, +)`` with elements of trailing shape ``shape`` (e.g. ``(n,)`` or ``(n, n)``).

    Group and algebra elements are the same arrays; the group law is addition.

    Parameters
    ----------
    shape : tuple of int
        Trailing shape of an element.
    antisymmetric : bool
        The field this factor moves holds skew matrices (shape ``(n, n)``), e.g. a rolling
        ball's body angular velocity Ω: the directions a state can move in are the skew ones.
        The group law is unchanged (a sum of skew matrices is skew); what asks for a basis of
        the directions — the energy projection of :mod:`lieint.methods.energy_projection` — takes
        ``E_jk − E_kj`` instead of every unit matrix.
    """

    def __init__(self, shape: tuple[int, ...], antisymmetric: bool = False):
        self.shape = tuple(int(s) for s in shape)
        if antisymmetric and (len(self.shape) != 2 or self.shape[0] != self.shape[1]):
            raise ValueError(f"`antisymmetric` needs a square shape (n, n); got {self.shape}.")
        self.antisymmetric = bool(antisymmetric)
        self.dim = int(np.prod(self.shape))
        self.name = f"R^{self.shape}"

    def exp(self, X):
        return X

    def cay(self, X):
        # cay of a nilpotent translation generator is I + X: the translation by X itself
        return X

    def dexpinv(self, u, v, degree=None):
        return v

    def dcayinv(self, X, v):
        return v

    def ad_spectral_radius(self, X):
        return np.zeros(np.shape(X)[: np.ndim(X) - len(self.shape)])

    def identity(self, batch_shape=()):
        return np.zeros(tuple(batch_shape) + self.shape)

    def multiply(self, g, h):
        return g + h

    def inverse(self, g):
        return -g

    def log(self, g):
        return g

    def project(self, g):
        # every array of the right shape is an element: nothing to remove
        return g

    def __repr__(self) -> str:
        return f"VectorSpace({self.shape}{', antisymmetric=True' if self.antisymmetric else ''})"


class ProductGroup(LieGroup):
    """Direct product ``G₁ × G₂ × …``: elements are tuples, every operation acts per factor.

    Brackets of a direct product are componentwise, so dexp⁻¹ and dcay⁻¹ are too, and the
    spectral radius of ``ad`` is the largest over the factors.
    """

    def __init__(self, *factors: LieGroup):
        if not factors or not all(isinstance(f, LieGroup) for f in factors):
            raise TypeError("`ProductGroup` takes one or more LieGroup factors.")
        self.factors = tuple(factors)
        self.dim = sum(f.dim for f in factors)
        self.name = " x ".join(f.name for f in factors)

    def exp(self, X):
        return tuple(f.exp(x) for f, x in zip(self.factors, X, strict=True))

    def cay(self, X):
        return tuple(f.cay(x) for f, x in zip(self.factors, X, strict=True))

    def dexpinv(self, u, v, degree=None):
        return tuple(f.dexpinv(a, b, degree) for f, a, b in zip(self.factors, u, v, strict=True))

    def dcayinv(self, X, v):
        return tuple(f.dcayinv(a, b) for f, a, b in zip(self.factors, X, v, strict=True))

    def ad_spectral_radius(self, X):
        return np.maximum.reduce([f.ad_spectral_radius(x) for f, x in zip(self.factors, X, strict=True)])

    def lincomb(self, weights, elements):
        return tuple(f.lincomb(weights, [e[i] for e in elements]) for i, f in enumerate(self.factors))

    def negate(self, X):
        return tuple(f.negate(x) for f, x in zip(self.factors, X, strict=True))

    def identity(self, batch_shape=()):
        return tuple(f.identity(batch_shape) for f in self.factors)

    def multiply(self, g, h):
        return tuple(f.multiply(a, b) for f, a, b in zip(self.factors, g, h, strict=True))

    def inverse(self, g):
        return tuple(f.inverse(a) for f, a in zip(self.factors, g, strict=True))

    def log(self, g):
        return tuple(f.log(a) for f, a in zip(self.factors, g, strict=True))

    def project(self, g):
        return tuple(f.project(a) for f, a in zip(self.factors, g, strict=True))

    def __repr__(self) -> str:
        return f"ProductGroup({', '.join(map(repr, self.factors))})"
