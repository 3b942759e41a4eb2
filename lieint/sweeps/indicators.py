"""Chaos indicators per member of a sweep: ``⟨Y⟩`` and the largest Lyapunov exponent.

A sweep asked for ``indicators=("megno", "lyapunov")`` runs, beside each batch's integration,
:func:`lieint.megno` on the same members, method, coordinates, span and step: one tangent
vector per member carried by the exact tangent map of the method (:mod:`lieint.tangent`; not
compiled: the tangent map steps complex copies of the state). Both indicators come from that
one run (:data:`INDICATORS`), and each is stored as a per-member variable of the store.

Every member starts from the same tangent vector — by default the one :func:`lieint.megno`
draws for one body with its default seed — so ``lieint.megno(system, y0, t_span, h, method)``
on one member gives what the sweep stored for it, to round-off. A vector drawn for the whole
batch instead would make a member's indicator depend on the chunk it ran in. The vector is
part of the plan (its fingerprint, and the store's ``plan`` attribute).

The indicators are those of the method's map: a sweep's ``project`` is not applied to the
tangent run (the projection is not part of the map whose derivative is taken).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from .keys import SweepError

__all__ = ["INDICATORS", "check_indicators", "compute_indicators"]

#: the chaos indicators a sweep stores per member, and what each is
INDICATORS = {
    "megno": "the mean MEGNO <Y> at the end of the run (-> 2 quasi-periodic, -> 0 stable periodic, grows if chaotic)",
    "lyapunov": "the largest Lyapunov exponent log|delta(T)|/T from the same tangent vector (-> 0 on a torus)",
}

#: history entries are not needed (only the values at the end): one per this many steps
_NO_HISTORY = 1 << 62


def check_indicators(
    indicators: str | Sequence[str] | None,
    vector: ArrayLike | None,
    system,
    options: dict,
    outputs: Sequence[str] = (),
) -> tuple[tuple[str, ...], tuple[float, ...] | None]:
    """The indicators' names and initial tangent vector, checked against the sweep's system and method.

    Parameters
    ----------
    indicators : str or sequence of str or None
        Names from :data:`INDICATORS`.
    vector : array_like, shape (dim,), optional
        The initial tangent vector of every member (tangent coordinates of
        :func:`lieint.tangent.chart_of`); default that of :func:`lieint.megno` for one body.
    system : LieGroupSystem
        A system of the sweep (its first point).
    options : dict
        The sweep's integrator options (``method``, ``coordinates``).
    outputs : sequence of str
        The sweep's outputs (an indicator may not share a name with one).

    Returns
    -------
    names : tuple of str
    vector : tuple of float or None
        None when no indicator is asked for.

    Raises
    ------
    SweepError
        An unknown name, a method without a tangent map for the system, a vector of the
        wrong shape, a vector without indicators.
    """
    from ..tangent.flow import TangentStepper

    if indicators is None:
        names: tuple = ()
    elif isinstance(indicators, str):
        names = (indicators,)
    else:
        try:
            names = tuple(indicators)
        except TypeError:
            raise SweepError(
                f"`indicators` must be a sequence of names from {sorted(INDICATORS)}; got {indicators!r}"
            ) from None
    for name in names:
        if not isinstance(name, str) or name not in INDICATORS:
            raise SweepError(
                f"`indicators`: {name!r} is not a chaos indicator a sweep stores; choose from {sorted(INDICATORS)}"
            )
    if len(set(names)) < len(names):
        raise SweepError(f"`indicators` names an indicator twice: {list(names)}")
    clash = sorted(set(names) & set(outputs))
    if clash:
        raise SweepError(f"`indicators` {clash} are also asked for as outputs; the store has one variable of each name")
    if not names:
        if vector is not None:
            raise SweepError("`indicator_vector` applies only with `indicators` (e.g. indicators=('megno',))")
        return (), None
    method = options.get("method", "rkmk4")
    try:
        stepper = TangentStepper(system, method, options.get("coordinates"))
    except (ValueError, TypeError) as exc:
        raise SweepError(
            f"`indicators` {list(names)} are computed on the tangent map of the sweep's method, and {method!r} on "
            f"{type(system).__name__} has none: {exc}"
        ) from None
    chart = stepper.chart
    if vector is None:
        # lieint.megno's vector for one body with its default seed (it normalises it)
        v = np.random.default_rng(0).normal(size=chart.dim)
    else:
        try:
            v = np.asarray(vector, dtype=float)
        except (TypeError, ValueError):
            v = None
        if v is None or v.shape != (chart.dim,) or not np.all(np.isfinite(v)) or not np.any(v):
            raise SweepError(
                f"`indicator_vector` must be a nonzero finite vector of the {chart.dim} tangent coordinates "
                f"{chart.labels()} of {type(system).__name__}; got {vector!r}"
            )
    return names, tuple(float(x) for x in v)


def compute_indicators(
    plan, system, y: dict, first_member: int = 0, *, stacked: bool = False
) -> tuple[dict[str, np.ndarray], list[str]]:
    """The plan's indicators of a batch of members, ``{name: (members,)}``.

    A batch whose tangent run fails (a member's state or tangent vector becomes non-finite)
    is run again member by member: the members that fail read NaN, and a note names them.

    Parameters
    ----------
    plan : SweepPlan
        The sweep's plan (its indicators, their vector, span, method and step).
    system : LieGroupSystem
        The batch's system.
    y : dict
        The batch's initial states (one batch axis).
    first_member : int, default 0
        The sweep's index of the batch's first member (for the notes).
    stacked : bool, default False
        Whether ``system`` is stacked (per-member parameters): its members are not run apart.

    Returns
    -------
    values : dict of ndarray
        One value per member of the batch, per indicator.
    notes : list of str
        The members whose indicators could not be computed, and why.
    """
    try:
        return _indicators(plan, system, y), []
    except FloatingPointError as exc:
        n = system.batch_shape(y)[0]
        if stacked or n == 1:
            values = {name: np.full(n, np.nan) for name in plan.indicators}
            return values, [f"indicators of members {first_member}..{first_member + n - 1}: {exc}"]
    values = {name: np.empty(n) for name in plan.indicators}
    notes = []
    for i in range(n):
        try:
            one = _indicators(plan, system, {k: v[i : i + 1] for k, v in y.items()})
        except FloatingPointError as exc:
            one = {name: np.full(1, np.nan) for name in plan.indicators}
            notes.append(f"indicators of member {first_member + i}: {exc}")
        for name in plan.indicators:
            values[name][i] = one[name][0]
    return values, notes


def _indicators(plan, system, y: dict) -> dict[str, np.ndarray]:
    from ..analysis.chaos import megno

    options = plan.options
    run = megno(
        system,
        y,
        plan.t_span,
        float(options["h"]),
        options.get("method", "rkmk4"),
        coordinates=options.get("coordinates"),
        vector=np.asarray(plan.indicator_vector),
        save_every=_NO_HISTORY,
    )
    values = {"megno": run.mean, "lyapunov": run.lyapunov}
    return {name: np.asarray(values[name], dtype=float).reshape(-1) for name in plan.indicators}
