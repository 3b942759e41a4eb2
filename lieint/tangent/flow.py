"""The tangent map of the numerical flow: the exact derivative of a method's discrete map.

A method with step ``h`` is a map ``Φ_h: y_k ↦ y_{k+1}``; a run is the composition of its
steps, and its tangent map ``DΦ(y₀)`` (in the coordinates of :mod:`lieint.tangent.coordinates`)
is the product of the steps' derivatives. It is computed here by the **complex step**
(Squire & Trapp 1998; Martins, Sturdza & Alonso 2003): the method steps the complex state
``y + iε v`` with ``ε = 1e-30`` and ``Im(Φ(y + iεv))/ε = DΦ(y) v + O(ε²)``, exact to round-off
since ``ε²`` is below the smallest double — no difference is taken, so nothing cancels. k
tangent vectors are k complex copies on a new leading axis, stepped together as a batch. The
real part of every copy is the ordinary run (to round-off).

This is the derivative of the map the method computes — its stages, its coordinate map, its
Newton or fixed-point iterations solved to round-off — not a variational equation integrated
beside it, so it inherits the map's structure: the tangent map of a symplectic method is
symplectic to round-off. The complex step is exact only where the step is real-analytic in
``y``: every function of the groups and built-in systems a step calls keeps complex values
(``np.sqrt`` of the squared angle, not a norm; a dense linear solve where a real path would
take a symmetric eigendecomposition), and the methods whose step is not analytic are refused
by name (:data:`REFUSED`). ``docs/theory.md`` (§ "The tangent flow") says why this design
was chosen over forward mode by hand.

The complex copies run on the generic numpy path (the compiled kernels are real), except where
the compiled engine has the method's tangent steps written out in forward mode — the 3D top's
RKMK methods, splittings into exact rotations and Moser–Veselov maps, the RKMK methods of the
n-dimensional top, the 3D heavy top, the 3D Chaplygin ball and the 3D rolling ball
(:mod:`lieint.tangent.compiled`):
:meth:`TangentStepper.advance` reads the copies as a real state and its derivatives and steps
them there. Every result's ``backend_reason`` says which path ran (:data:`BACKEND_REASON`,
:data:`lieint.tangent.compiled.COMPILED_REASON`).
"""

from __future__ import annotations

import re
import warnings
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..control import Plan
from ..methods.base import Method
from ..methods.registry import get_method, method_specs
from ..systems.base import LieGroupSystem
from .compiled import COMPILED_REASON
from .coordinates import TangentChart, chart_of

__all__ = [
    "BACKEND_REASON",
    "COMPLEX_STEP",
    "REFUSED",
    "TangentFlow",
    "TangentStepper",
    "family_of",
    "run_steps",
    "step_schedule",
    "tangent_backend",
    "tangent_flow",
]

#: the values of ``backend``
BACKENDS = ("auto", "numpy", "numba")

#: the imaginary step ε: small enough that ε² vanishes below the smallest double next to 1
COMPLEX_STEP = 1e-30

#: why the tangent flow runs on the generic path (reported as ``backend_reason``)
BACKEND_REASON = "the tangent map steps complex copies of the state: generic numpy path (the compiled kernels are real)"

#: method families whose step is not real-analytic in the state, with why
REFUSED = {
    "scipy": "scipy's solvers choose their own steps and work on real arrays",
    "exact": "the exact flow evaluates Jacobi elliptic functions, which scipy has for real arguments only",
    "rkmk-energy": "the energy projection's root finder is not analytic in the state",
    "magnus": "Magnus methods step prescribed rotations (no state to differentiate)",
    "symplectic": "RATTLE/Verlet are not checked for complex states",
}
#: registered names refused although their family is not (modified moments read the invariants)
_REFUSED_NAMES = {
    f"moser_veselov{p}": "the modified moments are computed from the invariants on real arrays" for p in (4, 6, 8, 10)
}


def tangent_backend(system: LieGroupSystem, method: str | Method, coordinates: str | None = None) -> str:
    """Where the tangent steps of ``method`` on ``system`` run, in words: the compiled engine
    (:data:`lieint.tangent.compiled.COMPILED_REASON`) or the generic path and why."""
    reason = _compiled_reason(system, get_method(method, coordinates=coordinates))
    return COMPILED_REASON if not reason else f"{BACKEND_REASON} ({reason})"


def _compiled_reason(system: LieGroupSystem, method: Method) -> str:
    """Why ``method``'s tangent steps on ``system`` run on the generic path ("" when compiled).
    A system with complex parameters (a parameter's complex step) always does."""
    from .compiled import compiled_reason

    complex_step = "the system's parameters are complex (a parameter's complex step)"
    try:
        if any(np.iscomplexobj(value) for value in system.parameter_values().values()):
            return complex_step
        form = system.compiled()
    except (TypeError, ValueError):  # a declaration that cannot be made of complex parameters
        return complex_step
    if form is not None and not all(np.isrealobj(getattr(form, name, 0.0)) for name in ("moments", "P", "b")):
        return complex_step
    return compiled_reason(system, method)


def _refusal(method: Method) -> str | None:
    """Why ``method``'s step cannot be differentiated by the complex step, or None."""
    if method.self_controlled:
        return REFUSED["scipy"]
    if method.name in _REFUSED_NAMES:
        return _REFUSED_NAMES[method.name]
    family = family_of(method)
    return REFUSED.get(family) if family is not None else None


def family_of(method: Method) -> str | None:
    """The registered family of ``method`` ("rkmk", "splitting", …), or None for an unregistered one."""
    base = re.sub(r"\[[^]]*\]", "", method.name)  # "rkmk23[cayley]+energy" is registered as "rkmk23+energy"
    spec = method_specs().get(base)
    return None if spec is None else spec.family


class TangentStepper:
    """One method stepping a system together with k tangent vectors (the complex step).

    Parameters
    ----------
    system : LieGroupSystem
        The system.
    method : str or Method
        A method name or object (not one of :data:`REFUSED`).
    coordinates : {"exp", "cayley"}, optional
        The coordinate map of a Lie-group method.
    backend : {"auto", "numpy", "numba"}, default "auto"
        "auto" steps on the compiled engine where the method's tangent steps are compiled
        (:mod:`lieint.tangent.compiled`), else on the generic path; "numpy" forces the generic
        path (the complex step: the reference); "numba" requires the compiled steps.

    Raises
    ------
    ValueError
        A method whose step is not analytic in the state (naming why), or one that does not
        apply to the system; ``backend="numba"`` where no compiled tangent steps exist.

    Examples
    --------
    >>> import numpy as np, lieint
    >>> from lieint.tangent import TangentStepper
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> stepper = TangentStepper(top, "rkmk4")
    >>> y = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    >>> z = stepper.seed(y, np.eye(stepper.chart.dim))
    >>> z, _ = stepper.step(0.0, z, 0.1)
    >>> stepper.split(z)[1].shape  # the 6 × 6 derivative of one step, column by column
    (6, 6)
    """

    def __init__(
        self,
        system: LieGroupSystem,
        method: str | Method = "rkmk4",
        coordinates: str | None = None,
        backend: str = "auto",
    ):
        if not isinstance(system, LieGroupSystem):
            raise TypeError(f"`system` must be a lieint system (LieGroupSystem); got {type(system).__name__}.")
        if backend not in BACKENDS:
            raise ValueError(f"`backend` must be one of {list(BACKENDS)}; got {backend!r}.")
        self.system = system
        self.method = get_method(method, coordinates=coordinates)
        why = _refusal(self.method)
        if why is not None:
            raise ValueError(f"`method` {self.method.name!r} has no tangent map here: {why}.")
        self.method.check_system(system)
        self.chart: TangentChart = chart_of(system)
        #: why the steps run on the generic path ("" when :meth:`advance` runs them compiled)
        forced = "backend='numpy' asked for the generic path"
        self.compiled_reason = forced if backend == "numpy" else _compiled_reason(system, self.method)
        if backend == "numba" and self.compiled_reason:
            raise ValueError(
                f"`backend='numba'`: no compiled tangent steps for {self.method.name!r} on {type(system).__name__}: "
                f"{self.compiled_reason}. Use 'auto' or 'numpy'."
            )
        self._compiled: dict = {}  # (k, batch) → lieint.tangent.compiled.CompiledTangent
        #: what the last :meth:`advance` ran on (``backend_reason`` of the results)
        self.backend_reason = BACKEND_REASON

    def seed(self, y: dict, vectors: np.ndarray) -> dict:
        """Complex copies ``y + iε v`` of the real state ``y``, one per tangent vector.

        Parameters
        ----------
        y : dict of ndarray
            A real state of batch shape ``b``.
        vectors : ndarray, shape (k, ..., dim)
            Tangent vectors (chart coordinates; shape ``(k, dim)`` broadcasts over bodies).

        Returns
        -------
        dict of ndarray
            The complex state, shape ``(k, *b, *field)`` per field.
        """
        batch = self.system.batch_shape(y)
        v = np.asarray(vectors, dtype=float)
        if v.ndim < 2 or v.shape[-1] != self.chart.dim:
            raise ValueError(
                f"`vectors` must have shape (k, {self.chart.dim}) or (k, *batch, {self.chart.dim}) "
                f"(k tangent vectors in the coordinates {self.chart.labels()}); got shape {v.shape}."
            )
        if v.ndim == 2:  # the same vectors at every body
            v = v.reshape(v.shape[:1] + (1,) * len(batch) + v.shape[-1:])
        v = np.broadcast_to(v, v.shape[:1] + batch + v.shape[-1:])
        return self.chart.perturb(y, v.astype(complex), 1j * COMPLEX_STEP)

    def split(self, z: dict) -> tuple[dict, np.ndarray]:
        """The real state and the tangent vectors of a complex state from :meth:`seed`.

        Parameters
        ----------
        z : dict of ndarray
            Complex copies, shape ``(k, *b, *field)``.

        Returns
        -------
        y : dict of ndarray
            The real state (of the first copy; every copy's real part is the same run).
        vectors : ndarray, shape (k, ..., dim)
            The tangent vectors carried by the copies.
        """
        y = {name: np.ascontiguousarray(z[name][0].real) for name in self.chart.names}
        dy = {name: z[name].imag / COMPLEX_STEP for name in self.chart.names}
        return y, self.chart.read(y, dy)

    def init(self, t0: float, z: dict, h: float) -> Any:
        """The method's state before the first step from the complex state ``z``.

        Parameters
        ----------
        t0 : float
            The initial time.
        z : dict of ndarray
            The complex state (:meth:`seed`).
        h : float
            The first step.

        Returns
        -------
        any
            What :meth:`Method.init` returns (None for one-step methods).
        """
        with self._complex_kept():
            return self.method.init(self.system, t0, z, h)

    @contextmanager
    def _complex_kept(self):
        """Turn a cast of the complex state to real (numpy's ComplexWarning) into an error."""
        with warnings.catch_warnings():
            warnings.simplefilter("error", np.exceptions.ComplexWarning)
            try:
                yield
            except np.exceptions.ComplexWarning as exc:
                raise ValueError(
                    f"`method` {self.method.name!r} on {type(self.system).__name__}: the step casts the complex "
                    f"state to real ({exc}); its tangent map cannot be computed by the complex step."
                ) from None

    def advance(self, z: dict, starts: np.ndarray, sizes: np.ndarray, state: Any = None) -> tuple[dict, Any]:
        """The complex state ``z`` after the steps ``sizes`` (starting at the times ``starts``).

        On the compiled engine where the method's tangent steps are compiled
        (:mod:`lieint.tangent.compiled`: the 3D top's RKMK methods, splittings and Moser–Veselov
        maps, the RKMK methods and embedded pairs of the n-D top, the 3D heavy top, Chaplygin ball and
        rolling ball; steps of any sizes), else step by step on the generic path
        (:meth:`step`);
        :attr:`backend_reason` says which.

        Parameters
        ----------
        z : dict of ndarray
            The complex state (:meth:`seed`).
        starts, sizes : ndarray
            The time at the start of each step and its size.
        state : any, optional
            The method's state (None for one-step methods).

        Returns
        -------
        z1 : dict of ndarray
            The complex state after the steps.
        state : any
            The method's state after them.
        """
        if not self.compiled_reason and state is None and len(sizes):
            self.backend_reason = COMPILED_REASON
            return self._advance_compiled(z, sizes), state
        self.backend_reason = BACKEND_REASON
        with np.errstate(over="ignore", invalid="ignore"):
            for tk, hk in zip(starts, sizes, strict=True):
                z, state = self.step(float(tk), z, float(hk), state)
        return z, state

    def _advance_compiled(self, z: dict, sizes: np.ndarray) -> dict:
        """:meth:`advance` on the compiled engine: the copies read as the real state and its
        derivatives ``Im z / ε``, stepped in forward mode, written back as copies."""
        from .compiled import CompiledTangent

        names = self.chart.names
        first = z[names[0]]
        k = first.shape[0]
        batch = first.shape[1 : first.ndim - len(self.system.fields[names[0]])]
        key = (k, batch)
        engine = self._compiled.get(key)
        if engine is None:
            engine = self._compiled[key] = CompiledTangent(self.system, self.method, k, batch)
        y = {name: np.ascontiguousarray(z[name][0].real) for name in names}
        dy = [{name: z[name][m].imag / COMPLEX_STEP for name in names} for m in range(k)]
        y1, dy1 = engine.advance(y, dy, sizes)
        return {name: y1[name][None] + (1j * COMPLEX_STEP) * np.stack([v[name] for v in dy1]) for name in names}

    def step(self, t: float, z: dict, h: float, state: Any = None) -> tuple[dict, Any]:
        """One step of the method on the complex copies.

        Parameters
        ----------
        t : float
            The time at the start of the step.
        z : dict of ndarray
            The complex state (:meth:`seed`).
        h : float
            The step.
        state : any, optional
            The method's state (from :meth:`Method.init`; None for one-step methods).

        Returns
        -------
        z1 : dict of ndarray
            The complex state after the step.
        state : any
            The method's state after it.

        Raises
        ------
        ValueError
            When the step discarded the imaginary part somewhere (its derivative would be lost).
        """
        with self._complex_kept():
            result = self.method.step(self.system, t, z, h, state)
        return result.y, result.state


@dataclass(frozen=True)
class TangentFlow:
    """The end of a run with the tangent map of its numerical flow.

    Attributes
    ----------
    t : float
        The final time.
    y : dict of ndarray
        The final state (the method's run, as :func:`lieint.integrate` computes it).
    vectors : ndarray, shape (k, ..., dim)
        ``DΦ(y₀) v_j`` for each initial tangent vector ``v_j``; with the default (every unit
        vector) ``vectors[j]`` is the j-th column of the Jacobian ``∂y(T)/∂y₀``.
    chart : TangentChart
        The coordinates of the tangent vectors (:attr:`TangentChart.labels`).
    nsteps : int
        Steps taken.
    backend_reason : str
        Where the tangent steps ran: the compiled engine (:data:`lieint.tangent.compiled.COMPILED_REASON`)
        or the generic path (:data:`BACKEND_REASON`).
    """

    t: float
    y: dict
    vectors: np.ndarray
    chart: TangentChart
    nsteps: int
    backend_reason: str = BACKEND_REASON

    @property
    def jacobian(self) -> np.ndarray:
        """``∂y(T)/∂y₀`` as a matrix ``(*b, dim, k)``: column j is ``DΦ(y₀) v_j``."""
        return np.moveaxis(self.vectors, 0, -1)


def tangent_flow(
    system: LieGroupSystem,
    y0: dict[str, ArrayLike],
    t_span: tuple[float, float],
    h: float | None = None,
    method: str | Method = "rkmk4",
    *,
    coordinates: str | None = None,
    vectors: ArrayLike | None = None,
    steps: ArrayLike | None = None,
    backend: str = "auto",
) -> TangentFlow:
    """Run a method and the exact derivative of its discrete map with respect to ``y₀``.

    Parameters
    ----------
    system : LieGroupSystem
        The system.
    y0 : dict of array_like
        The initial state (any batch of bodies).
    t_span : tuple of float
        ``(t0, t1)``.
    h : float, optional
        The step: fixed steps on the grid of :func:`lieint.integrate` (``t0 + k h``, a short
        last step onto ``t1``). An embedded pair steps its propagated solution so. Give
        either ``h`` or ``steps``.
    method : str or Method, default "rkmk4"
        The method (see :data:`lieint.tangent.flow.REFUSED` for those without a tangent map here).
    coordinates : {"exp", "cayley"}, optional
        The coordinate map of a Lie-group method.
    vectors : array_like, shape (k, dim) or (k, ..., dim), optional
        Initial tangent vectors in the chart's coordinates (:func:`chart_of`); default every
        unit vector (the whole Jacobian).
    steps : array_like of float, optional
        The step sizes to take from ``t0`` instead of ``h`` (e.g. ``np.diff(sol.t)`` of an
        adaptive run saved at every step: the map of that run with its controller held fixed).
    backend : {"auto", "numpy", "numba"}, default "auto"
        Where the steps run (:class:`TangentStepper`); the result's ``backend_reason`` says.

    Returns
    -------
    TangentFlow
        The final state and the propagated tangent vectors.

    Raises
    ------
    ValueError, TypeError
        A bad argument, named; a method without a tangent map here.

    Examples
    --------
    >>> import numpy as np, lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    >>> run = lieint.tangent_flow(top, y0, (0.0, 1.0), h=0.01)
    >>> run.jacobian.shape, run.chart.labels()[:3]
    ((6, 6), ['A[0,1]', 'A[0,2]', 'A[1,2]'])
    """
    stepper = TangentStepper(system, method, coordinates, backend)
    y = system.validate_state(y0)
    t0, t1, starts, sizes = step_schedule(t_span, h, steps)
    chart = stepper.chart
    v = np.eye(chart.dim) if vectors is None else np.asarray(vectors, dtype=float)
    if not np.all(np.isfinite(v)):
        raise ValueError("`vectors` must be finite.")
    z = run_steps(stepper, stepper.seed(y, v), t0, starts, sizes)
    y1, out = stepper.split(z)
    if np.max(np.abs(out), initial=0.0) > 1e20:
        raise FloatingPointError(
            f"the tangent vectors grew beyond 1e20 by t = {t1:g}: the complex step's ε²|v|² would reach the "
            "state's round-off. For exponential growth use lieint.lyapunov (it renormalises), or a shorter span."
        )
    if not (np.all(np.isfinite(out)) and all(np.all(np.isfinite(a)) for a in y1.values())):
        raise FloatingPointError(
            f"the run or its tangent map became non-finite before t = {t1:g}; reduce the step (h = {h}) or the horizon."
        )
    return TangentFlow(t1, y1, out, chart, len(sizes), stepper.backend_reason)


def run_steps(stepper: TangentStepper, z: dict, t0: float, starts: np.ndarray, sizes: np.ndarray) -> dict:
    """The complex state ``z`` stepped by ``stepper`` through the steps of :func:`step_schedule`.

    Parameters
    ----------
    stepper : TangentStepper
        The method on the system.
    z : dict of ndarray
        The complex state (copies on a leading axis).
    t0 : float
        The initial time.
    starts, sizes : ndarray
        The time at the start of each step and its size.

    Returns
    -------
    dict of ndarray
        The complex state after the last step (overflow left to the caller's finiteness check).
    """
    state = stepper.init(t0, z, float(sizes[0]))
    z, _ = stepper.advance(z, starts, sizes, state)
    return z


def step_schedule(
    t_span: tuple[float, float], h: float | None, steps: ArrayLike | None
) -> tuple[float, float, np.ndarray, np.ndarray]:
    """The steps of a run: ``h`` on the grid of :func:`lieint.integrate`, or given sizes.

    Parameters
    ----------
    t_span : tuple of float
        ``(t0, t1)``.
    h : float or None
        The fixed step (grid ``t0 + k h``, a short last step onto ``t1``).
    steps : array_like or None
        Step sizes adding up to ``t1 − t0`` (exactly one of ``h`` and ``steps``).

    Returns
    -------
    t0, t1 : float
        The span.
    starts, sizes : ndarray
        The time at the start of each step and its size.
    """
    try:
        t0, t1 = (float(x) for x in t_span)
    except (TypeError, ValueError):
        raise ValueError(f"`t_span` must be a pair of numbers (t0, t1); got {t_span!r}.") from None
    if not (np.isfinite(t0) and np.isfinite(t1) and t1 > t0):
        raise ValueError(f"`t_span` must be finite with t1 > t0; got {t_span!r}.")
    if (h is None) == (steps is None):
        raise ValueError("give exactly one of `h` (fixed steps) and `steps` (a list of step sizes).")
    if steps is not None:
        sizes = np.asarray(steps, dtype=float).ravel()
        if sizes.size == 0 or not np.all(np.isfinite(sizes)) or np.any(sizes <= 0):
            raise ValueError("`steps` must be a non-empty list of finite positive step sizes.")
        if abs(t0 + sizes.sum() - t1) > 1e-9 * max(1.0, abs(t1)):
            raise ValueError(f"`steps` must add up to t1 - t0 = {t1 - t0:g}; they add up to {sizes.sum():g}.")
        return t0, t1, t0 + np.concatenate([[0.0], np.cumsum(sizes[:-1])]), sizes
    number = isinstance(h, (int, float, np.floating, np.integer)) and not isinstance(h, bool)
    if not (number and np.isfinite(h) and h > 0):
        raise ValueError(f"`h` must be a finite positive number; got {h!r}.")
    plan = Plan.make(t0, t1, float(h))
    k = np.arange(plan.nsteps)
    sizes = np.full(plan.nsteps, plan.h)  # Plan.step_size of every step: h, the last one its own
    sizes[-1] = plan.step_size(plan.nsteps - 1)
    return t0, t1, t0 + k * plan.h, sizes
