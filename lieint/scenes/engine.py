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
  (:mod:`lieint.systems.catalog`), from the scene's parameters;
* ``[body] orientation = "rotor"`` gives the rotor form of the system
  (:class:`lieint.ga.RotorForm`: R carried as a rotor of Spin(n)).

The requested outputs are read through what the system declares (its ``outputs`` and
``invariants``), so any system -- a built-in one or one another package installs -- runs,
streams and plots the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..ivp import integrate
from ..solution import Solution
from ..systems import ChaplyginBall, EulerTop, FreeBody, HeavyTop, RollingBall
from ..systems.catalog import make_system
from .schema import Scene, SceneError

__all__ = ["SceneRun", "build_system", "collect_outputs", "run_scene", "scene_events", "scene_solver_options"]

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
    need_R = bool(wants & _NEEDS_R) or scene.orientation == "rotor"
    g = scene.gravity
    XG = scene.center_of_mass
    offset = XG is not None and bool(np.any(XG != 0))
    ini = dict(scene.initial)
    if scene.ensemble is not None:  # the members replace the single initial velocity: one batch
        ini[scene.ensemble["key"]] = scene.ensemble["members"]
    try:
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
        system, y0 = _orientation_form(scene, system, y0)
    except (TypeError, ValueError) as exc:
        raise SceneError(f"{scene.source or '<scene>'}: {exc}") from None
    _check_outputs(scene, system)
    return system, y0


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
    }


def run_scene(scene: Scene) -> SceneRun:
    """Build and integrate the scene; return the solution and its requested outputs."""
    system, y0 = build_system(scene)
    events = scene_events(system, y0, scene) or None
    sol = integrate(system, y0, (scene.t_start, scene.t_end), **scene_solver_options(scene), events=events)
    return SceneRun(scene, system, sol, collect_outputs(system, sol, scene.outputs))


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
