"""Parameter sensitivities ``∂y(T)/∂θ`` of a run, by the complex step through the parameters.

For each component c of a parameter θ (an entry of the mass tensor, the mass, a component of
the centre of mass or of gravity, the radius), the system is rebuilt with the complex value
``θ + iε e_c`` (:meth:`LieGroupSystem.with_parameter_step`: every derived quantity recomputed
analytically, nothing validated again, since the real system was), the method steps the
real initial state with it, and ``Im y(T)/ε`` read in the tangent coordinates of
:mod:`lieint.tangent.coordinates` is ``∂y(T)/∂θ_c`` — the exact derivative of the discrete
map with respect to the parameter, as :func:`lieint.tangent_flow` is with respect to ``y₀``.

Components: a scalar is one; a vector its entries; a mass tensor (symmetric) its upper
triangle ``(i, j)``, ``i ≤ j``, the off-diagonal ones moving ``B_ij`` and ``B_ji`` together
(the derivative along ``E_ij + E_ji``). A 3D body with a diagonal mass tensor also offers
``moments``, its principal moments ``I_k = b_i + b_j`` in the order of the axes: since
``b_i = (I_j + I_k − I_i)/2``, the moment ``I_k`` moves B along ``diag(½ − δ_ik)``.

The initial state is held as given, except the fields a parameter defines through the pose:
``Γ = Rᵀg`` (heavy top) and ``G = Rᵀg`` (a ball on an incline) follow g for the same attitude,
and a ball's centre stays at the height r.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..methods.base import Method
from ..systems.base import LieGroupSystem
from .coordinates import TangentChart
from .flow import BACKEND_REASON, COMPLEX_STEP, TangentStepper, family_of, run_steps, step_schedule

__all__ = ["Sensitivity", "offered_parameters", "sensitivity"]

#: method families that read the principal axes of B (a perturbed non-diagonal B has none analytic)
_AXES_FAMILIES = ("splitting",)


@dataclass(frozen=True)
class Sensitivity:
    """The end of a run with its derivatives with respect to the system's parameters.

    Attributes
    ----------
    t : float
        The final time.
    y : dict of ndarray
        The final state (the method's run, as :func:`lieint.integrate` computes it).
    jacobian : ndarray, shape (..., dim, p)
        ``∂y(T)/∂θ``: row i a tangent coordinate (:attr:`chart`), column c a parameter
        component (:attr:`labels`).
    labels : list of str
        The components, e.g. ``["mass", "center_of_mass[0]", "mass_tensor[0,1]", …]``.
    chart : TangentChart
        The coordinates of the rows (:meth:`TangentChart.labels`).
    nsteps : int
        Steps taken.
    backend_reason : str
        Why the run is not compiled.
    """

    t: float
    y: dict
    jacobian: np.ndarray
    labels: list[str]
    chart: TangentChart
    nsteps: int
    backend_reason: str = BACKEND_REASON

    def of(self, name: str) -> np.ndarray:
        """The columns of one parameter, ``(*b, dim, components)``.

        Parameters
        ----------
        name : str
            A parameter name (``"mass"``, ``"mass_tensor"``, …).

        Returns
        -------
        ndarray
            Its columns of :attr:`jacobian`, in the order of :attr:`labels`.
        """
        columns = [c for c, label in enumerate(self.labels) if label.split("[")[0] == name]
        if not columns:
            names = sorted({label.split("[")[0] for label in self.labels})
            raise ValueError(f"`name` must be one of the parameters of this result {names}; got {name!r}.")
        return self.jacobian[..., columns]


def _components(name: str, value: np.ndarray) -> list[tuple[str, np.ndarray]]:
    """(label, unit direction) of each component of a parameter (see the module docstring)."""
    if value.ndim == 0:
        return [(name, np.array(1.0))]
    if value.ndim == 1:
        return [(f"{name}[{k}]", np.eye(value.size)[k]) for k in range(value.size)]
    n = value.shape[0]
    out = []
    for i, j in zip(*np.triu_indices(n), strict=True):
        E = np.zeros((n, n))
        E[i, j] = E[j, i] = 1.0
        out.append((f"{name}[{i},{j}]", E))
    return out


def _tensor_name(values: dict) -> str | None:
    """The name of the system's mass tensor parameter, if it has one."""
    return next((name for name in ("B", "mass_tensor") if name in values), None)


def offered_parameters(system: LieGroupSystem) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """What ``system`` offers to :func:`sensitivity` (its own parameters, and ``moments`` for a
    diagonal 3D mass tensor), and what it refuses with why.

    Parameters
    ----------
    system : LieGroupSystem
        The system.

    Returns
    -------
    offered : dict of ndarray
        name → value.
    refused : dict of str
        name → why not.
    """
    offered = system.parameter_values()
    refused = dict(system.parameter_refusals())
    tensor = _tensor_name(offered)
    if tensor is not None and offered[tensor].shape == (3, 3):
        B = offered[tensor]
        if np.all(B == np.diag(np.diag(B))):
            offered["moments"] = np.diag(B).sum() - np.diag(B)
        else:
            refused["moments"] = (
                f"its mass tensor {tensor!r} is not diagonal, so its principal axes are an eigendecomposition; "
                f"differentiate with respect to {tensor!r} instead"
            )
    return offered, refused


def _chosen(system: LieGroupSystem, parameters) -> list[str]:
    """The parameter names asked for, checked against what the system offers."""
    offered, refused = offered_parameters(system)
    if not offered:
        why = "; ".join(sorted(set(refused.values())))
        raise ValueError(
            f"`system` {type(system).__name__} offers no numeric parameters to differentiate by"
            + (f" ({why})" if why else "")
            + "; lieint.tangent_flow differentiates with respect to the initial state."
        )
    if parameters is None:
        return list(offered)
    if isinstance(parameters, str):
        parameters = [parameters]
    try:
        names = list(parameters)
    except TypeError:
        raise TypeError(f"`parameters` must be a list of parameter names; got {type(parameters).__name__}.") from None
    if not names:
        raise ValueError(f"`parameters` must name at least one of {list(offered)}; got an empty list.")
    for name in names:
        if not isinstance(name, str):
            raise TypeError(f"`parameters` must be a list of names (str) from {list(offered)}; got {name!r}.")
        if name in refused:
            raise ValueError(
                f"`parameters` names {name!r}, which {type(system).__name__} cannot offer: {refused[name]}."
            )
        if name not in offered:
            raise ValueError(
                f"`parameters` names {name!r}, which {type(system).__name__} does not have; its parameters are "
                f"{list(offered)}."
            )
    if len(set(names)) != len(names):
        raise ValueError(f"`parameters` names a parameter twice: {names}.")
    return names


def sensitivity(
    system: LieGroupSystem,
    y0: dict[str, ArrayLike],
    t_span: tuple[float, float],
    h: float | None = None,
    method: str | Method = "rkmk4",
    *,
    parameters: list[str] | str | None = None,
    coordinates: str | None = None,
    steps: ArrayLike | None = None,
) -> Sensitivity:
    """Run a method and the exact derivative of its final state with respect to the system's parameters.

    Parameters
    ----------
    system : LieGroupSystem
        The system (:func:`offered_parameters` lists what it offers: the mass tensor
        ``B``/``mass_tensor``, ``moments`` (3D, diagonal tensor), ``mass``, ``center_of_mass``,
        ``gravity``, ``radius``).
    y0 : dict of array_like
        The initial state (any batch of bodies), held fixed as given except the fields a
        parameter defines through the pose (see the module docstring).
    t_span : tuple of float
        ``(t0, t1)``.
    h : float, optional
        The fixed step (the grid of :func:`lieint.integrate`); or give ``steps``.
    method : str or Method, default "rkmk4"
        The method (those of :data:`lieint.tangent.flow.REFUSED` have no tangent map; the
        splittings rotate about the principal axes of B and take no derivative with respect
        to a mass tensor that is not diagonal).
    parameters : list of str, optional
        The parameters to differentiate by (default: every one the system offers).
    coordinates : {"exp", "cayley"}, optional
        The coordinate map of a Lie-group method.
    steps : array_like of float, optional
        Step sizes to take instead of ``h`` (an adaptive run's, held fixed).

    Returns
    -------
    Sensitivity
        The final state and ``∂y(T)/∂θ`` in the tangent coordinates of
        :func:`lieint.tangent.chart_of`.

    Raises
    ------
    ValueError, TypeError
        A bad argument, named: a parameter the system does not have (or refuses, with why), a
        method without a tangent map.

    Examples
    --------
    >>> import numpy as np, lieint
    >>> top = lieint.HeavyTop(np.diag([1.0, 1.5, 2.0]), 1.0, [0.0, 0.1, 0.2], [0.0, 0.0, -9.81])
    >>> y0 = top.initial_state(angular_velocity=[0.5, 0.2, 1.0])
    >>> s = lieint.sensitivity(top, y0, (0.0, 1.0), h=0.01, parameters=["mass", "center_of_mass"])
    >>> s.labels, s.jacobian.shape
    (['mass', 'center_of_mass[0]', 'center_of_mass[1]', 'center_of_mass[2]'], (9, 4))
    """
    if not isinstance(system, LieGroupSystem):
        raise TypeError(f"`system` must be a lieint system (LieGroupSystem); got {type(system).__name__}.")
    names = _chosen(system, parameters)
    real_stepper = TangentStepper(system, method, coordinates)  # refuses methods without a tangent map
    y = system.validate_state(y0)
    t0, t1, starts, sizes = step_schedule(t_span, h, steps)
    values, _ = offered_parameters(system)
    labels, columns, y1 = [], [], None
    scale = 1j * COMPLEX_STEP
    for name in names:
        for label, direction in _components(name, values[name]):
            target = name
            if name == "moments":  # I_k moves B along diag(½ − δ_ik)
                target, direction = _tensor_name(values), np.diag(0.5 - direction)
            moved, z0 = system.with_parameter_step(target, direction, scale, y)
            _refuse_axes(moved, real_stepper, label)
            stepper = TangentStepper(moved, real_stepper.method)
            z = {k: np.asarray(v, dtype=complex)[None] for k, v in z0.items()}
            z = run_steps(stepper, z, t0, starts, sizes)
            y1, vectors = stepper.split(z)
            labels.append(label)
            columns.append(vectors[0])
    jacobian = np.stack(columns, axis=-1)
    if not (np.all(np.isfinite(jacobian)) and all(np.all(np.isfinite(a)) for a in y1.values())):
        raise FloatingPointError(
            f"the run or its parameter derivatives became non-finite before t = {t1:g}; reduce the step or the horizon."
        )
    return Sensitivity(t1, y1, jacobian, labels, real_stepper.chart, len(sizes))


def _refuse_axes(moved: LieGroupSystem, stepper: TangentStepper, label: str) -> None:
    """Refuse a splitting on a complex mass tensor that is not diagonal (no analytic principal axes)."""
    inertia = getattr(moved, "inertia", None)
    if family_of(stepper.method) in _AXES_FAMILIES and inertia is not None and inertia.P is None:
        raise ValueError(
            f"`method` {stepper.method.name!r} rotates about the principal axes of the mass tensor, which a "
            f"non-diagonal tensor has only through an eigendecomposition (not analytic for the complex step), "
            f"so it has no derivative with respect to {label!r} here. Use an RKMK method or moser_veselov, or a "
            "diagonal mass tensor and its diagonal entries."
        )
