""":func:`integrate`: check the user's arguments, then run the one driver (:mod:`lieint.driver`)."""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from ._validation import check_finite_positive
from .driver import Driver
from .methods.base import Method
from .methods.registry import AUTO, get_method
from .observe import StepObserver, group_action_of
from .solution import Solution
from .systems.base import LieGroupSystem

__all__ = ["LieStepWarning", "integrate"]


class LieStepWarning(RuntimeWarning):
    """The step is too large for the fastest rotation of the motion.

    Raised (as a warning) when ``h ξ(y)`` at a saved state has an ``ad`` spectral radius
    above π -- fewer than two steps per turn of the fastest relative rotation: the method
    stays on the group (Cayley and exponential coordinates alike) but its result is not an
    accurate solution. Exponential coordinates refuse the step outright beyond 2π
    (:class:`lieint.DexpinvRangeError`).
    """


def integrate(
    system: LieGroupSystem,
    y0: Mapping[str, ArrayLike],
    t_span: tuple[float, float],
    h: float | None = None,
    method: str | Method = "rkmk4",
    *,
    coordinates: str | None = None,
    project: bool = False,
    save_every: int = 1,
    dexpinv_degree: int | str | None = AUTO,
    rtol: float = 1e-8,
    atol: float = 1e-10,
    t_eval: ArrayLike | None = None,
    first_step: float | None = None,
    max_step: float | None = None,
    backend: str = "auto",
    dense_output: bool = False,
    events: EventFunction | Sequence[EventFunction] | None = None,
) -> Solution:
    """Integrate ``system`` from ``y0`` over ``t_span``.

    Every argument may be given by keyword, in any order; ``system``, ``y0``, ``t_span``,
    ``h`` and ``method`` may also be given by position, in this order. It is not scipy's
    order: :func:`scipy.integrate.solve_ivp` takes ``(fun, t_span, y0)``, and a call in that
    order is refused with a message saying so.

    Parameters
    ----------
    system : LieGroupSystem
        The system (e.g. :class:`lieint.EulerTop`).
    y0 : dict
        Initial state from ``system.initial_state(...)``; leading batch dimensions integrate
        as one ensemble.
    t_span : (float, float)
        ``(t0, t1)``, either way in time as in scipy: ``t1 < t0`` integrates backward, with
        every method (each step is then negative; ``y0`` is the state at ``t0``).
    h : float, optional
        Step size (positive, also backward) of fixed-step methods (required for them). The
        steps are ``t_k = t0 + k h`` (``t0 − k h`` backward); a last, shorter step lands exactly
        on ``t1`` when ``|t1 − t0|/h`` is not an integer.
        For lieint's adaptive methods the first trial step (the same as ``first_step``); for
        scipy's methods the grid of save times (``t0 + k h``, with ``save_every``).
    method : str or Method, default "rkmk4"
        A name from :func:`lieint.method_names` ("lie_euler", "rkmk2", "rkmk3", "rkmk4",
        "rkmk6"; for adaptive steps on a conservative system **"rkmk853+energy"**, whose global
        error follows rtol on every built-in system — at most 0.02 × rtol at rtol 1e-6 … 1e-10
        where scipy's DOP853 errs 0.2–8 × rtol (docs/measurements/adaptive.md) — and
        "rkmk23+energy", "rkmk45+energy"; the plain pairs "rkmk23", "rkmk45", "rkmk853" bound
        each step's error like scipy's, but near a separatrix their global error is 10³–10⁴ ×
        rtol; the commutator-free "cf3", "cf4", the
        Crouch–Grossman "cg3", "cg4a", the Magnus "magnus4", "magnus6" (generators of t only),
        "rk4", "scipy:DOP853", …) or a method object (:class:`~lieint.methods.Method`).
        scipy's solvers may be named bare as well: "RK45", "RK23", "DOP853", "Radau", "BDF"
        and "LSODA" are "scipy:RK45" etc. (the result's ``method`` is the prefixed name).
    coordinates : {"exp", "cayley"}, optional
        Coordinate map of methods that have one (default: the method's, "exp"); refused for
        methods without coordinates.
    project : bool, default False
        After every step project the state onto its manifold exactly (R onto SO(n) by the
        polar factor). scipy's solvers: the saved copies are projected, their own state is not.
    save_every : int, default 1
        Keep every k-th step (and always the last one).
    dexpinv_degree : int, None or "auto", default "auto"
        dexp⁻¹ truncation of Lie-group methods ("auto": degree p − 2, p + 4 for the adaptive
        pairs, whose error estimate cannot see the truncation; None: exact).
    rtol, atol : float, default 1e-8, 1e-10
        Tolerances of adaptive and scipy methods (ignored by fixed-step methods). Both are
        scalars. The defaults are tighter than scipy's (``rtol=1e-3``, ``atol=1e-6``): the
        methods here are meant for checking numbers, and scipy's defaults give 2–3 correct
        digits. lieint's adaptive methods measure the error on the state as scipy does,
        ``|y − ŷ| / (atol + rtol·|y|)`` in the RMS norm over every component.
    t_eval : array_like, optional
        Times at which to save the solution, inside the span, sorted the way the run goes:
        strictly increasing, or strictly decreasing when ``t1 < t0`` (as in scipy; they need
        not start at ``t0`` nor end at ``t1``; the run still goes to ``t1`` unless a terminal
        event stops it). Every method: lieint's methods save them from
        the dense output on the group (:mod:`lieint.dense`), scipy's from their own. Default:
        the grid of ``h`` and ``save_every``, else every ``save_every``-th accepted step.
    first_step : float, optional
        scipy's name for the first trial step of an adaptive method (lieint's adaptive methods:
        the same as ``h``, give one of them; scipy's: passed to the solver). Default: estimated
        from the vector field at ``y0``. Refused for fixed-step methods (they take ``h``).
    max_step : float, optional
        scipy's largest step size for an adaptive method: no trial step (the first included)
        is longer, lieint's pairs and scipy's solvers alike (passed to the solver). Use it when
        the tolerance lets the steps grow across what the run must resolve, such as the flips
        of a top near its middle axis. Default (or ``inf``, scipy's default): no bound. Refused
        for fixed-step methods (their step is ``h``).
    backend : {"auto", "numpy", "numba"}, default "auto"
        "auto" runs the compiled engine where the system and the method declare compiled forms
        (RKMK in exponential coordinates with truncated dexp⁻¹ or in Cayley coordinates, its
        embedded pairs with the whole step-size control loop, classical RK; on the Euler top of
        any dimension n ≥ 3, the heavy top, the free body and the balls), dense output, events
        and ``t_eval`` included, else the generic numpy path; "numpy" forces the generic path
        (the reference); "numba" requires the engine. ``sol.stats.backend_reason`` says why.
    dense_output : bool, default False
        Keep a continuous solution ``sol.sol(t)`` (:class:`lieint.dense.DenseOutput`): for
        Lie-group methods interpolated in the Lie algebra of each step, so its states lie on
        the manifold.
    events : callable or list of callables, optional
        Event functions ``g(t, y)`` with scipy's ``terminal`` and ``direction`` attributes,
        located on the dense output to 1e-12 in time (:mod:`lieint.events`); the result has
        ``t_events`` and ``y_events``. As in scipy, a crossing's direction is read in the
        order the run goes: backward in time, ``direction > 0`` selects the crossings where
        ``g`` rises as t decreases.

    Returns
    -------
    Solution
        ``t``, ``states`` (``(m, *batch, ...)`` per field), lazy ``invariants``, ``status``,
        ``success``, ``message``, ``stats`` (:class:`lieint.Stats`: steps, rejections,
        evaluations, times, back end); ``sol.y`` is scipy's ``(n_components, m)`` layout.

    Raises
    ------
    TypeError, ValueError
        A bad argument, named with what was expected and what was received.
    lieint.DexpinvRangeError
        When a Lie step is too large for the dexp⁻¹ series (exp coordinates).

    See Also
    --------
    scipy.integrate.solve_ivp : The interface this one follows where it fits.

    Notes
    -----
    The arguments of :func:`scipy.integrate.solve_ivp` and what stands for them here:

    ========================  =============================================================
    ``solve_ivp``             ``lieint.integrate``
    ========================  =============================================================
    ``fun``                   ``system`` (a :class:`~lieint.LieGroupSystem`: equations, group,
                              invariants), not a function
    ``t_span``                ``t_span`` (either way: ``t1 < t0`` integrates backward, every
                              method)
    ``y0`` (a vector)         ``y0`` (a state dict from ``system.initial_state``)
    ``method="RK45"``         ``method="RK45"`` or ``"scipy:RK45"``; lieint's methods by name
    ``t_eval``                ``t_eval`` (the same rules: inside the span, decreasing backward)
    ``dense_output``          ``dense_output`` (``sol.sol(t)`` returns a state dict)
    ``events``                ``events`` (``g(t, y)`` of a state dict; ``terminal``,
                              ``direction`` read in the run's order, also backward)
    ``rtol``, ``atol``        ``rtol``, ``atol`` (scalars; defaults 1e-8, 1e-10)
    ``first_step``            ``first_step`` (or ``h``) for adaptive methods
    (none)                    ``h``: the step of fixed-step methods
    ``max_step``              ``max_step`` for adaptive methods (lieint's and scipy's)
    ``OdeResult.t``           ``sol.t``
    ``OdeResult.y``           ``sol.y`` (the same layout, :attr:`Solution.y`); by field:
                              ``sol.states``
    ``status``                ``sol.status``: −1 failure, 0 reached ``t1``, 1 a terminal event
    ``message``, ``success``  ``sol.message``, ``sol.success``
    ``nfev``                  ``sol.nfev`` (``sol.stats``: steps, rejections, times)
    ``t_events``              ``sol.t_events``
    ``y_events``              ``sol.y_events`` (states as dicts)
    ``sol``                   ``sol.sol``
    ========================  =============================================================

    Examples
    --------
    A fixed-step Lie-group method keeps the Casimirs (the spectrum of A) to round-off:

    >>> import lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> y0 = top.initial_state(angular_velocity=[0.01, 1.0, 0.01])
    >>> sol = lieint.integrate(top, y0, t_span=(0.0, 10.0), h=0.01, method="rkmk4")
    >>> sol.status, sol.t.shape, sol.states["A"].shape
    (0, (1001,), (1001, 3, 3))
    >>> bool(sol.drift("casimirs") < 1e-13)
    True

    An adaptive pair, saved at given times, in scipy's layout:

    >>> sol = lieint.integrate(top, y0, (0.0, 10.0), method="rkmk45", rtol=1e-9, t_eval=[2.5, 5.0, 7.5])
    >>> t, y = sol.t, sol.y
    >>> y.shape  # 9 entries of A, then 9 of R, at 3 times
    (18, 3)

    Backward in time, from the last state saved (at t = 7.5) back to t = 0, no step longer
    than 0.1:

    >>> y_end = {name: rows[-1] for name, rows in sol.states.items()}
    >>> back = lieint.integrate(top, y_end, (7.5, 0.0), method="rkmk45", rtol=1e-9, max_step=0.1)
    >>> float(back.t[-1]), bool(abs(back.t[1] - back.t[0]) <= 0.1)
    (0.0, True)
    """
    # a built-in system's class has LieGroupSystem in its MRO: found without the ABC's Python-level
    # instance check (which still answers for any other class)
    if LieGroupSystem not in type(system).__mro__ and not isinstance(system, LieGroupSystem):
        raise TypeError(_not_a_system(system))
    _refuse_scipy_order(y0, t_span)
    if isinstance(h, str) and _names_a_method(h):
        raise TypeError(
            f"`h` (the 4th positional argument: the step size) must be a positive finite number; got {h!r}. "
            f"The method is the 5th positional argument, or by keyword: method={h!r}."
        )
    stepper = get_method(method, coordinates=coordinates, **_options(method, dexpinv_degree))
    y = system.validate_state(y0, "y0")
    t0, t1 = check_t_span(t_span, backward=True)
    if isinstance(save_every, bool) or not isinstance(save_every, (int, np.integer)) or save_every < 1:
        raise ValueError(f"`save_every` must be a positive integer; got {save_every!r}.")
    if not isinstance(project, (bool, np.bool_)):
        raise TypeError(f"`project` must be True or False; got {project!r}.")
    if backend not in ("auto", "numpy", "numba"):
        raise ValueError(f"`backend` must be one of ['auto', 'numpy', 'numba']; got {backend!r}.")
    if h is not None:
        if isinstance(h, (int, float, np.integer, np.floating)) and not isinstance(h, (bool, np.bool_)) and h < 0:
            raise ValueError(
                f"`h` must be a positive finite number; got {h!r}. The step size is positive either way in time: "
                f"to integrate backward give t_span = (t0, t1) with t1 < t0, e.g. t_span=({t1}, {t0})."
            )
        h = check_finite_positive(h, "h")
    if stepper.adaptive or stepper.self_controlled:
        for name, tol in (("rtol", rtol), ("atol", atol)):
            if np.ndim(tol) > 0:  # scipy takes an atol per component; lieint's error norms take one
                raise TypeError(
                    f"`{name}` must be one positive number (per-component tolerances, which scipy's atol "
                    f"allows, are not supported); got an array of shape {np.shape(tol)}."
                )
        rtol = check_finite_positive(rtol, "rtol")
        atol = check_finite_positive(atol, "atol")
        if first_step is not None:
            h, stepper = _first_step(first_step, h, stepper, t0, t1)
        if max_step is not None:
            max_step, stepper = _max_step(max_step, stepper)
    elif max_step is not None:
        raise ValueError(
            f"`max_step` applies to adaptive methods, which choose their steps; {stepper.name!r} takes fixed "
            f"steps of the size `h` you give (got max_step = {max_step!r}): drop max_step, or choose an adaptive "
            "method (method='rkmk45', 'rkmk853', scipy's 'RK45', 'DOP853', …)."
        )
    elif first_step is not None:
        raise ValueError(
            f"`first_step` applies to adaptive methods; {stepper.name!r} takes fixed steps: give `h` instead "
            f"(got first_step = {first_step!r})."
        )
    elif h is None:
        raise ValueError(_h_required(system, stepper, y, t0))
    if not isinstance(dense_output, (bool, np.bool_)):
        raise TypeError(f"`dense_output` must be True or False; got {dense_output!r}.")
    if t_eval is not None:
        t_eval = _check_t_eval(t_eval, t0, t1)
    # scipy's solvers save t_eval through the driver, which starts the rows at t0 and ends a
    # terminal event's run with the event's row: t0 is added in front, and the rows not at a
    # time of t_eval are dropped afterwards (lieint's methods save t_eval in the observer)
    t_eval_driver = t_eval
    if t_eval is not None and stepper.self_controlled and t_eval[0] != t0:
        t_eval_driver = np.concatenate([[t0], t_eval])
    observer = _observer(system, stepper, (t0, t1), t_eval, dense_output, events, project)
    driver = Driver(
        system,
        stepper,
        (t0, t1),
        h=h,
        rtol=rtol,
        atol=atol,
        project=bool(project),
        save_every=int(save_every),
        t_eval=t_eval_driver,
        max_step=max_step if not stepper.self_controlled else None,
        backend=backend,
        observer=observer,
    )
    sol = driver.run(y)
    if t_eval is not None and stepper.self_controlled:
        sol._keep_rows(np.isin(sol.t, t_eval))
    if driver.kind == "fixed" and not getattr(stepper, "any_step", False):  # exact flows take any step
        _warn_if_unresolved(system, sol, h, driver.generator_radius(sol.states, limit=np.pi / h))
    return sol


#: an event function ``g(t, y) -> float`` (with optional ``terminal`` and ``direction``)
EventFunction = Callable[[float, dict], float]


def _not_a_system(system) -> str:
    """The message for a ``system`` that is not a lieint system (a scipy ``fun`` among them)."""
    message = f"`system` must be a lieint system (e.g. lieint.EulerTop); got {type(system).__name__}."
    if callable(system):
        message += (
            " lieint integrates systems, not a right-hand side fun(t, y) as scipy.integrate.solve_ivp does: "
            "build the body (lieint.EulerTop, lieint.HeavyTop, …) and pass it with its initial state, "
            "integrate(system, y0=system.initial_state(...), t_span=(t0, t1), ...)."
        )
    return message


def _refuse_scipy_order(y0, t_span) -> None:
    """Refuse ``integrate(system, t_span, y0)`` (scipy's positional order) with a message."""
    if type(y0) is not dict and not isinstance(y0, Mapping) and (isinstance(t_span, Mapping) or _looks_like_a_span(y0)):
        raise TypeError(
            "lieint.integrate takes (system, y0, t_span): the initial state second, the time span third; "
            f"got the time span {y0!r} second and the state third, which is scipy's order "
            "(solve_ivp(fun, t_span, y0)). Swap them, or pass both by keyword: "
            "integrate(system, t_span=(t0, t1), y0=y0)."
        )


def _names_a_method(name: str) -> bool:
    """Whether ``name`` is a method's name (``integrate(system, y0, t_span, "RK45")`` gives it as h)."""
    try:
        get_method(name)
    except (TypeError, ValueError):
        return False
    return True


def _looks_like_a_span(value) -> bool:
    """A pair of real numbers (what scipy's ``t_span`` is)."""
    try:
        arr = np.asarray(value)
    except Exception:  # a ragged sequence: not a pair of numbers
        return False
    return arr.shape == (2,) and arr.dtype.kind in "iuf"


def _first_step(first_step, h, stepper, t0: float, t1: float):
    """``first_step`` checked, as the driver's ``h`` (lieint's adaptive methods) or in the scipy
    solver (whose ``h`` is the save grid); returns ``(h, stepper)``."""
    first_step = check_finite_positive(first_step, "first_step")
    if first_step > abs(t1 - t0):
        span = "t1 - t0" if t1 > t0 else "|t1 - t0|"
        raise ValueError(
            f"`first_step` = {first_step:g} must not exceed the span {span} = {abs(t1 - t0):g} (as in scipy)."
        )
    if stepper.self_controlled:
        if not hasattr(stepper, "first_step"):
            raise ValueError(f"`first_step` does not apply to the method object {stepper.name!r}.")
        return h, dataclasses.replace(stepper, first_step=first_step)
    if h is not None and h != first_step:
        raise ValueError(
            f"`h` = {h:g} and `first_step` = {first_step:g} both set the first trial step of the adaptive "
            f"method {stepper.name!r}; give one of them."
        )
    return first_step, stepper


def _max_step(max_step, stepper):
    """``max_step`` checked (a positive number; ``inf``, scipy's default, sets no bound): for
    lieint's adaptive methods the driver's bound, for scipy's passed to the solver; returns
    ``(max_step, stepper)`` (None when there is no bound)."""
    expected = "a positive number, the largest step size (inf, scipy's default, for no bound)"
    if isinstance(max_step, (bool, np.bool_)) or not isinstance(max_step, (int, float, np.integer, np.floating)):
        raise TypeError(f"`max_step` must be {expected}; got {max_step!r}.")
    max_step = float(max_step)
    if math.isnan(max_step) or max_step <= 0:
        raise ValueError(f"`max_step` must be {expected}; got {max_step!r}.")
    if math.isinf(max_step):  # scipy's default: no bound
        return None, stepper
    if stepper.self_controlled:
        if not hasattr(stepper, "max_step"):
            raise ValueError(f"`max_step` does not apply to the method object {stepper.name!r}.")
        return None, dataclasses.replace(stepper, max_step=max_step)
    return max_step, stepper


def _h_required(system, stepper, y: dict, t0: float) -> str:
    """The message of a fixed-step method called without ``h``: how to choose one."""
    message = (
        f"`h` (the step size) is required for the fixed-step method {stepper.name!r}. Either choose an adaptive "
        "method, which picks its steps from `rtol`/`atol` (method='rkmk45' or 'rkmk853', their '+energy' "
        "forms keeping the energy, or scipy's 'RK45', 'DOP853'), or give `h`: well below the period of the "
        "fastest rotation (lieint warns when ‖h Ω‖ reaches pi, fewer than two steps per turn), then halve it "
        "and compare: an "
        f"order-p method's error falls about 2^p-fold ({stepper.name!r}: p = {stepper.order})."
    )
    try:  # the fastest rotation at y0, when the system has a generator there
        with np.errstate(all="ignore"):
            rate = float(np.max(system.group.ad_spectral_radius(system.generator(t0, y)), initial=0.0))
    except Exception:  # only a hint: a system without a generator gets none
        return message
    if math.isfinite(rate) and rate > 0:
        message += (
            f" Here the fastest rotation at y0 turns at {rate:.3g} rad per unit time (a turn in "
            f"{2 * np.pi / rate:.3g}); h = {0.01 / rate:.2g} takes about 600 steps per turn."
        )
    return message


def _observer(system, stepper, t_span, t_eval, dense_output, events, project) -> StepObserver | None:
    """The step observer of dense output, events and ``t_eval`` rows; None when nothing watches
    the steps (the driver would drop an inactive observer: building one costs microseconds)."""
    if stepper.self_controlled:
        t_eval = None  # scipy's solvers save t_eval through their own dense output
    if not dense_output and events is None and t_eval is None:
        return None
    t0, t1 = t_span
    return StepObserver(
        system,
        t0,
        direction=1.0 if t1 >= t0 else -1.0,
        t_eval=t_eval,
        dense_output=bool(dense_output),
        events=events,
        project=bool(project),
        order=stepper.order,
        group_action=group_action_of(stepper),
    )


def _options(method, dexpinv_degree) -> dict:
    """Build options to pass on: ``dexpinv_degree`` only when the user set it."""
    if dexpinv_degree is AUTO or (isinstance(dexpinv_degree, str) and dexpinv_degree == "auto"):
        return {}
    return {"dexpinv_degree": dexpinv_degree}


def _check_t_eval(t_eval, t0: float, t1: float) -> np.ndarray:
    """``t_eval`` as a float array: times inside the span, strictly increasing when ``t1 > t0``
    and strictly decreasing when ``t1 < t0`` (scipy's rules)."""
    try:
        t_save = np.asarray(t_eval, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"`t_eval` must be a 1-D array of times; got {type(t_eval).__name__}.") from None
    if t_save.ndim != 1 or t_save.size < 1 or not np.all(np.isfinite(t_save)):
        raise ValueError(f"`t_eval` must be a 1-D array of at least one finite time; got shape {t_save.shape}.")
    forward = t1 > t0
    steps = np.diff(t_save) if forward else -np.diff(t_save)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0))
        way = "increase strictly" if forward else "decrease strictly (t1 < t0: a run backward in time)"
        raise ValueError(f"`t_eval` must {way}; got t_eval[{k}] = {t_save[k]} followed by {t_save[k + 1]}.")
    lo, hi = min(t0, t1), max(t0, t1)
    if t_save.min() < lo or t_save.max() > hi:
        raise ValueError(f"`t_eval` must lie inside t_span = ({t0}, {t1}); got times from {t_save[0]} to {t_save[-1]}.")
    return t_save


#: saved states at which the step is checked against the motion's fastest rotation
_WARN_SAMPLES = 200


def _warn_if_unresolved(system, sol: Solution, h: float, radius: float | None = None) -> None:
    """Warn when ``h ξ`` at the saved states exceeds π in ad spectral radius (see LieStepWarning).

    ``radius``: the largest ad spectral radius of ξ over every saved state, or an upper bound
    of it below π/h, when the back end computed it (a compiled kernel's ``generator_radius``);
    None evaluates ξ at the saved states (at most :data:`_WARN_SAMPLES` of them)."""
    if sol.t.size == 0:
        return
    if radius is not None:
        _warn(h * radius, h)
        return
    if sol.t.size <= _WARN_SAMPLES:  # every saved state (views: no copy, no index arithmetic)
        picks, sampled = range(sol.t.size), sol.states
    else:
        picks = np.unique(np.linspace(0, sol.t.size - 1, _WARN_SAMPLES).astype(int))
        sampled = {k: v[picks] for k, v in sol.states.items()}
    with np.errstate(all="ignore"):
        if getattr(system, "autonomous", False):
            # ξ does not depend on t: one batched evaluation over the sampled states
            scaled = system.group.lincomb([h], [system.generator(float(sol.t[0]), sampled)])
            rho = system.group.ad_radius_upper_bound(scaled)
            if _reaches_pi(rho):
                rho = system.group.ad_spectral_radius(scaled)
        else:
            # generators take one time (scalar logic such as `if t > …` is allowed)
            worst_rho = []
            for i in picks:
                y = {k: v[i] for k, v in sol.states.items()}
                scaled = system.group.lincomb([h], [system.generator(float(sol.t[i]), y)])
                r = system.group.ad_radius_upper_bound(scaled)
                if _reaches_pi(r):
                    r = system.group.ad_spectral_radius(scaled)
                worst_rho.append(_finite_max(r))
            rho = np.array(worst_rho)
    _warn(_finite_max(rho), h)


def _warn(worst: float, h: float) -> None:
    """The :class:`LieStepWarning` when the largest radius of ``h ξ`` reaches π."""
    if worst >= np.pi:
        warnings.warn(
            LieStepWarning(
                f"h = {h:g} is too large for this motion: ‖h ξ‖ reaches {worst:.3g} >= pi (ad spectral radius) at the "
                "saved states, fewer than two steps per turn of the fastest rotation: the result is not an accurate "
                "solution (a Lie-group method still keeps it on its manifold); reduce `h`."
            ),
            stacklevel=4,  # integrate → _warn_if_unresolved → _warn: the caller of integrate
        )


def _reaches_pi(rho) -> bool:
    """Whether any radius is ``>= pi`` (one reduction when the largest is finite)."""
    top = np.maximum.reduce(rho, axis=None, initial=0.0)
    if math.isfinite(top):
        return bool(top >= np.pi)
    return bool(np.logical_or.reduce(rho >= np.pi, axis=None))  # NaN hides an element >= pi


def _finite_max(rho) -> float:
    """The largest finite radius (0 when none is), in one reduction when all are finite."""
    top = float(np.maximum.reduce(rho, axis=None, initial=0.0))
    if math.isfinite(top):
        return top
    return float(np.maximum.reduce(np.where(np.isfinite(rho), rho, 0.0), axis=None, initial=0.0))


def check_t_span(t_span, backward: bool = False) -> tuple[float, float]:
    """``(t0, t1)`` as floats: finite, ``t1 != t0``; ``t1 > t0`` unless ``backward`` allows either way."""
    try:
        t0, t1 = map(float, t_span)
    except (TypeError, ValueError):
        raise ValueError(f"`t_span` must be a pair (t0, t1) of numbers; got {t_span!r}.") from None
    if not (math.isfinite(t0) and math.isfinite(t1)):
        raise ValueError(f"`t_span` must be finite; got {t_span!r}.")
    if backward and t1 == t0:
        raise ValueError(f"`t_span` = (t0, t1) must have t1 != t0 (nonempty, either way in time); got {t_span!r}.")
    if not backward and not t1 > t0:
        raise ValueError(f"`t_span` = (t0, t1) must have t1 > t0 (nonempty, forward in time); got {t_span!r}.")
    return t0, t1
