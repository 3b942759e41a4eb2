"""Holonomic or not: the Frobenius test of a velocity constraint (docs/theory.md §9).

A constraint ``L(x) ẋ = 0`` allows the velocities of the distribution ``D = ker L``. It is
holonomic — the motion stays on a submanifold of dimension ``dim D``, which is then the true
configuration space — iff D is involutive: the Lie bracket ``[X, Y] = DY·X − DX·Y`` of vector
fields in D stays in D (Frobenius). Numerically: span D at a point by vector fields, add
brackets of brackets until the span stops growing, and compare the dimension of the closure
with ``dim D`` (SVD ranks with a stated threshold; derivatives by central differences).

A :class:`Distribution` is given by vector fields on ambient coordinates x (a rotation is its
n² entries); the fields need only be defined near the point, and their ambient extensions give
the intrinsic brackets on the configuration manifold.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..groups.bivectors import bivector_dimension, from_bivector_coordinates
from .numerics import NumericalRank, numerical_rank

if TYPE_CHECKING:
    from ..systems.base import LieGroupSystem

__all__ = ["Distribution", "HolonomyResult", "constraint_of", "is_holonomic", "rolling_constraint"]

#: default relative threshold of the bracket ranks (nested central differences: ≈ 1e-8 accurate)
HOLONOMY_THRESHOLD = 1e-6
#: default step of the central differences of the brackets
BRACKET_STEP = 1e-4

VectorField = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Distribution:
    """A velocity distribution at a point of a configuration manifold.

    Attributes
    ----------
    name : str
        What it is ("rolling ball n = 3").
    point : ndarray
        Ambient coordinates x of the configuration.
    fields : tuple of callables
        Vector fields ``X(x) -> ẋ`` spanning the admissible velocities near the point.
    configuration_dimension : int
        Dimension of the configuration manifold the fields are tangent to.
    """

    name: str
    point: np.ndarray
    fields: tuple[VectorField, ...]
    configuration_dimension: int


@dataclass(frozen=True)
class HolonomyResult:
    """The verdict of the Frobenius test.

    Attributes
    ----------
    name : str
    holonomic : bool
        True iff the bracket closure has the dimension of the distribution.
    distribution_dimension : int
        ``dim D`` (admissible velocities).
    closure_dimension : int
        Dimension reached by D and its iterated brackets (the dimension of the reachable
        configurations near the point).
    configuration_dimension : int
    depth : int
        Bracket depth needed to reach the closure (0: none).
    rank : NumericalRank
        The rank decision of the closure.
    """

    name: str
    holonomic: bool
    distribution_dimension: int
    closure_dimension: int
    configuration_dimension: int
    depth: int
    rank: NumericalRank

    def report(self) -> str:
        verdict = "holonomic" if self.holonomic else "nonholonomic"
        r = self.rank
        return (
            f"{self.name}: configuration space {self.configuration_dimension}, admissible velocities "
            f"{self.distribution_dimension}, Lie brackets reach {self.closure_dimension} (depth {self.depth}) "
            f"→ {verdict}"
            + (
                f"; the true configuration space has dimension {self.closure_dimension}"
                if self.holonomic and self.closure_dimension < self.configuration_dimension
                else ""
            )
            + f"\n  (SVD rank threshold {r.threshold:.0e}: smallest kept {r.kept:.1e}, largest dropped {r.dropped:.1e})"
        )

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "holonomic": self.holonomic,
            "distribution_dimension": self.distribution_dimension,
            "closure_dimension": self.closure_dimension,
            "configuration_dimension": self.configuration_dimension,
            "depth": self.depth,
            "rank_threshold": self.rank.threshold,
        }

    def __str__(self) -> str:
        return self.report()


def lie_bracket(X: VectorField, Y: VectorField, step: float = BRACKET_STEP) -> VectorField:
    """The vector field ``[X, Y](x) = DY(x)·X(x) − DX(x)·Y(x)`` (central differences along X
    and Y, with a step relative to their size)."""

    def directional(F, x, w):
        size = np.linalg.norm(w)
        if size == 0:
            return np.zeros_like(x)
        eps = step / size
        return (F(x + eps * w) - F(x - eps * w)) / (2.0 * eps)

    def Z(x):
        return directional(Y, x, X(x)) - directional(X, x, Y(x))

    return Z


def is_holonomic(
    constraint: Distribution,
    *,
    threshold: float = HOLONOMY_THRESHOLD,
    step: float = BRACKET_STEP,
    max_depth: int = 3,
    verbose: bool = False,
) -> HolonomyResult:
    """Decide whether a velocity constraint is holonomic, by Lie brackets (module docstring).

    Parameters
    ----------
    constraint : Distribution
        The admissible velocities (e.g. :func:`rolling_constraint`, :func:`constraint_of`).
    threshold : float
        Relative SVD threshold of the ranks.
    step : float
        Central-difference step of the brackets.
    max_depth : int
        Deepest bracket tried.
    verbose : bool
        Print the report.

    Returns
    -------
    HolonomyResult
        The verdict, the dimensions of the distribution and of its bracket closure, and the
        depth reached.

    Examples
    --------
    >>> from lieint.analysis import is_holonomic, rolling_constraint
    >>> r = is_holonomic(rolling_constraint(3))
    >>> (r.holonomic, r.distribution_dimension, r.closure_dimension)
    (False, 3, 5)
    """
    if not isinstance(constraint, Distribution):
        raise TypeError(f"`constraint` must be a Distribution; got {type(constraint).__name__}.")
    x0 = np.asarray(constraint.point, dtype=float)
    fields = list(constraint.fields)
    if not fields:
        raise ValueError("`constraint` must have at least one vector field.")
    span = [np.ravel(F(x0)) for F in fields]
    base = numerical_rank(np.stack(span), threshold)
    dim_d = base.rank
    # keep a basis of the span: the fields that each add a dimension
    kept, vectors = [], []
    for F, v in zip(fields, span, strict=True):
        if numerical_rank(np.stack([*vectors, v]), threshold).rank > len(vectors):
            kept.append(F)
            vectors.append(v)
    generators, level, depth, rank = list(kept), list(kept), 0, base
    for d in range(1, max_depth + 1):
        if len(vectors) >= constraint.configuration_dimension:
            break
        added = []
        for G in generators:
            for F in level:
                if F is G:
                    continue
                Z = lie_bracket(G, F, step)
                z = np.ravel(Z(x0))
                trial = numerical_rank(np.stack([*vectors, z]), threshold)
                if trial.rank > len(vectors):
                    vectors.append(z)
                    added.append(Z)
                    rank = trial
        if not added:
            break
        level, depth = added, d
    rank = numerical_rank(np.stack(vectors), threshold)
    closure = rank.rank
    result = HolonomyResult(
        name=constraint.name,
        holonomic=closure == dim_d,
        distribution_dimension=dim_d,
        closure_dimension=closure,
        configuration_dimension=constraint.configuration_dimension,
        depth=depth,
        rank=rank,
    )
    if verbose:
        print(result.report())
    return result


# -- constraints of the built-in systems (docs/theory.md §4, §9, §10) ------------------------------


def rolling_constraint(
    n: int, radius: float = 1.0, R: ArrayLike | None = None, normal: ArrayLike | None = None
) -> Distribution:
    """A ball of radius r rolling without sliding on a plane of Rⁿ (docs/theory.md §4, §9).

    Configuration ``(R, p) ∈ SO(n) × plane`` (dimension ``n(n−1)/2 + n − 1``); admissible
    velocities ``Ṙ = RΩ``, ``ṗ = r R Ω Rᵀ ν`` for every body Ω ∈ so(n) (dimension
    ``n(n−1)/2``). n = 3: 3 in 5, brackets reach 5; n = 2 (a disk on a line): 1 in 2, involutive.

    Parameters
    ----------
    n : int
        The dimension of the ball (n ≥ 2).
    radius : float, default 1.0
        Its radius r.
    R : array_like, shape (n, n), optional
        The orientation at which to test (default: a fixed generic rotation).
    normal : array_like, shape (n,), optional
        The plane's normal ν (default ``e_n``).

    Returns
    -------
    Distribution
        The admissible velocities at that configuration.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"`n` must be an integer ≥ 2; got {n!r}.")
    n = int(n)
    nu = np.eye(n)[-1] if normal is None else np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    if R is None:
        from scipy.linalg import expm

        R = expm(from_bivector_coordinates(np.linspace(0.3, 0.9, bivector_dimension(n)), n))
    R = np.asarray(R, dtype=float)
    x0 = np.concatenate([R.ravel(), np.zeros(n)])
    basis = from_bivector_coordinates(np.eye(bivector_dimension(n)), n)

    def field(E):
        def X(x):
            Rx = x[: n * n].reshape(n, n)
            return np.concatenate([(Rx @ E).ravel(), radius * (Rx @ E @ Rx.T @ nu)])

        return X

    return Distribution(
        name=f"rolling ball n = {n}" if n > 2 else "rolling disk on a line (n = 2)",
        point=x0,
        fields=tuple(field(E) for E in basis),
        configuration_dimension=bivector_dimension(n) + n - 1,
    )


def _free_rotation(n: int, R, name: str) -> Distribution:
    R = np.eye(n) if R is None else np.asarray(R, dtype=float)
    basis = from_bivector_coordinates(np.eye(bivector_dimension(n)), n)

    def field(E):
        return lambda x: (x.reshape(n, n) @ E).ravel()

    return Distribution(name, R.ravel(), tuple(field(E) for E in basis), bivector_dimension(n))


def _surface_tangency(particle, q) -> Distribution:
    n, surface = particle.n, particle.surface

    def field(k):
        def X(x):
            g = surface.gradient(x)
            e = np.zeros(n)
            e[k] = 1.0
            return e - (g[k] / (g @ g)) * g

        return X

    return Distribution(
        f"particle on a surface n = {n} (⟨∇h, q̇⟩ = 0 in Rⁿ)", np.asarray(q, float), tuple(field(k) for k in range(n)), n
    )


def _rigid_atoms(body, q) -> Distribution:
    N, n = body.N, body.n
    fields: list[VectorField] = []
    for k in range(n):
        e = np.zeros(n)
        e[k] = 1.0
        fields.append(lambda x, e=e: np.tile(e, N))
    for E in from_bivector_coordinates(np.eye(bivector_dimension(n)), n):
        fields.append(lambda x, E=E: (x.reshape(N, n) @ E.T).ravel())
    return Distribution(
        f"atoms held rigid N = {N}, n = {n} (rigid velocities in R^{N * n})",
        np.asarray(q, float).ravel(),
        tuple(fields),
        N * n,
    )


def constraint_of(system: LieGroupSystem, state: dict | None = None) -> Distribution:
    """The velocity distribution of a system at a state (for ``lieint analyze``).

    Rolling balls: :func:`rolling_constraint`; a particle on a surface: ``⟨∇h, q̇⟩ = 0`` in Rⁿ;
    atoms held rigid: the rigid velocities (translations and rotations) in R^{N n}; a free top:
    all of T SO(n) (no constraint); a free particle: all of Rⁿ.

    Parameters
    ----------
    system : LieGroupSystem
        A ball, a particle, atoms or a top.
    state : dict, optional
        The state at which to test (one body); the configuration fields it needs.

    Returns
    -------
    Distribution
        The admissible velocities.
    """
    from ..systems.atoms import AtomsBody
    from ..systems.chaplygin import ChaplyginBall
    from ..systems.euler_top import EulerTop
    from ..systems.heavy_top import HeavyTop
    from ..systems.particles import Particle, SurfaceParticle
    from ..systems.rolling_ball import RollingBall

    state = {} if state is None else {k: np.asarray(v, dtype=float) for k, v in state.items()}
    if isinstance(system, (RollingBall, ChaplyginBall)):
        return rolling_constraint(system.n, system.radius, state.get("R"), system.normal)
    if isinstance(system, SurfaceParticle):
        return _surface_tangency(system, state["q"])
    if isinstance(system, Particle):
        n = system.n
        coords = tuple((lambda x, k=k: np.eye(n)[k]) for k in range(n))
        return Distribution(f"free particle n = {n} (no constraint)", np.asarray(state["q"], float), coords, n)
    if isinstance(system, AtomsBody):
        return _rigid_atoms(system, state["q"])
    if isinstance(system, (EulerTop, HeavyTop)):
        return _free_rotation(
            system.n, state.get("R"), f"top with a fixed point n = {system.n} (no velocity constraint)"
        )
    raise ValueError(
        "`system`: no velocity distribution known for "
        f"{type(system).__name__}; build a Distribution of its admissible velocities."
    )
