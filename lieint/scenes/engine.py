"""Assemble exactly the system a scene calls for, run it, and collect its outputs.

Only the effects the scene declares are simulated:

* support ``fixed_point``: an offset centre of mass under gravity is a :class:`HeavyTop`;
  otherwise gravity exerts no torque and the body is an :class:`EulerTop` (no gravity term);
* support ``rolling``: a ball with its centre of mass at the centre and gravity along the
  normal (or none) is a :class:`ChaplyginBall` (the isospectral specialisation), any other
  a :class:`RollingBall`;
* support ``free``: a :class:`FreeBody`;
* R is integrated only if an output needs it (``orientation``, ``momentum``,
  ``orthogonality``, or the centre of a ball), the centre only if an output needs it
  (``center``, ``contact_path``, ``velocity``, or the energy of a ball on an incline);
* a body given as ``system = "name"`` is built by that system's factory
  (:mod:`lieint.catalog`), from the scene's parameters;
* ``[body] orientation = "rotor"`` gives the rotor form of the system
  (:class:`lieint.ga.RotorForm`: R carried as a rotor of Spin(n)).

The requested outputs are read through what the system declares (its ``outputs`` and
``invariants``), so any system -- a built-in one or one another package installs -- runs,
streams and plots the same way.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np

from ..catalog import make_system
from ..ivp import integrate
from ..solution import Solution
from ..systems import ChaplyginBall, EulerTop, FreeBody, HeavyTop, RollingBall
from .schema import Scene, SceneError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = [
    "SceneRun",
    "build_system",
    "collect_outputs",
    "run_scene",
    "scene_events",
    "scene_key_error",
    "scene_solver_options",
]

_NEEDS_R = {"orientation", "momentum", "orthogonality"}
_NEEDS_CENTER = {"center", "contact_path"}


@dataclass
class SceneRun:
    """A scene's run: the system built, the solution, and the requested outputs by name."""

    scene: Scene
    system: object
    solution: Solution
    outputs: dict[str, np.ndarray]


def build_system(scene: Scene):
    """The system and initial state the scene calls for (nothing more is simulated)."""
    if scene.system is not None:
        return _named_system(scene)
    wants = set(scene.outputs)
    # an initial orientation given is integrated (and checked to be a rotation), never dropped
    need_R = bool(wants & _NEEDS_R) or scene.orientation == "rotor" or "orientation" in scene.initial
    g = scene.gravity
    XG = scene.center_of_mass
    offset = XG is not None and bool(np.any(XG != 0))
    ini = dict(scene.initial)
    if scene.ensemble is not None:  # the members replace the single initial velocity: one batch
        ini[scene.ensemble["key"]] = scene.ensemble["members"]
    try:
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported below, by key
            system, y0 = _assemble(scene, wants, need_R, g, XG, offset, ini)
        y0 = system.validate_state(y0, "initial state")
        system, y0 = _orientation_form(scene, system, y0)
    except (TypeError, ValueError) as exc:
        raise scene_key_error(scene, exc) from None
    _check_outputs(scene, system)
    return system, y0


def _assemble(scene: Scene, wants, need_R, g, XG, offset, ini):
    """The system of the scene's support and forces, and its initial state."""
    if scene.support == "fixed_point":
        if g is not None and offset:
            system = HeavyTop(scene.mass_tensor, scene.mass, XG, g, orientation=need_R)
        else:
            system = EulerTop(scene.mass_tensor, orientation=need_R)
        y0 = _top_state(system, ini)
    elif scene.support == "rolling":
        nu = scene.normal if scene.normal is not None else np.eye(scene.dimension)[-1]
        nu = nu / np.linalg.norm(nu) if np.linalg.norm(nu) > 0 else nu
        along_normal = g is None or np.linalg.norm(g - (g @ nu) * nu) <= 1e-14 * np.linalg.norm(g)
        if not offset and along_normal:
            system = ChaplyginBall(
                scene.mass_tensor,
                scene.mass,
                scene.radius,
                scene.normal,
                orientation=need_R,
                track_center=bool(wants & _NEEDS_CENTER),
            )
        else:
            center = bool(wants & _NEEDS_CENTER) or ("energy" in wants and not along_normal)
            system = RollingBall(
                scene.mass_tensor,
                scene.mass,
                scene.radius,
                XG,
                g,
                scene.normal,
                orientation=need_R,
                track_center=center,
            )
        y0 = system.initial_state(
            R=ini.get("orientation"),
            Omega=ini.get("omega"),
            angular_velocity=ini.get("angular_velocity"),
            center=ini.get("center"),
            velocity=ini.get("velocity"),
        )
    else:
        system = FreeBody(scene.mass_tensor, scene.mass, g, orientation=need_R)
        y0 = system.initial_state(
            R=ini.get("orientation"),
            Omega=ini.get("omega"),
            A=ini.get("momentum"),
            angular_velocity=ini.get("angular_velocity"),
            center=ini.get("center"),
            velocity=ini.get("velocity"),
        )
    return system, y0


#: the names the systems give their arguments, and the scene keys they come from: a message
#: about ``B`` or ``y0['A']`` is about ``[body] mass_tensor`` or ``[initial] angular_velocity``
_ARGUMENTS = (
    (("B", "mass_tensor"), "body", ("mass_tensor", "principal_moments", "uniform")),
    (("mass", "M"), "body", ("mass",)),
    (("radius", "r"), "body", ("radius",)),
    (("center_of_mass", "X_G", "XG"), "body", ("center_of_mass",)),
    (("g", "gravity"), "forces", ("gravity",)),
    (("normal", "nu"), "support", ("normal",)),
    (("Omega", "angular_velocity", "A"), "initial", ("angular_velocity", "omega", "momentum")),
    (("R", "orientation"), "initial", ("orientation",)),
    (("center",), "initial", ("center",)),
    (("velocity", "v"), "initial", ("velocity",)),
)


def scene_key_error(scene: Scene, exc: Exception) -> SceneError:
    """A system's refusal of the values a scene gave it, as an error naming the scene key and
    its line: ``[body] mass_tensor (line 5): must be symmetric …`` instead of ```B` must be …``."""
    import re

    from .reader import TableReader
    from .schema import TABLES

    text = str(exc)
    source = scene.source or "<scene>"
    found = re.match(r"^`(?:y0|initial state)\['(\w+)'\]`|^`(\w+)`", text)
    if found is None:
        return SceneError(f"{source}: {text}")
    name = found.group(1) or found.group(2)
    match = next(((table, keys) for names, table, keys in _ARGUMENTS if name in names), None)
    if match is None:
        return SceneError(f"{source}: {text}")
    table, keys = match
    given = [k for k in keys if k in (scene.initial if table == "initial" else _table_keys(scene, table))]
    key = given[0] if given else keys[0]
    rest = text[found.end() :].lstrip()
    if found.group(1):  # a field of the initial state: say which quantity it is
        if rest.startswith("must be finite"):
            rest = f"gives an initial {found.group(1)} beyond the floating-point range{rest[len('must be finite') :]}"
        else:
            rest = f"gives an initial {found.group(1)} that {rest}"
    if table == "initial" and scene.ensemble is not None and key == scene.ensemble["key"]:
        rest += " (for one of the members of [ensemble])"
    line = None
    if scene.text is not None:
        try:
            data = tomllib.loads(scene.text)
        except (tomllib.TOMLDecodeError, RecursionError):  # pragma: no cover - it was parsed once
            data = {}
        line = TableReader(data, scene.text, source, TABLES).line_of(table, key)
    at = f" (line {line})" if line else ""
    return SceneError(f"{source}: [{table}] {key}{at}: {rest}")


def _table_keys(scene: Scene, table: str) -> set[str]:
    """The keys a scene gave in ``table`` (from its text; else those its fields show)."""
    if scene.text is not None:
        try:
            return set(tomllib.loads(scene.text).get(table, {}))
        except (tomllib.TOMLDecodeError, RecursionError, AttributeError):  # pragma: no cover
            return set()
    present = {
        "body": {"mass_tensor": scene.mass_tensor, "mass": scene.mass, "radius": scene.radius,
                 "center_of_mass": scene.center_of_mass},
        "forces": {"gravity": scene.gravity},
        "support": {"normal": scene.normal},
    }.get(table, {})  # fmt: skip
    return {k for k, v in present.items() if v is not None}


def _orientation_form(scene: Scene, system, y0):
    """The rotor form of the system when the scene asks for ``orientation = "rotor"``."""
    if scene.orientation != "rotor":
        return system, y0
    from ..ga.spin import RotorForm  # clifford only for scenes that ask for rotors

    rotor = RotorForm(system)
    return rotor, rotor.from_matrix_state(y0)


def _top_state(system, ini):
    return system.initial_state(
        R=ini.get("orientation"),
        Omega=ini.get("omega"),
        A=ini.get("momentum"),
        angular_velocity=ini.get("angular_velocity"),
    )


def _named_system(scene: Scene):
    try:
        system = make_system(scene.system, scene.parameters)
        if not hasattr(system, "initial_state"):
            raise ValueError(f"the system {scene.system!r} has no `initial_state` to build its state from [initial]")
        _check_initial_keys(scene, system)
        y0 = system.initial_state(**scene.initial)
        y0 = system.validate_state(y0, "initial state")
        system, y0 = _orientation_form(scene, system, y0)
    except (TypeError, ValueError) as exc:
        raise SceneError(f"{scene.source or '<scene>'}: {exc}") from None
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # the system's own code (an installed package's) must not end lieint
        raise SceneError(
            f"{scene.source or '<scene>'}: [body] system {scene.system!r}: building its initial state failed: "
            f"{type(exc).__name__}: {exc}"
        ) from None
    _check_outputs(scene, system)
    return system, y0


def _check_initial_keys(scene: Scene, system) -> None:
    """[initial] keys must be parameters of the system's ``initial_state``."""
    import inspect

    try:
        params = inspect.signature(system.initial_state).parameters
    except (TypeError, ValueError):  # a builtin or C callable: let the call report
        return
    if any(p.kind is p.VAR_KEYWORD for p in params.values()):
        return
    takes = [n for n, p in params.items() if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)]
    unknown = sorted(set(scene.initial) - set(takes))
    if unknown:
        raise ValueError(
            f"[initial] {unknown[0]}: not a parameter of {type(system).__name__}.initial_state, which takes {takes}"
        )


def _check_outputs(scene: Scene, system) -> None:
    valid = set(system.outputs) | set(system.invariants)
    unknown = [q for q in scene.outputs if q not in valid]
    if unknown:
        raise SceneError(
            f"{scene.source or '<scene>'}: [output] quantities: {unknown[0]!r} is not an output of this scene's "
            f"system ({type(system).__name__}); choose from {sorted(valid)}"
        )


def scene_solver_options(scene: Scene) -> dict:
    """The keyword arguments of :func:`lieint.integrate` a scene's [integrator] sets."""
    return {
        "h": scene.step,
        "method": scene.method,
        "coordinates": scene.coordinates,
        "project": scene.project,
        "save_every": scene.save_every,
        "rtol": scene.rtol,
        "atol": scene.atol,
        "backend": scene.backend,
    }


def run_scene(scene: Scene) -> SceneRun:
    """Build and integrate the scene; return the solution and its requested outputs.

    A step an ensemble cannot take (:class:`~lieint.groups.base.DexpinvRangeError`) is raised
    naming the member whose initial step is the largest (:func:`fastest_member`)."""
    from ..groups.base import DexpinvRangeError

    system, y0 = build_system(scene)
    events = scene_events(system, y0, scene) or None
    try:
        sol = integrate(system, y0, (scene.t_start, scene.t_end), **scene_solver_options(scene), events=events)
    except DexpinvRangeError as exc:
        which = fastest_member(system, y0, scene.t_start, scene.step)
        if which is None:
            raise
        raise DexpinvRangeError(f"{exc} {member_phrase(scene, *which)}") from None
    return SceneRun(scene, system, sol, collect_outputs(system, sol, scene.outputs))


def fastest_member(system, y0: dict, t: float, h: float) -> tuple[int, float] | None:
    """``(index, radius)`` of the member of a batched state whose first step ``h ξ(t, y)``
    has the largest ad spectral radius (the one that refuses a batch its step), or None for a
    state without a batch axis."""
    if not system.batch_shape(y0):
        return None
    with np.errstate(all="ignore"):
        xi = system.group.lincomb([h], [system.generator(t, y0)])
        rho = np.asarray(system.group.ad_spectral_radius(xi), dtype=float).reshape(-1)
    rho = np.where(np.isnan(rho), np.inf, rho)
    index = int(np.argmax(rho))
    return index, float(rho[index])


def nonfinite_members(sol: Solution) -> list[int]:
    """The members of a batched solution whose last saved state is not finite."""
    if not sol.batch_shape or sol.t.size == 0:
        return []
    bad = np.zeros(int(np.prod(sol.batch_shape)), dtype=bool)
    for values in sol.states.values():
        last = np.asarray(values[-1]).reshape(bad.size, -1)
        bad |= ~np.all(np.isfinite(last), axis=1)
    return np.flatnonzero(bad).tolist()


def member_phrase(scene: Scene, index: int, radius: float) -> str:
    """Which member of the scene's ensemble refuses the step, in words."""
    where = ""
    if scene.ensemble is not None:
        key = scene.ensemble["key"]
        value = np.array2string(
            np.asarray(scene.ensemble["members"][index]), separator=", ", formatter={"float_kind": lambda v: f"{v:.4g}"}
        )
        where = f", [initial] {key} = {' '.join(value.split())}"
    return (
        f"The member that refuses it is member {index} of the ensemble (0-based{where}): its first step has "
        f"‖h ξ‖ = {radius:.3g}."
    )


def collect_outputs(system, sol: Solution, names) -> dict[str, np.ndarray]:
    """Requested outputs (declared outputs or invariants of the system) over the saved times."""
    return sol.outputs(names)


def scene_events(system, y0: dict, scene: Scene) -> list:
    """The scene's ``[[events]]`` as event functions ``g(t, y) = output(t, y)[component] − value``
    with their ``terminal`` and ``direction`` (:mod:`lieint.events`); checked on ``y0``."""
    events = []
    for ev in scene.events:
        name, component = ev["output"], ev["component"]
        if name not in system.outputs and name not in system.invariants:
            raise SceneError(
                f"{scene.source or '<scene>'}: [[events]] output {name!r} is not an output of "
                f"{type(system).__name__}; choose from {sorted({*system.outputs, *system.invariants})}"
            )

        def g(t, y, name=name, component=component, value=ev["value"]):
            return float(np.asarray(system.evaluate_outputs(t, y, [name])[name])[component]) - value

        try:
            g(scene.t_start, y0)
        except (IndexError, TypeError, ValueError):
            shape = np.shape(system.evaluate_outputs(scene.t_start, y0, [name])[name])
            raise SceneError(
                f"{scene.source or '<scene>'}: [[events]] {ev['name']!r}: component {list(component)} must pick one "
                f"number of {name!r} (shape {shape}; events need a single body, not an ensemble)"
            ) from None
        g.__name__ = ev["name"]
        g.terminal = ev["terminal"]
        g.direction = ev["direction"]
        events.append(g)
    return events
