""":func:`integrate`: check the user's arguments, then run the one driver (:mod:`lieint.driver`)."""

from __future__ import annotations

import math
import warnings

import numpy as np

from ._validation import check_finite_positive
from .driver import Driver
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
    y0: dict,
    t_span: tuple[float, float],
    h: float | None = None,
    method="rkmk4",
    *,
    coordinates: str | None = None,
    project: bool = False,
    save_every: int = 1,
    dexpinv_degree=AUTO,
    rtol: float = 1e-8,
    atol: float = 1e-10,
    t_eval=None,
    backend: str = "auto",
    dense_output: bool = False,
    events=None,
) -> Solution:
    """Integrate ``system`` from ``y0`` over ``t_span``.

    Parameters
    ----------
    system : LieGroupSystem
        The system (e.g. :class:`lieint.EulerTop`).
    y0 : dict
        Initial state from ``system.initial_state(...)``; leading batch dimensions integrate
        as one ensemble.
    t_span : (float, float)
        ``(t0, t1)`` with ``t1 > t0``.
    h : float
        Step size of fixed-step methods. The steps are ``t_k = t0 + k h``; a last, shorter
        step lands exactly on ``t1`` when ``(t1 − t0)/h`` is not an integer. For adaptive
        methods the initial step (default: estimated); for scipy methods only the save grid.
    method : str or Method
        A name from :func:`lieint.method_names` ("lie_euler", "rkmk2", "rkmk3", "rkmk4",
        "rkmk6", the adaptive "rkmk23", "rkmk45", "rkmk853" and, for conservative systems, the
        same pairs keeping the energy, "rkmk23+energy", "rkmk45+energy", "rkmk853+energy"
        (global error per rtol like scipy's pairs'; the guide), the commutator-free "cf3", "cf4",
        the Crouch–Grossman "cg3", "cg4a", the Magnus "magnus4", "magnus6" (generators of t
        only), "rk4", "scipy:DOP853", …) or a
        method object (:class:`~lieint.methods.Method`).
    coordinates : {"exp", "cayley"}, optional
        Coordinate map of methods that have one (default: the method's, "exp"); refused for
        methods without coordinates.
    project : bool, default False
        After every step project the state onto its manifold exactly (R onto SO(n) by the
        polar factor). scipy's solvers: the saved copies are projected, their own state is not.
    save_every : int, default 1
        Keep every k-th step (and always the last one).
    dexpinv_degree : int, None or "auto"
        dexp⁻¹ truncation of Lie-group methods ("auto": degree p − 2; None: exact).
    rtol, atol : float
        Tolerances of adaptive and scipy methods (adaptive Lie-group methods measure the error
        on the state: ``|y − ŷ| / (atol + rtol·|y|)`` in the RMS norm).
    t_eval : array_like, optional
        Save times, increasing from ``t0`` to ``t1`` (every method; lieint's methods save them
        from the dense output on the group, :mod:`lieint.dense`). Default: the grid of ``h``
        and ``save_every``, else every ``save_every``-th accepted step.
    backend : {"auto", "numpy", "numba"}
        "auto" runs a compiled kernel where one covers the system and method (the Euler top
        of any dimension n ≥ 3 with fixed-step RKMK in exponential coordinates and truncated
        dexp⁻¹, or classical RK; on the 3D top also the RKMK embedded pairs with their whole
        step-size control loop), else the generic numpy path; "numpy" forces the generic path
        (the reference); "numba" requires the kernel. Dense output, events and ``t_eval``
        watch every step and keep the generic path.
    dense_output : bool, default False
        Keep a continuous solution ``sol.sol(t)`` (:class:`lieint.dense.DenseOutput`): for
        Lie-group methods interpolated in the Lie algebra of each step, so its states lie on
        the manifold.
    events : callable or list of callables, optional
        Event functions ``g(t, y)`` with scipy's ``terminal`` and ``direction`` attributes,
        located on the dense output to 1e-12 in time (:mod:`lieint.events`); the result has
        ``t_events`` and ``y_events``.

    Returns
    -------
    Solution
        ``t``, ``states`` (``(m, *batch, ...)`` per field), lazy ``invariants``, ``stats``
        (:class:`lieint.driver.Stats`: steps, rejections, evaluations, times, back end).

    Raises
    ------
    lieint.groups.DexpinvRangeError
        When a Lie step is too large for the dexp⁻¹ series (exp coordinates).
    """
    if not isinstance(system, LieGroupSystem):
        raise TypeError(f"`system` must be a lieint system (e.g. lieint.EulerTop); got {type(system).__name__}.")
    stepper = get_method(method, coordinates=coordinates, **_options(method, dexpinv_degree))
    y = system.validate_state(y0, "y0")
    t0, t1 = _check_t_span(t_span)
    if isinstance(save_every, bool) or not isinstance(save_every, (int, np.integer)) or save_every < 1:
        raise ValueError(f"`save_every` must be a positive integer; got {save_every!r}.")
    if not isinstance(project, (bool, np.bool_)):
        raise TypeError(f"`project` must be True or False; got {project!r}.")
    if backend not in ("auto", "numpy", "numba"):
        raise ValueError(f"`backend` must be one of ['auto', 'numpy', 'numba']; got {backend!r}.")
    if h is not None:
        h = check_finite_positive(h, "h")
    if stepper.adaptive or stepper.self_controlled:
        rtol = check_finite_positive(rtol, "rtol")
        atol = check_finite_positive(atol, "atol")
    elif h is None:
        raise ValueError(f"`h` (the step size) is required for the fixed-step method {stepper.name!r}.")
    if not isinstance(dense_output, (bool, np.bool_)):
        raise TypeError(f"`dense_output` must be True or False; got {dense_output!r}.")
    if t_eval is not None:
        t_eval = _check_t_eval(t_eval, t0, t1)
    observer = _observer(system, stepper, t0, t_eval, dense_output, events, project)
    driver = Driver(
        system,
        stepper,
        (t0, t1),
        h=h,
        rtol=rtol,
        atol=atol,
        project=bool(project),
        save_every=int(save_every),
        t_eval=t_eval,
        backend=backend,
        observer=observer,
    )
    sol = driver.run(y)
    if driver.kind == "fixed" and not getattr(stepper, "any_step", False):  # exact flows take any step
        _warn_if_unresolved(system, sol, h, driver.generator_radius(sol.states, limit=np.pi / h))
    return sol


def _observer(system, stepper, t0: float, t_eval, dense_output, events, project) -> StepObserver | None:
    """The step observer of dense output, events and ``t_eval`` rows; None when nothing watches
    the steps (the driver would drop an inactive observer: building one costs microseconds)."""
    if stepper.self_controlled:
        t_eval = None  # scipy's solvers save t_eval through their own dense output
    if not dense_output and events is None and t_eval is None:
        return None
    return StepObserver(
        system,
        t0,
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
    try:
        t_save = np.asarray(t_eval, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"`t_eval` must be a 1-D array of times; got {type(t_eval).__name__}.") from None
    if t_save.ndim != 1 or t_save.size < 2 or not np.all(np.isfinite(t_save)):
        raise ValueError(f"`t_eval` must be a 1-D array of at least two finite times; got shape {t_save.shape}.")
    if t_save[0] != t0 or t_save[-1] != t1 or np.any(np.diff(t_save) <= 0):
        raise ValueError(
            f"`t_eval` must increase strictly from t0 = {t0} to t1 = {t1}; got first {t_save[0]}, last {t_save[-1]}."
        )
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


def _check_t_span(t_span) -> tuple[float, float]:
    try:
        t0, t1 = (float(v) for v in t_span)
    except (TypeError, ValueError):
        raise ValueError(f"`t_span` must be a pair (t0, t1) of numbers; got {t_span!r}.") from None
    if not (math.isfinite(t0) and math.isfinite(t1)):
        raise ValueError(f"`t_span` must be finite; got {t_span!r}.")
    if not t1 > t0:
        raise ValueError(f"`t_span` = (t0, t1) must have t1 > t0 (nonempty, forward in time); got {t_span!r}.")
    return t0, t1
