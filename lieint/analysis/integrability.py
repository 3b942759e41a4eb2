"""Counting toward integrability (docs/theory.md §7).

The reduction equation::

    dim(phase space) − #independent first integrals − dim(isotropy) − (1 if an invariant measure)

The integrals are counted by the rank of their Jacobian at the state (central differences in a
chart of the phase space, rows normalised, SVD rank with a stated threshold), group by group in
the order docs/theory.md §7 names them (energy, then the momentum components, then further
integrals). The isotropy is the dimension of the symmetries that keep the level set of the
integrals: ``dim{ξ ∈ so(n) : [ξ, a] = 0}`` for the Euler top (rotations about the momentum
bivector a), plus the translations of the plane for a rolling ball. Two conventions are those of
docs/theory.md §7:

* For a Hamiltonian system (the Euler top, a particle in a central field) the Liouville measure
  is not counted; each integral beyond energy and momentum decreases the count by two (itself
  and its Hamiltonian flow, through the symplectic form): ``12 − 1 − 6 − 2 − 1 − 1 = 1`` for the
  4D top with the Schottky–Frahm integral.
* For a nonholonomic system with an invariant measure (Chaplygin's ball) the measure counts
  one (Jacobi's last multiplier).

Charts are known for :class:`~lieint.EulerTop`, :class:`~lieint.ChaplyginBall`,
:class:`~lieint.CentralForceParticle` and a :class:`~lieint.SurfaceParticle` on a surface of
revolution with the force along its axis (Clairaut's integral).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..groups.bivectors import bivector_coordinates, bivector_dimension, commutator, from_bivector_coordinates

if TYPE_CHECKING:
    from ..systems.base import LieGroupSystem
from .numerics import (
    DIFFERENCE_STEP,
    RANK_THRESHOLD,
    NumericalRank,
    central_jacobian,
    normalised_rows,
    numerical_rank,
)

__all__ = ["IntegrabilityCount", "PhaseChart", "integrability_count", "phase_chart"]


@dataclass(frozen=True)
class PhaseChart:
    """What the count needs of a system at a state.

    Attributes
    ----------
    name : str
        The system's name ("Euler top n = 3").
    dimension : int
        Dimension of the phase space.
    point : callable
        ``z ∈ R^dimension ↦ state`` (``z = 0``: the state), a chart of the phase space.
    integrals : dict
        Group name → ``f(state) -> array``: the first integrals, group by group ("energy",
        "momentum a", …) in the order docs/theory.md §7 subtracts them.
    extra : dict
        Further integrals (e.g. Manakov's), counted after the isotropy.
    symmetry : str
        The symmetry algebra ("so(3)", "se(2)").
    symmetry_action : ndarray, shape (k, m)
        The infinitesimal action of a basis of the symmetry algebra on the momentum values;
        the isotropy is ``k − rank``.
    hamiltonian : bool
        A symplectic structure (each extra integral brings its Hamiltonian flow).
    measure : bool
        An invariant measure counted as in docs/theory.md §7 (Chaplygin's).
    isotropy_description : str
        How the isotropy arises, for the report (may be empty).
    """

    name: str
    dimension: int
    point: Callable[[np.ndarray], dict]
    integrals: dict[str, Callable[[dict], np.ndarray]]
    symmetry: str
    symmetry_action: np.ndarray
    hamiltonian: bool
    measure: bool
    extra: dict[str, Callable[[dict], np.ndarray]] = field(default_factory=dict)
    isotropy_description: str = ""


@dataclass(frozen=True)
class IntegrabilityCount:
    """The reduction equation (docs/theory.md §7) at one state (see the module docstring).

    Attributes
    ----------
    system : str
    phase_dimension : int
    integral_ranks : dict
        Group name → number of independent integrals it adds (in order).
    integrals : int
        ``#independent first integrals`` (Jacobian rank of all groups).
    isotropy : int
        Dimension of the symmetries keeping the level set.
    extra_integrals : int
        Independent integrals added by ``extra`` (e.g. Schottky–Frahm), counted after the isotropy.
    extra_flows : int
        Their Hamiltonian flows (= extra_integrals for a Hamiltonian system, else 0).
    measure : int
        1 if an invariant measure is counted.
    result : int
        The reduced dimension.
    symmetry : str
        The symmetry algebra.
    jacobian_rank, isotropy_rank : NumericalRank
        The numerical ranks behind the figures (threshold, smallest kept and largest dropped
        singular values).
    isotropy_description : str
        How the isotropy arises, for the report (may be empty).
    """

    system: str
    phase_dimension: int
    integral_ranks: dict[str, int]
    integrals: int
    isotropy: int
    extra_integrals: int
    extra_flows: int
    measure: int
    result: int
    symmetry: str
    jacobian_rank: NumericalRank
    isotropy_rank: NumericalRank
    isotropy_description: str = ""

    def terms(self) -> list[int]:
        """The numbers of the reduction equation, as docs/theory.md §7 writes it."""
        out = [self.phase_dimension, *self.integral_ranks.values(), self.isotropy]
        if self.extra_integrals:
            out.append(self.extra_integrals)
        if self.extra_flows:
            out.append(self.extra_flows)
        if self.measure:
            out.append(1)
        return out

    def equation(self) -> str:
        """``"6 − 1 − 3 − 1 = 1"``."""
        t = self.terms()
        return " − ".join(str(x) for x in t) + f" = {self.result}"

    def verdict(self) -> str:
        if self.result <= 1:
            return "integrable (reduced to dimension ≤ 1)"
        if self.result == 2:
            return "quite good (a flow on a surface)"
        return "not enough reduced"

    def report(self) -> str:
        """The equation as docs/theory.md §7 writes it, and the figures behind it."""
        ranks = ", ".join(f"{name} {r}" for name, r in self.integral_ranks.items())
        jr, ir = self.jacobian_rank, self.isotropy_rank
        lines = [
            f"{self.system}: {self.equation()}  →  {self.verdict()}",
            f"  phase space dimension {self.phase_dimension}",
            f"  independent first integrals {self.integrals}: {ranks} (Jacobian rank by SVD, threshold "
            f"{jr.threshold:.0e}: smallest kept {jr.kept:.1e}, largest dropped {jr.dropped:.1e})",
            f"  isotropy {self.isotropy}: {self.isotropy_description or self.symmetry} (rank of the action "
            f"{ir.rank}, threshold {ir.threshold:.0e}: smallest kept {ir.kept:.1e}, largest dropped {ir.dropped:.1e})",
        ]
        if self.extra_integrals:
            lines.append(
                f"  further independent integrals {self.extra_integrals}"
                + (f", and their Hamiltonian flows {self.extra_flows}" if self.extra_flows else "")
            )
        lines.append(f"  invariant measure counted: {'yes' if self.measure else 'no'}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {
            "system": self.system,
            "equation": self.equation(),
            "terms": self.terms(),
            "result": self.result,
            "phase_dimension": self.phase_dimension,
            "integral_ranks": dict(self.integral_ranks),
            "integrals": self.integrals,
            "isotropy": self.isotropy,
            "extra_integrals": self.extra_integrals,
            "extra_flows": self.extra_flows,
            "measure": self.measure,
            "symmetry": self.symmetry,
            "rank_threshold": self.jacobian_rank.threshold,
            "jacobian_kept": self.jacobian_rank.kept,
            "jacobian_dropped": self.jacobian_rank.dropped,
        }

    def __str__(self) -> str:
        return self.report()


def integrability_count(
    system: LieGroupSystem,
    state: dict,
    *,
    integrals: str = "momentum",
    threshold: float = RANK_THRESHOLD,
    step: float = DIFFERENCE_STEP,
    verbose: bool = True,
) -> IntegrabilityCount:
    """The count toward integrability at ``state`` (module docstring; docs/theory.md §7).

    Parameters
    ----------
    system : EulerTop, ChaplyginBall, CentralForceParticle or SurfaceParticle
        The system (a particle on a surface needs an axis of symmetry).
    state : dict
        One state of the system (no batch axes); a generic state gives the generic count.
    integrals : {"momentum", "manakov"}
        Which integrals to count: energy and momentum, or (Euler top) also Manakov's family
        ``tr((A − λB²)^k)``.
    threshold : float
        Relative SVD threshold of the ranks.
    step : float
        Central-difference step in the chart.
    verbose : bool, default True
        Print the report in the form of docs/theory.md §7 (the returned object's ``report()``).

    Returns
    -------
    IntegrabilityCount
        The figures of the count and the ranks behind them.

    Examples
    --------
    >>> import lieint
    >>> from lieint.analysis import integrability_count
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> y = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    >>> count = integrability_count(top, y)  # doctest: +ELLIPSIS
    Euler top n = 3: 6 − 1 − 3 − 1 = 1  →  integrable (reduced to dimension ≤ 1)
    ...
    >>> count.result, count.integrals, count.isotropy
    (1, 4, 1)
    """
    if integrals not in ("momentum", "manakov"):
        raise ValueError(f'`integrals` must be "momentum" or "manakov"; got {integrals!r}.')
    chart = phase_chart(system, state, integrals=integrals)
    ranks: dict[str, int] = {}
    rows = []
    total = numerical_rank(np.zeros((0, 0)), threshold)
    for name, f in chart.integrals.items():
        rows.append(_rows(chart, f, step))
        total = numerical_rank(np.vstack(rows), threshold)
        ranks[name] = total.rank - sum(ranks.values())
    base = total.rank
    extra_rank = 0
    if chart.extra:
        for f in chart.extra.values():
            rows.append(_rows(chart, f, step))
        total = numerical_rank(np.vstack(rows), threshold)
        extra_rank = total.rank - base
    action = chart.symmetry_action
    iso_rank = numerical_rank(action, threshold)
    isotropy = action.shape[0] - iso_rank.rank
    flows = extra_rank if chart.hamiltonian else 0
    measure = int(chart.measure)
    result = chart.dimension - base - isotropy - extra_rank - flows - measure
    count = IntegrabilityCount(
        system=chart.name,
        phase_dimension=chart.dimension,
        integral_ranks=ranks,
        integrals=base + extra_rank,
        isotropy=isotropy,
        extra_integrals=extra_rank,
        extra_flows=flows,
        measure=measure,
        result=result,
        symmetry=chart.symmetry,
        jacobian_rank=total,
        isotropy_rank=iso_rank,
        isotropy_description=chart.isotropy_description,
    )
    if verbose:
        print(count.report())
    return count


def _rows(chart: PhaseChart, f, step: float) -> np.ndarray:
    J = central_jacobian(lambda z: f(chart.point(z)), chart.dimension, step)
    return normalised_rows(J, np.ravel(f(chart.point(np.zeros(chart.dimension)))))


# -- charts ---------------------------------------------------------------------------------------------


def phase_chart(system: LieGroupSystem, state: dict, *, integrals: str = "momentum") -> PhaseChart:
    """The :class:`PhaseChart` of a system at a state; a clear error for other systems.

    Parameters
    ----------
    system : EulerTop, ChaplyginBall, CentralForceParticle or SurfaceParticle
        The system (a particle on a surface needs an axis of symmetry).
    state : dict
        One state of it (no batch axes).
    integrals : {"momentum", "manakov"}, default "momentum"
        As :func:`integrability_count`.

    Returns
    -------
    PhaseChart
        The chart, the integrals and the symmetry the count needs.
    """
    from ..systems.chaplygin import ChaplyginBall
    from ..systems.euler_top import EulerTop
    from ..systems.particles import CentralForceParticle, SurfaceParticle

    state = {k: np.asarray(v, dtype=float) for k, v in state.items()}
    if integrals == "manakov" and not isinstance(system, EulerTop):
        raise ValueError(f'`integrals` = "manakov" applies to an EulerTop; got {type(system).__name__}.')
    if isinstance(system, EulerTop):
        return _euler_top_chart(system, state, integrals)
    if isinstance(system, ChaplyginBall):
        return _chaplygin_chart(system, state)
    if isinstance(system, CentralForceParticle):
        return _central_chart(system, state)
    if isinstance(system, SurfaceParticle) and system.axis is not None and system.n >= 3:
        return _surface_chart(system, state)
    raise ValueError(
        "`system`: the count needs a chart of the phase space, known for EulerTop, ChaplyginBall, "
        "CentralForceParticle and a SurfaceParticle with an axis of symmetry; "
        f"got {system!r}."
    )


def _single(state: dict, fields) -> None:
    for name in fields:
        arr = state[name]
        if (name in ("A", "R") and arr.ndim != 2) or (name in ("Gamma", "center", "q", "v") and arr.ndim != 1):
            raise ValueError(f"`state` must be one state (no batch axes); got `state['{name}']` of shape {arr.shape}.")


def _so_basis(n: int) -> np.ndarray:
    d = bivector_dimension(n)
    return from_bivector_coordinates(np.eye(d), n)


def _expm(X: np.ndarray) -> np.ndarray:
    from scipy.linalg import expm

    return expm(X)


def _commutator_action(basis: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Rows ``[ξ_k, a]`` (bivector coordinates) for a basis ξ_k."""
    return np.stack([bivector_coordinates(commutator(E, a)) for E in basis])


def _euler_top_chart(top, state: dict, integrals: str) -> PhaseChart:
    n = top.n
    A0 = state["A"]
    R0 = state.get("R", np.eye(n))  # the count does not depend on R (left invariance); R = I when not integrated
    _single({"A": A0, "R": R0}, ("A", "R"))
    d = bivector_dimension(n)

    def point(z):
        return {"A": A0 + from_bivector_coordinates(z[:d], n), "R": R0 @ _expm(from_bivector_coordinates(z[d:], n))}

    def momentum(y):
        return bivector_coordinates(y["R"] @ y["A"] @ y["R"].T)

    a = R0 @ A0 @ R0.T
    extra = {}
    if integrals == "manakov":
        from ..systems.invariants import manakov_integrals

        B2 = top.B @ top.B
        extra["manakov"] = lambda y: manakov_integrals(y["A"], B2)
    return PhaseChart(
        name=f"Euler top n = {n}",
        dimension=2 * d,
        point=point,
        integrals={"energy": lambda y: np.atleast_1d(top.energy(y["A"])), "momentum a": momentum},
        extra=extra,
        symmetry=f"so({n})",
        symmetry_action=_commutator_action(_so_basis(n), a),
        hamiltonian=True,
        measure=False,
        isotropy_description=f"dim{{ξ ∈ so({n}) : [ξ, a] = 0}}",
    )


def _central_chart(particle, state: dict) -> PhaseChart:
    n = particle.n
    q0, v0 = state["q"], state["v"]
    _single(state, ("q", "v"))
    C = particle.centre

    def point(z):
        return {"q": q0 + z[:n], "v": v0 + z[n:]}

    def momentum(y):
        d = y["q"] - C
        return bivector_coordinates(np.outer(d, y["v"]) - np.outer(y["v"], d))

    L = from_bivector_coordinates(momentum(state), n)
    return PhaseChart(
        name=f"particle in a central field n = {n}",
        dimension=2 * n,
        point=point,
        integrals={
            "energy": lambda y: np.atleast_1d(particle.energy(y)),
            "momentum (q − C) ∧ q̇": momentum,
        },
        symmetry=f"so({n})",
        symmetry_action=_commutator_action(_so_basis(n), L),
        hamiltonian=True,
        measure=False,
        isotropy_description=f"dim{{ξ ∈ so({n}) : [ξ, (q − C) ∧ q̇] = 0}}",
    )


def _chaplygin_chart(ball, state: dict) -> PhaseChart:
    n, nu = ball.n, ball.normal
    A0 = state["A"]
    R0 = state.get("R")
    if R0 is None:
        if not np.allclose(state["Gamma"], nu, atol=1e-12):
            raise ValueError("`state` without 'R' must have Γ = ν (taken at R = I); integrate the orientation.")
        R0 = np.eye(n)
    c0 = state.get("center", ball.radius * nu)
    _single({"A": A0, "R": R0, "center": c0}, ("A", "R", "center"))
    d = bivector_dimension(n)
    # an orthonormal basis of the plane (translations) and of so(n−1) (rotations keeping ν)
    Q, _ = np.linalg.qr(np.column_stack([nu, np.eye(n)]))
    plane = Q[:, 1:n].T  # (n − 1, n)
    rotations = np.array([np.outer(u, w) - np.outer(w, u) for i, u in enumerate(plane) for w in plane[i + 1 :]])
    rotations = rotations.reshape(-1, n, n)

    def point(z):
        R = R0 @ _expm(from_bivector_coordinates(z[d : 2 * d], n))
        return {
            "A": A0 + from_bivector_coordinates(z[:d], n),
            "R": R,
            "Gamma": R.T @ nu,
            "center": c0 + z[2 * d :] @ plane,
        }

    def momentum(y):
        return bivector_coordinates(y["R"] @ y["A"] @ y["R"].T)

    a = R0 @ A0 @ R0.T
    rot_action = _commutator_action(rotations, a) if len(rotations) else np.zeros((0, d))
    # translations move the contact point and keep a and the energy: zero rows of the action
    action = np.vstack([rot_action, np.zeros((n - 1, d))])
    return PhaseChart(
        name=f"Chaplygin ball n = {n}",
        dimension=2 * d + n - 1,
        point=point,
        integrals={"energy": lambda y: np.atleast_1d(ball.energy(y)), "momentum a": momentum},
        symmetry=f"se({n - 1}) (motions of the plane)",
        symmetry_action=action,
        hamiltonian=False,
        measure=True,
        isotropy_description=f"{n - 1} translations of the plane + dim{{ξ ∈ so({n - 1}) : [ξ, a] = 0}}",
    )


def _surface_chart(particle, state: dict) -> PhaseChart:
    from ..systems.multivectors import trivector

    n, C, e = particle.n, particle.surface.centre, particle.axis
    q0, v0 = state["q"], state["v"]
    _single(state, ("q", "v"))
    # an orthonormal basis of the tangent space at q₀; the chart retracts onto the surface
    g = particle.surface.gradient(q0)
    Q, _ = np.linalg.qr(np.column_stack([g, np.eye(n)]))
    T = Q[:, 1:n]  # (n, n − 1)

    def point(z):
        return particle.project({"q": q0 + T @ z[: n - 1], "v": v0 + T @ z[n - 1 :]})

    def clairaut(y):
        return trivector(y["q"] - C, y["v"], e)

    # rotations keeping the axis: so(n − 1) on the hyperplane ⟂ e, acting on u ∧ v ∧ e as a derivation
    P, _ = np.linalg.qr(np.column_stack([e, np.eye(n)]))
    plane = P[:, 1:n].T
    rotations = [np.outer(u, w) - np.outer(w, u) for i, u in enumerate(plane) for w in plane[i + 1 :]]
    u, w = q0 - C, v0
    action = np.array([trivector(X @ u, w, e) + trivector(u, X @ w, e) for X in rotations])
    return PhaseChart(
        name=f"particle on a surface of revolution n = {n}",
        dimension=2 * (n - 1),
        point=point,
        integrals={"energy": lambda y: np.atleast_1d(particle.energy(y)), "Clairaut (q − C) ∧ q̇ ∧ e": clairaut},
        symmetry=f"so({n - 1}) (rotations about the axis)",
        symmetry_action=action.reshape(len(rotations), -1),
        hamiltonian=True,
        measure=False,
        isotropy_description=f"dim{{ξ ∈ so({n - 1}) : ξ·((q − C) ∧ q̇ ∧ e) = 0}}",
    )
