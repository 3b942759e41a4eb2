"""The Euler top with its orientation stored as a rotor of Spin(n).

Spin(n) as a group of its own, and the Euler top's rotor form (:class:`lieint.ga.RotorForm`).

The rotor moves by ``exp(hΩ/2)`` on the right (``S ↦ S exp(u/2)``, the double cover of
``R ↦ R exp(u)``) and the body momentum by the sandwich ``A ↦ S̃ A S`` (= ``QᵀAQ``). The exact
projection is the rotor normalisation ``S (S̃S)^{-1/2}``. Same generator, same method, same
numbers as the matrix path up to round-off; the cost per step is that of ``2ⁿ``-dimensional
products instead of n × n matrix products.
"""

from __future__ import annotations

import numpy as np

from ..groups.base import LieGroup
from ..groups.bivectors import bivector_dimension
from ..groups.so import SO
from ..systems.euler_top import EulerTop
from .algebra import algebra
from .exponential import rotor_exp_of_skew
from .spin import RotorForm

__all__ = ["RotorEulerTop", "Spin"]


class Spin(LieGroup):
    """Spin(n) for the integrators: algebra elements are skew matrices (so(n) ≅ spin(n)),
    group elements are rotors ``(..., 2ⁿ)``; ``exp(u) = exp(u/2)`` in Cl(n).

    dexp⁻¹ and the convergence check are those of so(n) (the algebras are isomorphic).
    Only exponential coordinates: the Cayley map of so(n) has no rotor form used here.
    """

    def __init__(self, n: int):
        self.so = SO(n)
        self.ga = algebra(n)
        self.n = n
        self.dim = bivector_dimension(n)
        self.name = f"spin({n})"

    def identity(self, batch_shape=()):
        one = np.zeros((*batch_shape, self.ga.size))
        one[..., 0] = 1.0
        return one

    def multiply(self, g, h):
        return self.ga.product(g, h)

    def inverse(self, g):
        """``S⁻¹ = S̃`` for unit rotors."""
        return self.ga.reverse(g)

    def exp(self, X):
        return rotor_exp_of_skew(X, 0.5)

    def log(self, g):
        """The principal logarithm of the rotation under ``g`` (rotors with positive scalar part)."""
        return self.so.log(self.ga.rotor_matrix(g))

    def project(self, g):
        """``S / √⟨S S̃⟩₀``: the unit rotor nearest a slightly denormalised one."""
        norm2 = self.ga.product(g, self.ga.reverse(g))[..., :1]
        return g / np.sqrt(norm2)

    def cay(self, X):
        raise ValueError(
            "Cayley coordinates are not available for the rotor representation; use coordinates='exp' "
            "(or the matrix representation, lieint.EulerTop)."
        )

    def dexpinv(self, u, v, degree=None):
        return self.so.dexpinv(u, v, degree)

    def dcayinv(self, X, v):
        return self.so.dcayinv(X, v)

    def ad_spectral_radius(self, X):
        return self.so.ad_spectral_radius(X)


class RotorEulerTop(RotorForm):
    """:class:`lieint.EulerTop` with the orientation as a rotor: state ``{"A", "rotor"}``.

    The rotor form (:class:`lieint.ga.RotorForm`) of ``EulerTop(B)``.

    Parameters
    ----------
    B : array_like, shape (n, n)
        Body mass tensor; ``2 ≤ n ≤ 8`` (Cl(n) has ``2ⁿ`` coefficients).

    Invariants: ``energy``, ``casimirs``, ``manakov`` as for the matrix top, ``momentum``
    ``a = R A Rᵀ`` (R the matrix of the rotor) and ``rotor_defect`` ``‖S̃S − 1‖``.
    """

    def __init__(self, B):
        super().__init__(EulerTop(B))
        self.B = self.system.B

    def __repr__(self) -> str:
        return f"RotorEulerTop(n={self.n})"
