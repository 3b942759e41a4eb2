"""Splitting methods with exactly integrable pieces for the free and the heavy top (docs/theory.md §11).

**Free top, any n.** In the eigenbasis ``B = P diag(b) Pᵀ`` (``Ã = PᵀAP``) the kinetic energy
is a sum over the coordinate planes::

    T = ¼ tr(ΩA) = Σ_{i<j} T_ij,   T_ij = Ã_ij² / (2 (b_i + b_j)),

and each ``T_ij`` generates the rotation in the plane ``(p_i, p_j)`` with the *constant*
angular velocity ``Ω_ij = −Ã_ij/(b_i + b_j)`` (``Ã_ij`` does not change under it): the exact
flow over a time τ is the group action ``(A, R) ↦ (QᵀAQ, RQ)`` with
``Q = P exp(τ Ω_ij e_i∧e_j) Pᵀ``, a plane rotation by the angle ``τ Ω_ij``. For n = 3 these are
the rotations about the principal axes (McLachlan 1993; Touma & Wisdom 1994): plane (2, 3) is
axis 1, and so on. The split is named by the order of the axes, "123", "213", "312", …
(default: the planes in lexicographic order, "321"); Fassò (2003) shows that the energy
error depends on this choice by orders of magnitude with the moments of inertia
(``benchmarks/long_time.py`` measures it).

**Heavy top, any n.** ``H = T − U`` with ``U = M⟨Γ, X_G⟩``: the free part as above, and the
gravity *kick* ``Ȧ = M X_G ∧ Γ`` (Γ, R fixed), exact as ``A ↦ A + τ M X_G ∧ Γ`` — the SE(n)
action of ``(I, τ M X_G)``. With ``free="exact"`` (n = 3) the free part is one exact flow of the
free top (:func:`~lieint.methods.exact_flow.free_top_increment`) instead of the rotations: the
splitting then has only the error of separating kinetic and potential energy.

The basic step ``S_h`` is Strang's symmetric composition of the pieces (heavy top: kick h/2,
free part h, kick h/2; free part: ``T₁(h/2) … T_{m−1}(h/2) T_m(h) T_{m−1}(h/2) … T₁(h/2)``),
order 2. Every piece is an exact Hamiltonian flow on the Lie–Poisson space and a group
action, so the methods are Poisson (symplectic on the leaves), keep the Casimirs and
``|Γ|`` to round-off and have bounded energy error; the free-top splitting also keeps the
space momentum (each piece does). Orders 4 and 6 compose ``S`` symmetrically:

* ``"yoshida"`` (default, Yoshida 1990): order 4 the triple jump ``S(γ₁h) S(γ₂h) S(γ₁h)``,
  ``γ₁ = 1/(2 − 2^{1/3})``, ``γ₂ = 1 − 2γ₁`` (3 basic steps); order 6 Yoshida's 7-step
  symmetric composition "solution A", ``w₁ = −1.17767998417887``, ``w₂ = 0.235573213359357``,
  ``w₃ = 0.784513610477560``, ``w₀ = 1 − 2(w₁ + w₂ + w₃)``, steps ``w₃ w₂ w₁ w₀ w₁ w₂ w₃``;
  higher orders apply triple jumps to it (order 8: 21 basic steps);
* ``"triple_jump"``: the triple jump applied recursively, ``γ₁ = 1/(2 − 2^{1/(q+1)})`` raising
  the order from q to q + 2 (9 basic steps for order 6; large error constants);
* ``"suzuki"``: the fractal ``S(p h)² S((1 − 4p) h) S(p h)²``, ``p = 1/(4 − 4^{1/(q+1)})``
  (Suzuki 1990; 5 basic steps for order 4, 25 for order 6), the smallest error constants per step.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

from ..groups.bivectors import wedge
from .base import Method, MethodSpec, StepResult
from .composition import COMPOSITIONS, composition_coefficients
from .registry import AUTO, register

__all__ = ["COMPOSITIONS", "Splitting", "composition_coefficients"]

#: how the free part is integrated
FREE_PARTS = ("rotations", "exact")
_STRUCTURES = ("free_top", "heavy_top")


def _planes(n: int, split: str | None) -> list[tuple[int, int]]:
    """The coordinate planes of the free part in the order of the split."""
    if split is None:
        return [(i, j) for i in range(n) for j in range(i + 1, n)]
    if n != 3:
        raise ValueError(f"`split` names an order of the three principal axes (n = 3); this body has n = {n}.")
    if sorted(split) != ["1", "2", "3"]:
        raise ValueError(f"`split` must be an order of the principal axes such as '123' or '213'; got {split!r}.")
    plane = {"1": (1, 2), "2": (0, 2), "3": (0, 1)}  # axis k ↔ the plane of the other two
    return [plane[a] for a in split]


@dataclass(frozen=True)
class Splitting(Method):
    """A splitting method for the free or heavy top (see the module docstring).

    Parameters
    ----------
    name : str
        Name shown in tables.
    order : {2, 4, 6}
        Order of the composition.
    split : str or None
        n = 3: the order of the principal axes ("123", "213", …; axis k is column k of
        ``system.inertia.P``, the body axis itself when B is diagonal). None: the planes
        ``(i, j)``, i < j, in lexicographic order (for n = 3 that is "321": planes (1, 2),
        (1, 3), (2, 3) are the axes 3, 2, 1).
    composition : {"yoshida", "triple_jump", "suzuki"}
        Composition scheme of orders 4 and 6.
    free : {"rotations", "exact"}
        The free part as a Strang composition of the plane rotations, or (n = 3) its exact
        elliptic flow.

    Examples
    --------
    >>> import lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    >>> method = lieint.get_method("splitting4", split="213")
    >>> sol = lieint.integrate(top, y0, (0.0, 10.0), h=0.1, method=method)
    >>> bool(sol.drift("casimirs").max() < 1e-13)
    True
    """

    name: str
    order: int
    split: str | None = None
    composition: str = "yoshida"
    free: str = "rotations"

    group_action = True

    def __post_init__(self):
        if self.order not in (2, 4, 6):
            raise ValueError(f"`order` of a splitting must be 2, 4 or 6; got {self.order!r}.")
        if self.split is not None:
            if not isinstance(self.split, str):
                raise TypeError(f"`split` must be a string such as '123' or '213'; got {type(self.split).__name__}.")
            _planes(3, self.split)
        composition_coefficients(self.order, self.composition)  # validates the scheme
        if self.free not in FREE_PARTS:
            raise ValueError(f"`free` must be one of {list(FREE_PARTS)}; got {self.free!r}.")
        if self.free == "exact" and self.split is not None:
            raise ValueError("`split` names the order of the rotations; it does not apply with free='exact'.")

    @property
    def coefficients(self) -> np.ndarray:
        """Fractions of h of the basic Strang steps."""
        return composition_coefficients(self.order, self.composition)

    def check_system(self, system) -> None:
        structure = getattr(system, "structure", frozenset())
        if not any(s in structure for s in _STRUCTURES):
            raise ValueError(
                f"`method` {self.name!r} splits the free top (structure 'free_top', lieint.EulerTop) or the heavy "
                f"top (structure 'heavy_top', lieint.HeavyTop) into exactly solvable flows; got "
                f"{type(system).__name__} with structure {sorted(structure)}."
            )
        if self.split is not None:
            _planes(system.inertia.n, self.split)
        if self.free == "exact" and system.inertia.n != 3:
            raise ValueError(
                f"`method` {self.name!r} with free='exact' needs a 3D body (the elliptic flow); "
                f"got n = {system.inertia.n}."
            )

    def step(self, system, t: float, y: dict, h: float, state=None) -> StepResult:
        pieces = _Pieces(system, self.split, self.free == "exact")
        for c in self.coefficients:
            y = pieces.strang(y, c * h)
        return StepResult(y, None, len(self.coefficients), None)

    def compiled(self):
        """The compiled engine's form: the free 3D top's rotations in machine code
        (:mod:`lieint.fast.top3_split`), the heavy top's and the n-D top's through their compiled
        pieces (:mod:`lieint.fast.pieces_split`); ``free="exact"`` runs on the numpy path."""
        if self.free != "rotations" or not self.steps_as(Splitting, ("step", "check_system")):
            return None
        from ..fast.forms import MapForm

        substeps = tuple(float(c) for c in self.coefficients)
        return MapForm("splitting", COMPILED_SPLITTINGS, substeps, planes=tuple(_planes(3, self.split)))


#: where the splittings have compiled stage code: system form (class name) -> module
COMPILED_SPLITTINGS = {"Top3Form": "lieint.fast.top3_split", "PiecesForm": "lieint.fast.pieces_split"}


class _Pieces:
    """The exact flows of one system: plane rotations and (heavy top) the gravity kick."""

    def __init__(self, system, split, exact: bool = False):
        self.system, self.exact = system, exact
        inertia = system.inertia
        self.n, self.b, self.P, self.diagonal = inertia.n, inertia.b, inertia.P, inertia.diagonal
        self.planes = _planes(self.n, split)
        self.heavy = "heavy_top" in system.structure
        self.MXG = system.mass * system.center_of_mass if self.heavy else None

    def rotate(self, y: dict, plane: tuple[int, int], tau: float) -> dict:
        i, j = plane
        A = y["A"]
        a = A[..., i, j] if self.diagonal else (self.P.T @ A @ self.P)[..., i, j]
        theta = -tau * a / (self.b[i] + self.b[j])  # τ Ω_ij
        c, s = np.cos(theta), np.sin(theta)
        Q = np.broadcast_to(np.eye(self.n, dtype=theta.dtype), A.shape).copy()  # complex kept (lieint.tangent)
        Q[..., i, i] = c
        Q[..., j, j] = c
        Q[..., i, j] = s  # exp(θ e_i∧e_j): the (i, j) entry of e_i∧e_j is +1
        Q[..., j, i] = -s
        if not self.diagonal:
            Q = self.P @ Q @ self.P.T
        return self.system.act(self._element(Q), y)

    def _element(self, Q: np.ndarray) -> np.ndarray:
        if not self.heavy:
            return Q
        n = self.n
        g = np.zeros(Q.shape[:-2] + (n + 1, n + 1), dtype=Q.dtype)
        g[..., :n, :n] = Q
        g[..., n, n] = 1.0
        return g

    def kick(self, y: dict, tau: float) -> dict:
        out = dict(y)
        out["A"] = y["A"] + tau * wedge(np.broadcast_to(self.MXG, y["Gamma"].shape), y["Gamma"])
        return out

    def free(self, y: dict, h: float) -> dict:
        if self.exact:
            from .exact_flow import free_top_increment

            return self.system.act(self._element(free_top_increment(self.system.inertia, y["A"], h)), y)
        planes = self.planes
        for p in planes[:-1]:
            y = self.rotate(y, p, 0.5 * h)
        y = self.rotate(y, planes[-1], h)
        for p in reversed(planes[:-1]):
            y = self.rotate(y, p, 0.5 * h)
        return y

    def strang(self, y: dict, h: float) -> dict:
        if not self.heavy:
            return self.free(y, h)
        return self.kick(self.free(self.kick(y, 0.5 * h), h), 0.5 * h)


# -- the registry's entries -------------------------------------------------------------------


def _build(name: str, order: int, coordinates: str | None = None, split=AUTO, composition=AUTO, free=AUTO) -> Splitting:
    split = None if split is AUTO else split
    composition = "yoshida" if composition is AUTO else composition
    free = "rotations" if free is AUTO else free
    label = name if split is None else f"{name}[{split}]"
    if composition != "yoshida":
        label = f"{label}[{composition}]"
    if free != "rotations":
        label = f"{label}[free={free}]"
    return Splitting(label, order, split, composition, free)


for _order in (2, 4, 6):
    _name = f"splitting{_order}"
    _how = "Strang" if _order == 2 else "Yoshida/Suzuki composition of Strang"
    register(
        MethodSpec(
            _name,
            "splitting",
            _order,
            partial(_build, _name, _order),
            description=f"{_how} splitting into exact rotations (free top) + gravity kick (heavy top), order {_order}",
            options=("split", "composition", "free"),
        )
    )
