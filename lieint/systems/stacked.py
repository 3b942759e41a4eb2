"""Systems with per-member parameters: many bodies of one kind, different bodies, one batch.

A sweep over a parameter (a moment of inertia, a mass, gravity) makes a different system at
every point. Stacking them gives one system whose parameters carry a leading batch axis that
broadcasts against the state's batch axis ``(k, ...)`` (and the saved series ``(m, k, ...)``),
so all the members run as one batched call on the generic path.

A system class supports stacking by a class method ``stack_parameters(systems, counts)``
returning the stacked system (``counts[i]`` consecutive members use ``systems[i]``); the Euler
top and the heavy top are stacked here. :func:`stack_systems` returns None for anything else,
and callers then run each system's members as their own batch.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..groups.bivectors import inner, skew_part
from ..groups.so import project_to_so
from .euler_top import EulerTop
from .heavy_top import HeavyTop

__all__ = ["StackedInertia", "stack_systems"]


class StackedInertia:
    """Inertia operators of k bodies: ``B``, ``b``, ``P`` with a leading member axis.

    Same maps as :class:`lieint.systems.rigid.InertiaOperator` (``A = −(BΩ + ΩB)``,
    ``Ω_ij = −Ã_ij/(b_i + b_j)`` in each body's eigenbasis, ``T = ¼ tr(ΩA)``), member by member.
    """

    def __init__(self, operators, counts: Sequence[int]):
        counts = np.asarray(counts, dtype=int)

        def rep(name):
            return np.repeat(np.stack([getattr(op, name) for op in operators]), counts, axis=0)

        self.n = operators[0].n
        self.B, self.b, self.P = rep("B"), rep("b"), rep("P")
        self.minus_inv_pair, self.B2 = rep("minus_inv_pair"), rep("B2")
        self.diagonal = all(op.diagonal for op in operators)

    @property
    def principal_moments(self) -> np.ndarray:
        """n = 3: ``I = tr(B) − b`` per member, shape ``(k, 3)``."""
        return self.b.sum(axis=-1, keepdims=True) - self.b

    def momentum(self, Omega: np.ndarray) -> np.ndarray:
        """``A = −(BΩ + ΩB)`` member by member."""
        return -(self.B @ Omega + Omega @ self.B)

    def angular_velocity(self, A: np.ndarray) -> np.ndarray:
        """Ω from A member by member (exactly skew, as the single operator)."""
        if self.diagonal:
            return skew_part(A * self.minus_inv_pair)
        P = self.P
        return skew_part(P @ ((np.swapaxes(P, -1, -2) @ A @ P) * self.minus_inv_pair) @ np.swapaxes(P, -1, -2))

    def energy(self, A: np.ndarray) -> np.ndarray:
        """``T = ¼ tr(ΩA)`` member by member."""
        return -0.25 * inner(self.angular_velocity(A), A)


#: why a stack of different tops offers no parameters to lieint.sensitivity
STACK_REFUSAL = "a stack of different tops has one value per member; differentiate each top on its own"


class _StackedEulerTop(EulerTop):
    """k Euler tops with their own mass tensors, one batch (no compiled kernel, no Manakov integrals)."""

    def __init__(self, tops: Sequence[EulerTop], counts: Sequence[int]):
        first = tops[0]
        self.inertia = StackedInertia([t.inertia for t in tops], counts)
        self.B, self.b, self.P = self.inertia.B, self.inertia.b, self.inertia.P
        self.n = first.n
        self.group = first.group
        self.orientation = first.orientation
        self.fields = dict(first.fields)
        self._diagonal = self.inertia.diagonal
        self._minus_inv_pair = self.inertia.minus_inv_pair
        self._B2 = self.inertia.B2
        self.members = int(np.sum(counts))

    @property
    def invariants(self):
        declared = dict(super().invariants)
        declared.pop("manakov")  # its normalisation is per body; not defined for a stack
        return declared

    def compiled(self):
        return None

    def parameter_values(self) -> dict:
        return {}  # one value per member: differentiate each top on its own (parameter_refusals)

    def parameter_refusals(self) -> dict:
        return {name: STACK_REFUSAL for name in ("B",)}

    def __repr__(self) -> str:
        return f"StackedEulerTop(n={self.n}, members={self.members}, orientation={self.orientation})"


class _StackedHeavyTop(HeavyTop):
    """k heavy tops with their own mass tensors, masses, centres of mass and gravity, one batch."""

    def __init__(self, tops: Sequence[HeavyTop], counts: Sequence[int]):
        first = tops[0]
        reps = np.asarray(counts, dtype=int)
        self.top = _StackedEulerTop([t.top for t in tops], counts)
        self.inertia = self.top.inertia
        self.B, self.n = self.top.B, first.n
        self.mass = np.repeat([t.mass for t in tops], reps)
        self.center_of_mass = np.repeat(np.stack([t.center_of_mass for t in tops]), reps, axis=0)
        self.gravity = np.repeat(np.stack([t.gravity for t in tops]), reps, axis=0)
        self.orientation = first.orientation
        self.group = first.group
        self.fields = dict(first.fields)
        self._MXG = self.mass[:, None] * self.center_of_mass
        self._extra = {}
        self.members = int(reps.sum())

    def energy(self, A: np.ndarray, Gamma: np.ndarray) -> np.ndarray:
        """``H = T − U`` member by member (``U = M⟨Γ, X_G⟩`` with each member's M X_G)."""
        return self.top.energy(A) - np.sum(Gamma * self._MXG, axis=-1)

    def project(self, y):
        Gam = y["Gamma"]
        # each member keeps its own |g|
        scale = np.linalg.norm(self.gravity, axis=-1, keepdims=True) / np.linalg.norm(Gam, axis=-1, keepdims=True)
        out = {"A": skew_part(y["A"]), "Gamma": Gam * scale}
        if self.orientation:
            out["R"] = project_to_so(y["R"])
        return out

    def parameter_values(self) -> dict:
        return {}  # one value per member: differentiate each top on its own (parameter_refusals)

    def parameter_refusals(self) -> dict:
        return {name: STACK_REFUSAL for name in ("mass_tensor", "mass", "center_of_mass", "gravity")}

    def __repr__(self) -> str:
        return f"StackedHeavyTop(n={self.n}, members={self.members}, orientation={self.orientation})"


def _stack_euler(systems, counts):
    return _StackedEulerTop(systems, counts)


def _stack_heavy(systems, counts):
    if any(s._extra for s in systems):  # named cases add integrals of their own parameters
        return None
    return _StackedHeavyTop(systems, counts)


_BUILTIN = {EulerTop: _stack_euler, HeavyTop: _stack_heavy}


def stack_systems(systems: Sequence, counts: Sequence[int]):
    """One system running ``counts[i]`` members of ``systems[i]`` in a single batch, or None.

    Parameters
    ----------
    systems : sequence of LieGroupSystem
        Systems of one class with the same fields (e.g. Euler tops with different mass tensors).
    counts : sequence of int
        Consecutive members per system.

    Returns
    -------
    LieGroupSystem or None
        The stacked system, or None when the class cannot be stacked (no ``stack_parameters``
        class method and no built-in rule) or the systems differ in class or fields.
    """
    if len(systems) != len(counts) or not systems:
        raise ValueError(
            f"`systems` and `counts` must have the same nonzero length; got {len(systems)} and {len(counts)}."
        )
    cls = type(systems[0])
    if any(type(s) is not cls or s.fields != systems[0].fields for s in systems):
        return None
    hook = getattr(cls, "stack_parameters", None)
    if hook is not None:
        return hook(list(systems), list(counts))
    rule = _BUILTIN.get(cls)
    return None if rule is None else rule(list(systems), list(counts))
