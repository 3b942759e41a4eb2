"""Dense output on the group: a continuous solution between the steps that stays on the manifold.

A Lie-group step moves the state by a group element, ``y₁ = ρ(exp(u₁), y₀)`` with ``u₁`` in the
algebra 𝔤 (every Lie-group method of lieint reports ``u₁`` as an :class:`Increment`). Between
the steps the solution is interpolated **in the algebra**, never in the embedding space: the
curve ``u(θ)``, ``θ ∈ [0, 1]``, is the cubic Hermite polynomial with

* ``u(0) = 0``, ``u′(0) = h ξ(t₀, y₀)`` (the group path leaves ``y₀`` with velocity ``ξ``);
* ``u(1) = u₁``, ``u′(1) = h dexp⁻¹_{−u₁}(ξ(t₁, y₁))`` (the right-trivialised derivative of
  ``exp(u)`` at ``u₁`` equals ``ξ(t₁, y₁)``, see docs/theory.md §6 and §14 for the sign of the right action),

and ``y(t₀ + θh) = ρ(exp(u(θ)), y₀)``. The interpolant therefore lies on the orbit of ``y₀``
(R orthogonal, the spectrum of A kept, to round-off), matches the step's end points exactly,
and has a local error ``O(h⁴)``. For methods of order p > 4 the curve also passes through the
last one (p ≤ 6) or two (p ≤ 8) earlier step ends in the chart of ``y₀``, with their
derivatives (degree 5 or 7, local error ``O(h⁶)`` or ``O(h⁸)``), so the dense solution has
the method's order (except on the first steps of a run, where fewer earlier ends exist).

A method that moves the state by the group action without reporting its increment (the
Moser–Veselov maps, the splittings, the exact flow) gets it from the two states: the system's
``relative_element(y₀, y₁)`` gives ``g = R₀ᵀR₁`` when the state carries the attitude R, and
``u₁ = log g``. Methods without a group increment (classical Runge–Kutta on the embedding, and
any step of a system whose state does not determine ``g``) get the same cubic Hermite
interpolant on the state arrays with the vector field at both ends. scipy's solvers
bring their own dense output.

Each interpolant costs one generator evaluation at the end of its step (the next step's start
reuses it).
"""

from __future__ import annotations

import functools
from bisect import bisect_left, bisect_right
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["DenseOutput", "EmbeddedHermite", "Increment", "LieHermite", "Restep", "StepTable", "earlier_nodes"]


@dataclass(frozen=True)
class Increment:
    """What a Lie-group step reports for dense output: ``y₁ = ρ(exp(u), y₀)``.

    Give ``u`` (exponential coordinates) or the step's group element ``g`` (its log is taken
    only when an interpolant is built, so runs without dense output never pay for it).

    Attributes
    ----------
    u : algebra element or None
        The step's increment in exponential coordinates.
    g : group element or None
        The step's group element (methods in other coordinates, products of exponentials).
    data : Any
        Method-specific stage data (e.g. the RKMK stage increments and ``h``), or None.
    """

    u: Any = None
    g: Any = None
    data: Any = None

    def algebra(self, group):
        """``u`` with ``y₁ = ρ(exp(u), y₀)``."""
        return self.u if self.u is not None else group.log(self.g)


@dataclass(frozen=True)
class Restep:
    """Dense output by stepping again: ``y(t₀ + τ)`` is the method's own step of size τ from
    ``(t₀, y₀)`` (for ``0 < τ < h``), so between the steps the solution has the method's order,
    its error constant and every property its steps have (on the group, on the energy level).

    A method reports it as its step's ``dense`` when a Hermite curve through the step ends would
    be much less accurate than the step itself — the energy-keeping pairs, whose steps flow the
    spin about the momentum axis exactly and may turn the body by radians
    (:mod:`lieint.methods.energy_projection`). Each evaluation costs one step.

    Attributes
    ----------
    method : Method
        The method that took the step.
    system : LieGroupSystem
    t0, t1 : float
        The step's ends.
    y0, y1 : dict
        The states there (returned as they are at the ends).
    state : Any
        The method's state at ``t0`` (what its step received).
    """

    method: Any
    system: Any
    t0: float
    t1: float
    y0: dict
    y1: dict
    state: Any

    def __call__(self, t: float) -> dict:
        t = float(t)
        if t == self.t1:
            return self.y1
        if t == self.t0:
            return self.y0
        return self.method.step(self.system, self.t0, self.y0, t - self.t0, self.state).y


@dataclass(frozen=True)
class _SteppedAgain:
    """:class:`Restep` over a step of a compiled run: ``step(t)`` is the method's own step from
    ``(t₀, y₀)`` to t (the engine's), the ends returned as the run keeps them."""

    t0: float
    t1: float
    y0: dict
    y1: dict
    step: Callable[[float], dict]

    def __call__(self, t: float) -> dict:
        t = float(t)
        if t == self.t1:
            return self.y1
        if t == self.t0:
            return self.y0
        return self.step(t)


def _hermite(theta: float) -> tuple[float, float, float, float]:
    """Cubic Hermite basis ``(h₀₀, h₁₀, h₀₁, h₁₁)`` at θ."""
    t2, t3 = theta * theta, theta * theta * theta
    return 2 * t3 - 3 * t2 + 1, t3 - 2 * t2 + theta, -2 * t3 + 3 * t2, t3 - t2


class LieHermite:
    """``y(t₀ + θh) = ρ(exp(u(θ)), y₀)`` with ``u`` the Hermite curve of the module docstring.

    Parameters
    ----------
    system : LieGroupSystem
    t0, t1 : float
        The step's end times.
    y0 : dict
        The state at ``t0``.
    u1 : algebra element
        The step's increment, ``y₁ = ρ(exp(u₁), y₀)``.
    xi0, xi1 : algebra elements
        The generator ``ξ`` at ``(t₀, y₀)`` and ``(t₁, y₁)``.
    y1 : dict, optional
        The state at ``t1``, returned there as it is (``exp(log g)`` may differ from ``g`` by
        round-off).
    earlier : sequence of (t_j, v_j, ξ_j)
        Earlier step ends in the chart of ``y₀``: ``y(t_j) = ρ(exp(v_j), y₀)`` with the
        generator ``ξ_j`` there. Each adds two conditions (``u(θ_j) = v_j``,
        ``u′(θ_j) = h dexp⁻¹_{−v_j}(ξ_j)``), raising the degree by two and the order of the
        interpolant by two (cubic: 4, quintic: 6, degree 7: 8).
    mismatch : dict, optional
        ``y₁ − ρ(exp(u₁), y₀)`` per field, for a method that keeps only some fields on the
        group orbit: added with the weight ``h₀₁(θ) = 3θ² − 2θ³`` (zero value and slope at
        θ = 0, value 1 and slope 0 at θ = 1), so the curve ends at ``y₁``.
    """

    def __init__(
        self,
        system,
        t0: float,
        t1: float,
        y0: dict,
        u1,
        xi0,
        xi1,
        y1: dict | None = None,
        earlier=(),
        mismatch: dict | None = None,
    ):
        self.mismatch = mismatch
        group = system.group
        self.system, self.t0, self.t1, self.y0, self.y1 = system, float(t0), float(t1), y0, y1
        self.h = h = self.t1 - self.t0

        def slope(v, xi):
            # exact dexp⁻¹ (no truncation: the interpolant's order must not depend on a degree)
            return group.lincomb([h], [group.dexpinv(group.negate(v), xi, None)])

        # conditions: (θ, derivative order, algebra element or None for the zero value at θ = 0)
        conditions = [(0.0, 0, None), (0.0, 1, group.lincomb([h], [xi0])), (1.0, 0, u1), (1.0, 1, slope(u1, xi1))]
        for tj, vj, xij in earlier:
            theta = (float(tj) - self.t0) / h
            conditions += [(theta, 0, vj), (theta, 1, slope(vj, xij))]
        self._coefficients = _hermite_coefficients(tuple((theta, d) for theta, d, _ in conditions))
        self._data = [(i, x) for i, (_, _, x) in enumerate(conditions) if x is not None]
        self.degree = len(conditions) - 1

    def algebra(self, theta: float):
        """``u(θ)``."""
        w = (float(theta) ** np.arange(self.degree + 1)) @ self._coefficients
        return self.system.group.lincomb([float(w[i]) for i, _ in self._data], [x for _, x in self._data])

    def __call__(self, t: float) -> dict:
        if self.y1 is not None and float(t) == self.t1:
            return self.y1
        theta = (float(t) - self.t0) / self.h
        y = self.system.act(self.system.group.exp(self.algebra(theta)), self.y0)
        if self.mismatch is not None:
            w = _hermite(theta)[2]
            y = {k: v + w * self.mismatch[k] for k, v in y.items()}
        return y


@functools.lru_cache(maxsize=256)
def _hermite_coefficients(nodes: tuple[tuple[float, int], ...]) -> np.ndarray:
    """The polynomial coefficients of the Hermite interpolant's basis, per condition: the inverse
    of the matrix of the conditions ``(θ, derivative order)`` on ``1, θ, θ², …``. The same for
    every step whose earlier nodes sit at the same θ (every step of a fixed grid), so computed
    once (read only: the cached array is shared)."""
    m = len(nodes)
    M = np.zeros((m, m))
    powers = np.arange(m)
    for row, (theta, d) in enumerate(nodes):
        if d == 0:
            M[row] = theta**powers
        else:
            M[row, 1:] = powers[1:] * theta ** (powers[1:] - 1)
    inverse = np.linalg.inv(M)
    inverse.flags.writeable = False
    return inverse


class EmbeddedHermite:
    """Cubic Hermite interpolation of the state arrays (methods on the embedding space).

    ``y(t₀ + θh) = h₀₀ y₀ + h₁₀ h f₀ + h₀₁ y₁ + h₁₁ h f₁`` per field, with ``f`` the vector field.
    """

    def __init__(self, t0: float, t1: float, y0: dict, y1: dict, f0: dict, f1: dict):
        self.t0, self.t1 = float(t0), float(t1)
        self.h = self.t1 - self.t0
        self.y0, self.y1, self.f0, self.f1 = y0, y1, f0, f1

    def __call__(self, t: float) -> dict:
        h00, h10, h01, h11 = _hermite((float(t) - self.t0) / self.h)
        h = self.h
        return {
            k: h00 * self.y0[k] + (h10 * h) * self.f0[k] + h01 * self.y1[k] + (h11 * h) * self.f1[k] for k in self.y0
        }


class DenseOutput:
    """The continuous solution ``sol.sol(t)`` of a run: one interpolant per accepted step.

    Calling it with one time returns the state dict at that time; with an array of times
    ``(m,)`` a dict of ``(m, *batch, ...)`` arrays. Times outside the integrated span (from
    ``t0`` to ``t_end``, which lies before ``t0`` for a run backward in time) are refused.
    The steps come one by one (:meth:`append`, the generic path) or as tables of steps
    (:meth:`extend`, a compiled run: each step's interpolant is built when first asked for).

    Examples
    --------
    >>> import numpy as np, lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    >>> sol = lieint.integrate(top, y0, (0.0, 1.0), h=0.1, dense_output=True)
    >>> R = sol.sol(0.55)["R"]
    >>> bool(np.abs(R.T @ R - np.eye(3)).max() < 1e-14)
    True
    """

    def __init__(self, t0: float):
        self.t0 = float(t0)
        # segments of steps: ([step ends], [interpolants]) of the generic path, or a StepTable;
        # `_last` holds each segment's last end, for the bisection. The bisections run on
        # direction·t, increasing either way (direction −1: a run backward in time, set by the
        # first step), so the step ends are kept as direction·t
        self._segments: list = []
        self._last: list[float] = []
        self.direction = 1.0

    def _key(self, t1: float) -> float:
        """``direction·t1``, the first step setting the direction."""
        if not self._segments and float(t1) < self.t0:
            self.direction = -1.0
        return self.direction * float(t1)

    def append(self, t1: float, piece: Callable[[float], dict]) -> None:
        """One step's interpolant, ending at ``t1``."""
        key = self._key(t1)
        if not self._segments or isinstance(self._segments[-1], StepTable):
            self._segments.append(([], []))
            self._last.append(key)
        ends, pieces = self._segments[-1]
        ends.append(key)
        pieces.append(piece)
        self._last[-1] = key

    def extend(self, table: StepTable) -> None:
        """The steps of ``table`` (as far as its ``end``)."""
        if table.steps:
            key = self._key(table.end)
            self._segments.append(table)
            self._last.append(key)

    @property
    def t_end(self) -> float:
        return self.direction * self._last[-1] if self._last else self.t0

    @property
    def steps(self) -> int:
        return sum(len(seg[0]) if isinstance(seg, tuple) else seg.steps for seg in self._segments)

    def _one(self, t: float) -> dict:
        key = self.direction * t
        if not self.direction * self.t0 <= key <= self._last[-1]:
            lo, hi = sorted((self.t0, self.t_end))
            raise ValueError(f"`t` must lie in the integrated span [{lo}, {hi}]; got {t!r}.")
        # a time equal to a step's end belongs to that step (its interpolant ends there exactly)
        k = min(bisect_left(self._last, key), len(self._segments) - 1)
        segment = self._segments[k]
        if isinstance(segment, StepTable):
            return segment(t)
        ends, pieces = segment
        i = min(bisect_right(ends, key), len(pieces) - 1)
        if i > 0 and ends[i - 1] == key:
            i -= 1
        return pieces[i](t)

    def __call__(self, t):
        if not self._segments:
            raise ValueError("the run took no step; there is nothing to interpolate.")
        arr = np.asarray(t, dtype=float)
        if arr.ndim == 0:
            return self._one(float(arr))
        if arr.ndim != 1:
            raise ValueError(f"`t` must be a time or a 1-D array of times; got shape {arr.shape}.")
        rows = [self._one(float(s)) for s in arr]
        if not rows:
            raise ValueError("`t` is empty.")
        return {k: np.stack([r[k] for r in rows]) for k in rows[0]}

    def __repr__(self) -> str:
        return f"DenseOutput(t0={self.t0}, t_end={self.t_end}, steps={self.steps})"


def earlier_nodes(group, history) -> list:
    """The earlier step ends a Lie-group interpolant also passes through, in the chart of the
    current step's start: ``history`` holds ``(t_j, ξ_j, u_j)`` of the last steps (oldest first);
    ``y_j = ρ(exp(−u_{n−1}) ⋯ exp(−u_j), y_n)`` for a right action. The principal log of the chain
    follows the path back only while the path turns by less than π (bounded by the steps' ad
    radii): beyond, fewer nodes (a lower degree)."""
    earlier, g, reach = [], None, 0.0
    for tj, xij, uj in reversed(history):
        back = group.exp(group.negate(uj))
        g = back if g is None else group.multiply(g, back)
        reach += float(np.max(group.ad_spectral_radius(uj), initial=0.0))
        if earlier and not reach < np.pi:
            break
        earlier.append((tj, group.negate(uj) if len(earlier) == 0 else group.log(g), xij))
    return earlier


def _take(x, j):
    """Element j of an array, or of each array of a tuple (a product group's algebra)."""
    if isinstance(x, tuple):
        return tuple(_take(part, j) for part in x)
    return x[j]


class StepTable:
    """A stretch of accepted steps as arrays (what a compiled run hands over): the step ends
    ``t`` ``(m + 1,)`` (the stretch's start first), the states there ``rows`` (a dict of
    ``(m + 1, ...)`` arrays) and each step's increment in the algebra ``increments`` (``(m, ...)``,
    a tuple of them on a product group, or a function of j giving the increment of step j; None
    for steps on the embedding space, classical RK).

    The interpolant of step j is built when first asked for, exactly as
    :class:`lieint.observe.StepObserver` builds that of a step of the generic path: the cubic
    Hermite curve in the algebra (:class:`LieHermite`, with the earlier step ends of
    ``history`` and of the table for methods of order p > 4), or on the state arrays
    (:class:`EmbeddedHermite`). ``cayley``: the increments are Cayley coordinates of the step's
    element (its log is taken when the interpolant is built). ``derived``: the steps reported no
    increment but moved the state by the group action (True: a splitting, a map) or kept its
    group-valued fields on the group ("fields": the midpoint) — each step's element is read off
    its two states (``system.relative_element``), as :class:`lieint.observe.StepObserver` does on
    the generic path, and in the "fields" case the curve is corrected to end at ``y₁``. ``end``:
    where the table stops (a terminal event within its last step). The times decrease in a run
    backward in time.
    """

    def __init__(
        self, system, t, rows: dict, increments, *, cayley=False, extra_nodes=0, history=(), derived=False, restep=None
    ):
        self.system = system
        #: ``restep(j, t)``: the method's own step from step end j to t (the energy pairs), or None
        self.restep = restep
        self.t = np.asarray(t, dtype=float)
        self.derived = derived if increments is None else False
        if self.derived:
            increments = self._derived_increment
        self.rows, self.increments, self.cayley = rows, increments, bool(cayley)
        self.extra_nodes = int(extra_nodes)
        self.history = list(history)  # (t_j, ξ_j, u_j) of the steps before the table
        self.steps = self.t.size - 1
        self.end = float(self.t[-1])
        #: −1 when the steps go backward in time (the times decrease), else +1
        self.direction = -1.0 if self.steps and self.t[-1] < self.t[0] else 1.0
        self._negated: np.ndarray | None = None  # −t, for the bisection of a backward table
        self.nfev = 0
        self._field: dict[int, object] = {}
        self._pieces: dict[int, object] = {}

    def row(self, i: int) -> dict:
        return {k: v[i] for k, v in self.rows.items()}

    def _evaluate(self, i: int):
        """ξ (or the vector field, classical RK) at step end i, evaluated once."""
        cached = self._field.get(i)
        if cached is None:
            lie = self.increments is not None
            evaluate = self.system.generator if lie else self.system.vector_field
            cached = self._field[i] = evaluate(float(self.t[i]), self.row(i))
            self.nfev += 1
        return cached

    def _derived_increment(self, j: int):
        """``log g`` of step j, ``g = relative_element(y_j, y_{j+1})`` (the generic path's)."""
        return self.system.group.log(self.system.relative_element(self.row(j), self.row(j + 1)))

    def increment(self, j: int):
        """``u_j`` with ``y_{j+1} = ρ(exp(u_j), y_j)``."""
        u = self.increments(j) if callable(self.increments) else _take(self.increments, j)
        if self.cayley:
            group = self.system.group
            u = group.log(group.cay(u))
        return u

    def history_before(self, j: int) -> list:
        """``(t_i, ξ_i, u_i)`` of the ``extra_nodes`` steps before step j (oldest first); none for
        steps without increments (their interpolants are on the state arrays)."""
        if not self.extra_nodes or self.increments is None:
            return []
        own = [(float(self.t[i]), self._evaluate(i), self.increment(i)) for i in range(max(0, j - self.extra_nodes), j)]
        return (self.history + own)[-self.extra_nodes :]

    def interpolant(self, j: int):
        """The interpolant of step j (built once)."""
        piece = self._pieces.get(j)
        if piece is not None:
            return piece
        t0, t1, y0, y1 = float(self.t[j]), float(self.t[j + 1]), self.row(j), self.row(j + 1)
        if self.restep is not None:
            piece = self._pieces[j] = _SteppedAgain(t0, t1, y0, y1, lambda t, j=j: self.restep(j, t))
            return piece
        d0, d1 = self._evaluate(j), self._evaluate(j + 1)
        if self.increments is None:
            piece = EmbeddedHermite(t0, t1, y0, y1, d0, d1)
        else:
            earlier = earlier_nodes(self.system.group, self.history_before(j))
            u, mismatch = self.increment(j), None
            if self.derived == "fields":  # only R was moved by the group: end the curve at y₁
                moved = self.system.act(self.system.group.exp(u), y0)
                mismatch = {k: y1[k] - moved[k] for k in y1}
            piece = LieHermite(self.system, t0, t1, y0, u, d0, d1, y1, earlier, mismatch=mismatch)
        self._pieces[j] = piece
        return piece

    def step_of(self, t: float) -> int:
        """The step whose interval holds t (a time equal to a step's end belongs to that step)."""
        if self.direction > 0:
            j = int(np.searchsorted(self.t, t, side="left")) - 1
        else:  # decreasing times: the bisection on −t (negated once per table)
            if self._negated is None or self._negated.size != self.t.size:
                self._negated = -self.t
            j = int(np.searchsorted(self._negated, -t, side="left")) - 1
        return min(max(j, 0), self.steps - 1)

    def __call__(self, t: float) -> dict:
        j = self.step_of(float(t))
        if float(t) == self.t[j + 1]:
            return self.row(j + 1)
        return self.interpolant(j)(t)

    def truncate(self, end: float) -> None:
        """Stop the table at ``end`` (a terminal event within its steps)."""
        self.end = float(end)
        keep = self.step_of(self.end) + 1
        self.t, self.steps = self.t[: keep + 1], keep
        self.rows = {k: v[: keep + 1] for k, v in self.rows.items()}

    def next_history(self) -> list:
        """The history the next table starts from (the last steps of this one)."""
        return self.history_before(self.steps) if self.extra_nodes else []
