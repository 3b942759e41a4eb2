"""The Euler top with its orientation stored as a rotor of Spin(n).

The rotor moves by ``exp(hΩ/2)`` on the right (``S ↦ S exp(u/2)``, the double cover of
``R ↦ R exp(u)``) and the body momentum by the sandwich ``A ↦ S̃ A S`` (= ``QᵀAQ``). The exact
projection is the rotor normalisation ``S (S̃S)^{-1/2}``. Same generator, same method, same
numbers as the matrix path up to round-off; the cost per step is that of ``2ⁿ``-dimensional
products instead of n × n matrix products.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .._validation import check_skew
from ..groups.base import LieGroup
from ..groups.bivectors import bivector_dimension, skew_part
from ..groups.so import SO
from ..systems.base import Invariant, Output, State
from ..systems.euler_top import EulerTop
from .algebra import algebra, matrix_to_rotor

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
        return self.ga.rotor_exp(X)

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


class RotorEulerTop(EulerTop):
    """:class:`lieint.EulerTop` with the orientation as a rotor: state ``{"A", "rotor"}``.

    Parameters
    ----------
    B : array_like, shape (n, n)
        Body mass tensor; ``2 ≤ n ≤ 8`` (Cl(n) has ``2ⁿ`` coefficients).

    Invariants: ``energy``, ``casimirs``, ``manakov`` as for the matrix top, ``momentum``
    ``a = R A Rᵀ`` (R the matrix of the rotor) and ``rotor_defect`` ``‖S̃S − 1‖``.
    """

    def __init__(self, B):
        super().__init__(B, orientation=False)
        self.ga = algebra(self.n)
        self.group = Spin(self.n)
        self.fields = {"A": (self.n, self.n), "rotor": (self.ga.size,)}

    def rotation_matrix(self, rotor: np.ndarray) -> np.ndarray:
        """R ∈ SO(n) of rotors ``(..., 2ⁿ)``."""
        return self.ga.rotor_matrix(rotor)

    def act(self, g, y: State) -> State:
        ga = self.ga
        A = ga.skew(ga.product(ga.product(ga.reverse(g), ga.bivector(y["A"])), g))
        return {"A": A, "rotor": ga.product(y["rotor"], g)}

    def infinitesimal_action(self, xi, y: State) -> State:
        A = y["A"]
        return {"A": A @ xi - xi @ A, "rotor": self.ga.product(y["rotor"], 0.5 * self.ga.bivector(xi))}

    def project(self, y: State) -> State:
        return {"A": skew_part(y["A"]), "rotor": self.ga.normalize(y["rotor"])}

    @property
    def invariants(self) -> dict[str, Invariant]:
        ga = self.ga

        def momentum(t, y):
            R = ga.rotor_matrix(y["rotor"])
            return R @ y["A"] @ np.swapaxes(R, -1, -2)

        def rotor_defect(t, y):
            S = y["rotor"]
            return np.linalg.norm(ga.product(ga.reverse(S), S) - ga.scalar(np.ones(S.shape[:-1])), axis=-1)

        declared = dict(super().invariants)
        declared["momentum"] = Invariant(momentum, "integral", "space momentum R A Rᵀ")
        declared["rotor_defect"] = Invariant(rotor_defect, "defect", "‖S̃S − 1‖ (rotor off Spin(n))")
        return declared

    @property
    def outputs(self) -> dict[str, Output]:
        out = dict(super().outputs)
        out["orientation"] = Output(
            lambda t, y: self.rotation_matrix(y["rotor"]), (self.n, self.n), "orientation R", "rotation"
        )
        return out

    def compiled(self):
        return None  # the compiled kernels step matrices, not rotors

    def initial_state(self, *, Omega=None, A=None, R=None, angular_velocity=None, rotor=None) -> State:
        """As :meth:`lieint.EulerTop.initial_state`, with the orientation given as ``R`` (a matrix,
        converted to the rotor with nonnegative scalar part) or ``rotor`` (clifford rotor(s))."""
        if R is not None and rotor is not None:
            raise ValueError("Give the orientation as `R` or as `rotor`, not both.")
        top = EulerTop(self.B, orientation=True)
        s = top.initial_state(Omega=Omega, A=A, R=R, angular_velocity=angular_velocity)
        if rotor is not None:
            from .algebra import to_values

            S = to_values(rotor)
            if S.shape[-1] != self.ga.size:
                raise ValueError(
                    f"`rotor` must be a rotor of Cl({self.n}) ({self.ga.size} coefficients); got shape {S.shape}."
                )
            defect = np.max(np.abs(self.ga.product(self.ga.reverse(S), S) - self.ga.scalar(np.ones(S.shape[:-1]))))
            if defect > 1e-10:
                raise ValueError(f"`rotor` must be a unit rotor (S̃S = 1); got ‖S̃S − 1‖ = {defect:.3g}.")
            batch = np.broadcast_shapes(s["A"].shape[:-2], S.shape[:-1])
            return {
                "A": np.broadcast_to(s["A"], batch + s["A"].shape[-2:]).copy(),
                "rotor": np.broadcast_to(S, batch + S.shape[-1:]).copy(),
            }
        return {"A": s["A"], "rotor": matrix_to_rotor(s["R"], as_multivector=False)}

    def validate_state(self, y: Mapping[str, np.ndarray], name: str = "y0") -> State:
        out = super(EulerTop, self).validate_state(y, name)  # keys, shapes, finiteness
        out["A"] = check_skew(out["A"], f"{name}['A']")
        return out

    def __repr__(self) -> str:
        return f"RotorEulerTop(n={self.n})"
