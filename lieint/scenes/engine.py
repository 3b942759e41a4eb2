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
  (``center``, ``contact_path``, ``velocity``, or the energy of a ball on an incline).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..integrate import integrate
from ..solution import Solution
from ..systems import ChaplyginBall, EulerTop, FreeBody, HeavyTop, RollingBall
from .schema import Scene, SceneError

__all__ = ["STATE_OUTPUTS", "SceneRun", "build_system", "run_scene"]

#: outputs read off the state, and the state field each needs
STATE_OUTPUTS = {
    "orientation": "R",
    "angular_momentum": "A",
    "angular_velocity": None,
    "gamma": "Gamma",
    "center": "center",
    "contact_path": "center",
    "velocity": "velocity",
}
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
    wants = set(scene.outputs)
    need_R = bool(wants & _NEEDS_R)
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
    except (TypeError, ValueError) as exc:
        raise SceneError(f"{scene.source or '<scene>'}: {exc}") from None
    _check_outputs(scene, system)
    return system, y0


def _top_state(system, ini):
    return system.initial_state(
        R=ini.get("orientation"),
        Omega=ini.get("omega"),
        A=ini.get("momentum"),
        angular_velocity=ini.get("angular_velocity"),
    )


def _available(system) -> set[str]:
    names = set(system.invariant_functions)
    for name, field in STATE_OUTPUTS.items():
        if field is None or field in system.fields or (name == "orientation" and "R" in system.fields):
            names.add(name)
    if "center" not in system.fields and not isinstance(system, FreeBody):
        names -= {"center", "contact_path"}
    if not isinstance(system, (RollingBall, ChaplyginBall)):
        names.discard("contact_path")
    return names


def _check_outputs(scene: Scene, system) -> None:
    valid = _available(system) | _NEEDS_R | _NEEDS_CENTER
    if isinstance(system, (EulerTop, HeavyTop)):
        valid -= {"center", "contact_path"}
    unknown = [q for q in scene.outputs if q not in valid]
    if unknown:
        raise SceneError(
            f"{scene.source or '<scene>'}: [output] quantities: {unknown[0]!r} is not an output of this scene's "
            f"system ({type(system).__name__}); choose from {sorted(valid)}"
        )


def run_scene(scene: Scene) -> SceneRun:
    """Build and integrate the scene; return the solution and its requested outputs."""
    system, y0 = build_system(scene)
    sol = integrate(
        system,
        y0,
        (scene.t_start, scene.t_end),
        h=scene.step,
        method=scene.method,
        coordinates=scene.coordinates if _is_lie(scene.method) else None,
        project=scene.project,
        save_every=scene.save_every,
    )
    return SceneRun(scene, system, sol, collect_outputs(system, sol, scene.outputs))


def _is_lie(method: str) -> bool:
    from ..methods.registry import get_method

    return get_method(method).kind == "lie"


def collect_outputs(system, sol: Solution, names) -> dict[str, np.ndarray]:
    """Requested outputs as arrays over the saved times."""
    out = {}
    for name in names:
        if name in sol.invariants:
            out[name] = sol.invariants[name]
        elif name == "orientation":
            out[name] = sol.states["R"]
        elif name == "contact_path":
            out[name] = system.contact_point(sol.states["center"])
        elif name == "angular_velocity":
            out[name] = _angular_velocity(system, sol.states)
        else:
            out[name] = sol.states[STATE_OUTPUTS[name]]
    return out


def _angular_velocity(system, states):
    if "Omega" in states:
        return states["Omega"]
    if isinstance(system, ChaplyginBall):
        return system.angular_velocity(states["A"], states["Gamma"])
    top = system.top if isinstance(system, (HeavyTop, FreeBody)) else system
    return top.angular_velocity(states["A"])
