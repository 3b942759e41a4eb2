"""Adaptive pairs for conservative systems: energy kept on the group orbit, and on systems that
declare one, the generator's commuting part flowed exactly (``"rkmk23+energy"``,
``"rkmk45+energy"``, ``"rkmk853+energy"``).

Why. A Lie-group step moves the state by the group action, so it keeps every invariant of the
action exactly — the Casimirs (the spectrum of A, |Γ|) — but not the energy H. On an
integrable system the frequencies of the motion depend on the invariant torus, i.e. on the
Casimirs *and* H: a step whose energy error accumulates moves the state onto tori of other
frequencies and the phase error grows like t² (Calvo & Hairer 1995; Hairer, Lubich & Wanner,
*Geometric Numerical Integration*, §X.3: a method that keeps every first integral of an
integrable system has an error that grows only linearly). A classical Runge–Kutta pair on the
3D top escapes the t² term by a coincidence of that equation (its error is, to leading order,
a scaling of A, which keeps the orbit's shape ``H/|A|²``); a Lie-group pair cannot copy it,
because it keeps |A| exactly. Keeping H as well restores linear growth — and with it global
errors proportional to ``rtol`` (docs/measurements/adaptive.md).

The second ingredient concerns the size of what the pair integrates. The Euler top's generator
Ω is defined only up to the centraliser of A (``[A, Ω − λA] = [A, Ω]``); the part
``λA``, ``λ = ⟨Ω, A⟩/⟨A, A⟩`` (a ratio of the energy and the Casimir, constant along the flow),
has an exact flow — the attitude turns about the momentum axis, A stays — that commutes with
the motion (:meth:`lieint.EulerTop.commuting_generator`). A step of size h is therefore

    y₁ = base step of the generator ``Ω − λA`` from ``ρ(exp(h λ₀A₀), y₀)``,

exact in the split, so the base pair's order is kept, while the pair integrates ``Ω − λA``,
the element of least norm in ``Ω + span{A}``: near a steady rotation it is small however fast
the body spins, and the local error constant of the Lie step (which scales with the increment,
not with A') falls — near the separatrix of the 3D top, at equal steps, the plain pair's local
error in A is 46–98× DOP853's (``benchmarks/adaptive_rtol.py --equal-steps``). Systems without
``commuting_generator`` skip it, and so does a subclass that replaced the generator the
commuting part was derived for.

How the energy is kept. After the base step ``y₁`` (its error estimate drives the controller
unchanged), ``y₁`` is moved along its group orbit in the direction of steepest ascent of H
within the orbit::

    y₁ ← ρ(exp(s η), y₁),      η = Σ_i ∂_i H · e_i,      ∂_i H = d/dε H(ρ(exp(ε e_i), y₁))|₀,

with ``e_i`` a basis of the directions of the algebra 𝔤 of ``system.group``
(:func:`algebra_basis`; central differences, ε = 1e-6) and the scalar s from Newton/secant
iterations on ``H(ρ(exp(s η), y₁)) = H(y₀)``. The move is of the size of the step's energy
error, so the order of the base method is kept (a projection method, HLW §IV.4), and because it
is a group action every invariant of the action stays exact (and, with R in the state, the
spatial angular momentum ``R A Rᵀ``). For the Euler top ``η`` is ``[Ω, A]`` up to a factor (ρ
conjugates A, so the move is the double-bracket direction ``[A, [Ω, A]]``); for a vector-space
factor (velocities, positions) it is the ordinary gradient. The metric is the Euclidean one of
the basis coordinates (radians, and the units of the vector fields, restricted to skew matrices
for a field that holds them); the direction's accuracy does not affect the level reached, only
how far along the orbit the state moves to reach it.

A state whose energy is already within ``LEVEL_ULPS`` ulps of the level is not moved (a move
would only add the noise of evaluating H — near a separatrix, where the period depends on the
energy like ``log|E − E_s|``, that noise becomes a phase error). A body at which H has (nearly)
no gradient along the orbit is left as the base step put it: the move is applied only when it is
below 1e-3 (``|s η|``) and the secant iteration meets the level to round-off or cuts the gap a
hundredfold (an energy near zero, kinetic and potential cancelling, can leave the band below
the round-off of H; the iteration then stops on stagnation).

The estimate. The controller sees the base pair's embedded solution of the highest order
(q = 5 for the 8(5,3) pair, q = 4 for 5(4), q = 2 for 3(2)) and steps with the exponent
``1/(q + 1)``: DOP853's combination ``‖e₅‖²/√(‖e₅‖² + 0.01‖e₃‖²)``, which the plain pair keeps to take
scipy's steps, is far below ``‖e₅‖`` when the third-order estimate dominates, and on the group that
let isolated steps through whose true local error was 10–65× the estimate — near the free top's
unstable axis, as the body leaves it (``benchmarks/adaptive_systems.py``), each a phase error the
next flip inherits: the Dzhanibekov flips at rtol 1e-10 were located to 9.2e-10 s with the
combination, 9.6e-12 s with e₅ (scipy's DOP853: 4.1e-12 s), for 2.3× the steps (257 against 113).

Cost: on the generic path about 2.3× the base pair's step (H at the step's end, the gradient's
``2 dim 𝔤`` evaluations of H in one batched call, then one to four secant evaluations, each an
exponential and an action). The compiled engine runs the whole step, the level carried in the
compiled state, the same steps as the generic path to round-off: on the 3D Euler top in
exponential coordinates (:mod:`lieint.fast.top3`, family ``rkmk_energy``: the orbit gradient
``w × Π`` exact instead of by differences), on the n-D top in exponential and Cayley coordinates
and the 3D top in Cayley coordinates (:mod:`lieint.fast.topn_energy`: the gradient ``[Ã, Ω̃]``
exact) and on every system whose
compiled pieces declare an energy — the heavy top, the free body, both balls — in either
coordinates (:mod:`lieint.fast.generic_energy`: these central differences through the compiled
action). A run with dense output, events or ``t_eval`` stays on the generic path, whose dense
output steps again (:class:`lieint.dense.Restep`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import lru_cache, partial
from typing import Any

import numpy as np

from ..dense import Restep
from ..fast.forms import RKMKForm
from ..groups.base import MatrixLieGroup
from ..groups.se import SE
from ..groups.so import SO
from ..groups.vector import ProductGroup, VectorSpace
from .base import Method, MethodSpec, StepResult
from .registry import AUTO, get_method, register

__all__ = ["LEVEL_ULPS", "EnergyProjected", "algebra_basis"]

#: the finite-difference step of the orbit gradient (rotation angle / translation)
_EPSILON = 1e-6
#: the largest move |s η| the projection accepts (larger: H has no usable gradient there)
_MAX_MOVE = 1e-3
#: a state is on its energy level when ``|H − H₀| ≤ LEVEL_ULPS · ε · |H₀|``: H is evaluated to a
#: few ulps of its terms, so a tighter level would chase round-off
LEVEL_ULPS = 64
#: secant iterations (two reach round-off from a step's energy error; one more as a margin)
_ITERATIONS = 4


@lru_cache(maxsize=16)
def _skew_basis(n: int) -> np.ndarray:
    """``E_jk − E_kj`` for j < k, stacked: a basis of the n × n skew matrices (read-only, made
    once per n: every energy pair's call checks its system with it)."""
    pairs = [(j, k) for j in range(n) for k in range(j + 1, n)]
    out = np.zeros((len(pairs), n, n))
    for i, (j, k) in enumerate(pairs):
        out[i, j, k], out[i, k, j] = -1.0, 1.0
    out.flags.writeable = False
    return out


def algebra_basis(group) -> Any:
    """A basis ``e_1 … e_d`` of the directions of ``group``'s algebra, stacked on a leading axis.

    SO(n): the skew matrices ``E_jk − E_kj`` (j < k); SE(n): those in the rotation block and
    the n unit translations; a vector space: the unit arrays, or the skew basis when its field
    holds skew matrices (``VectorSpace(..., antisymmetric=True)``); a product group: a tuple,
    one stacked array per factor, each basis element non-zero in one factor only.
    """
    if isinstance(group, SO):
        return _skew_basis(group.n)
    if isinstance(group, SE):
        n = group.n
        rotations = _skew_basis(n)
        out = np.zeros((len(rotations) + n, n + 1, n + 1))
        out[: len(rotations), :n, :n] = rotations
        for i in range(n):
            out[len(rotations) + i, i, n] = 1.0
        return out
    if isinstance(group, VectorSpace):
        if group.antisymmetric:
            return _skew_basis(group.shape[0])
        return np.eye(group.dim).reshape((group.dim,) + group.shape)
    if isinstance(group, ProductGroup):
        if any(isinstance(f, ProductGroup) for f in group.factors):
            raise TypeError(f"`group`: nested product groups are not supported; got {group!r}")
        parts = [algebra_basis(f) for f in group.factors]
        total = sum(len(part) for part in parts)
        out, start = [], 0
        for part in parts:
            block = np.zeros((total,) + part.shape[1:])
            block[start : start + len(part)] = part
            out.append(block)
            start += len(part)
        return tuple(out)
    raise TypeError(f"`group`: no algebra basis is known for {group!r}")


class _Reduced:
    """``system`` with the generator ``ξ − η``, η its ``commuting_generator`` (every other
    attribute is the system's own); ξ is evaluated once per stage."""

    def __init__(self, system):
        self._system = system

    def __getattr__(self, name):
        return getattr(self._system, name)

    def generator(self, t, y):
        xi = self._system.generator(t, y)
        return xi - self._system.commuting_generator(t, y, xi)


def _commuting_part(system):
    """The system's ``commuting_generator``, or None — also when a subclass replaced the
    generator the commuting part was derived for (its split would no longer be exact: the
    commuting part must be constant along the flow, as ``λ = −4T/|A|²`` is for the Euler top)."""
    part = getattr(system, "commuting_generator", None)
    if part is None:
        return None
    owner = next((c for c in type(system).__mro__ if "commuting_generator" in vars(c)), None)
    if owner is None or getattr(type(system), "generator", None) is not getattr(owner, "generator", None):
        return None
    return part


def _prefixed(base_state) -> dict:
    """The base method's state as ``base:``-prefixed entries (none for a stateless method)."""
    if base_state is None:
        return {}
    if not isinstance(base_state, dict):
        raise TypeError(
            f"`method`: the energy projection carries a base method's state as a dict of arrays or None; "
            f"got {type(base_state).__name__}"
        )
    return {f"base:{k}": v for k, v in base_state.items()}


def _trailing_ndim(group) -> int | tuple:
    if isinstance(group, MatrixLieGroup):
        return 2
    if isinstance(group, VectorSpace):
        return len(group.shape)
    return tuple(_trailing_ndim(f) for f in group.factors)


def _map(fn, X, ndim):
    """Apply ``fn(array, trailing_ndim)`` to an algebra element (per factor of a product)."""
    if isinstance(ndim, tuple):
        return tuple(_map(fn, x, d) for x, d in zip(X, ndim, strict=True))
    return fn(X, ndim)


@dataclass(frozen=True)
class EnergyProjected(Method):
    """A Lie-group method whose every step ends on the initial energy level, moved there along
    the group orbit; on a system with a ``commuting_generator`` (the Euler top) the base method
    integrates the generator without its commuting part, whose exact flow is composed with the
    step (see the module docstring).

    Parameters
    ----------
    base : Method
        A method that moves the state by the group action (``group_action`` True): RKMK,
        its embedded pairs, commutator-free, Crouch–Grossman, Magnus. Its error estimate
        (before the move) drives the step-size controller. The registry holds the adaptive
        pairs (``"rkmk23+energy"``, ``"rkmk45+energy"``, ``"rkmk853+energy"``); any other base
        can be wrapped and passed as ``method=``.

    Examples
    --------
    >>> import lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> y0 = top.initial_state(angular_velocity=[0.3, 0.5, 1.0])
    >>> sol = lieint.integrate(top, y0, (0.0, 10.0), method="rkmk45+energy", rtol=1e-8)
    >>> bool(sol.drift("energy") < 1e-13 and sol.drift("casimirs") < 1e-13)
    True
    """

    base: Method

    @property
    def name(self) -> str:  # type: ignore[override]
        return f"{self.base.name}+energy"

    @property
    def order(self) -> int | None:  # type: ignore[override]
        return self.base.order

    @property
    def coordinates(self) -> str | None:  # type: ignore[override]
        return self.base.coordinates

    @property
    def adaptive(self) -> bool:  # type: ignore[override]
        return self.base.adaptive

    @property
    def error_order(self) -> int | None:
        """The order of the estimate the controller sees: the base pair's embedded order (5 for
        the 8(5,3) pair, whose combined estimate is not used: :meth:`step`)."""
        pair = getattr(self.base, "tableau", None)
        return getattr(pair, "embedded_order", self.base.error_order)

    group_action = True

    def check_system(self, system) -> None:
        self.base.check_system(system)
        if not self.base.group_action:
            raise ValueError(
                f"`method` {self.name!r}: {self.base.name!r} does not move the state by the group action, "
                "so there is no group orbit to keep the energy on."
            )
        energy = system.invariants.get("energy")
        if energy is None or energy.kind != "integral" or not system.autonomous:
            raise ValueError(
                f"`method` {self.name!r} keeps the energy, but {type(system).__name__} has no conserved energy "
                "(no autonomous 'energy' integral among its invariants)."
            )
        try:
            algebra_basis(system.group)
        except TypeError as exc:
            raise ValueError(f"`method` {self.name!r}: {exc}.") from None

    def init(self, system, t0: float, y0: dict, h) -> dict:
        """``{"energy0": H(y₀)}`` (per body) and the base method's state under ``base:`` keys —
        a dict of arrays, so that streamed runs checkpoint and resume it like any other."""
        energy0 = np.asarray(system.invariants["energy"](t0, y0), dtype=float)
        return {"energy0": energy0, **_prefixed(self.base.init(system, t0, y0, h))}

    def step(self, system, t: float, y: dict, h: float, state) -> StepResult:
        energy0 = np.asarray(state["energy0"], dtype=float)
        base_state = {k[5:]: v for k, v in state.items() if k.startswith("base:")} or None
        group = system.group
        commuting = _commuting_part(system)
        if commuting is not None:
            # the exact flow of the commuting part first (it moves only the attitude), then the
            # base step of the rest: the two flows commute, so the split is exact
            turn = group.exp(group.lincomb([h], [commuting(t, y)]))
            result = self.base.step(_Reduced(system), t, system.act(turn, y), h, base_state)
        else:
            result = self.base.step(system, t, y, h, base_state)
        y1 = self.onto_level(system, t + h, result.y, energy0)
        # dense output steps again from y₀ (a Hermite curve through the ends erred ~10⁵×
        # more than these steps, which may spin the body by radians about the momentum axis)
        dense = Restep(self, system, t, t + h, y, y1, state)
        state1 = {"energy0": energy0, **_prefixed(result.state)}
        # the 8(5,3) pair's combined estimate ‖e₅‖²/√(‖e₅‖² + 0.01‖e₃‖²) is built for a classical
        # step's error; on the group it let isolated steps through with a true error 10–65× the
        # estimate (the top as it leaves its unstable axis), each a phase error of the next flip:
        # the fifth-order estimate e₅ alone bounds the step (module docstring)
        error = result.error[0] if isinstance(result.error, tuple) else result.error
        return StepResult(y1, error, result.nfev, state1, result.h, dense)

    def onto_level(self, system, t: float, y: dict, energy0: np.ndarray) -> dict:
        """``ρ(exp(s η), y)`` with ``H(ρ(exp(s η), y)) = H₀`` per body (s = 0 where the
        projection does not apply, see the module docstring)."""
        group, energy = system.group, system.invariants["energy"]
        batch = np.shape(energy0)
        basis, ndim = algebra_basis(group), _trailing_ndim(group)
        d = len(basis[0] if isinstance(basis, tuple) else basis)

        def spread(X, k):  # (d, *trailing) -> (d, 1…1, *trailing) against the batch
            return X.reshape((d,) + (1,) * len(batch) + X.shape[1:])

        basis = _map(spread, basis, ndim)
        f0 = np.asarray(energy(t, y), dtype=float) - energy0
        # H is evaluated to a few ulps of its terms: below this the gap is round-off
        level = LEVEL_ULPS * np.finfo(float).eps * np.abs(energy0)
        if not np.any(np.isfinite(f0) & (np.abs(f0) > level)):  # every body on its level already
            return dict(y)
        up = energy(t, system.act(group.exp(_map(lambda X, k: _EPSILON * X, basis, ndim)), y))
        down = energy(t, system.act(group.exp(_map(lambda X, k: -_EPSILON * X, basis, ndim)), y))
        grad = (np.asarray(up) - np.asarray(down)) / (2.0 * _EPSILON)  # (d, *batch)

        def combine(X, k):  # Σ_i grad_i e_i -> (*batch, *trailing)
            return np.tensordot(grad, X, axes=(0, 0)).reshape(batch + X.shape[1 + len(batch) :])

        eta = _map(combine, basis, ndim)

        def scaled(s):
            return _map(lambda X, k: np.reshape(s, batch + (1,) * k) * X, eta, ndim)

        def gap(s):
            return np.asarray(energy(t, system.act(group.exp(scaled(s)), y)), dtype=float) - energy0

        slope0 = np.sum(grad * grad, axis=0)  # dH/ds at s = 0
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            s_prev, f_prev = np.zeros(batch), f0
            # a body whose base step already kept the energy to round-off is not moved: a move
            # there would only add the noise of evaluating H (near a separatrix, where the
            # period depends on the energy like log|E − E_s|, that noise becomes a phase error)
            s = np.where((slope0 > 0) & (np.abs(f0) > level), -f0 / slope0, 0.0)
            f = np.where(s != 0.0, gap(s), f0)
            for _ in range(_ITERATIONS - 1):  # secant steps, each body frozen once on the level
                active = (np.abs(f) > level) & (f != f_prev)
                if not np.any(active):
                    break
                step = np.where(active, f * (s - s_prev) / np.where(active, f - f_prev, 1.0), 0.0)
                s_prev, f_prev, s = s, f, s - step
                f = np.where(active, gap(s), f)
        size = np.abs(s) * np.sqrt(slope0)
        # applied where it moved little and met the level (or cut the gap a hundredfold)
        ok = np.isfinite(s) & np.isfinite(f) & (size <= _MAX_MOVE)
        ok &= (np.abs(f) <= level) | (np.abs(f) <= 1e-2 * np.abs(f0))
        s = np.where(ok, s, 0.0)
        move = scaled(s)
        moved = system.act(group.exp(move), y)
        keep = {k: np.reshape(ok, batch + (1,) * (np.ndim(v) - len(batch))) for k, v in moved.items()}
        return {k: np.where(keep[k], moved[k], y[k]) for k in moved}

    def compiled(self):
        """The base pair's form marked ``keeps_energy`` (the compiled engine runs it on the tops
        and on compiled pieces that declare an energy: the module docstring), with the estimate
        this method steps on — the embedded
        solution of the highest order alone — or None (a base without a compiled pair, or whose
        steps a subclass replaced)."""
        if type(self) is not EnergyProjected:
            return None
        form = self.base.compiled()
        if not isinstance(form, RKMKForm) or not form.pair:
            return None
        return dataclasses.replace(form, b_low=None, error_order=self.error_order, keeps_energy=True)


def _build(base_name: str, coordinates: str | None = None, dexpinv_degree=AUTO) -> EnergyProjected:
    return EnergyProjected(get_method(base_name, coordinates=coordinates, dexpinv_degree=dexpinv_degree))


_KEEPS = "every step moved along the group orbit onto the initial energy (the top's spin flowed exactly)"
for _base, _order, _text in (
    ("rkmk23", 3, f"adaptive RKMK 3(2), {_KEEPS}; global error follows rtol"),
    ("rkmk45", 5, f"adaptive RKMK 5(4), {_KEEPS}; global error follows rtol"),
    ("rkmk853", 8, f"adaptive RKMK 8(5), {_KEEPS}; global error follows rtol — the default adaptive choice"),
):
    register(
        MethodSpec(
            f"{_base}+energy",
            "rkmk-energy",
            _order,
            partial(_build, _base),
            ("exp", "cayley"),
            True,
            _text,
            ("dexpinv_degree",),
        )
    )
