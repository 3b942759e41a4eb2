"""Systems by name: the built-in ones and those other packages install.

A package makes its system available to scenes, streamed runs and plots by declaring an entry
point in the group ``lieint.systems`` whose value is the system class (or any factory taking
keyword parameters), e.g. in its ``pyproject.toml``::

    [project.entry-points."lieint.systems"]
    pendulum = "mypackage.pendulum:Pendulum"

A scene then names it, with numeric parameters passed as keywords to the factory and the
``[initial]`` keys passed to ``system.initial_state``::

    [body]
    system = "pendulum"
    parameters = { length = 1.0, mass = 2.0 }

Scenes stay data: they name an installed system, never Python code to import. A system whose
input is a function takes it as samples: ``prescribed_rotation`` (:class:`~lieint.PrescribedRotation`)
takes ``rates`` (body rates ``(m, 3)``) and their ``times`` ``(m,)``::

    [body]
    system = "prescribed_rotation"
    parameters = { times = [0.0, 0.5, 1.0, 1.5, 2.0], rates = [[0.3, 1.0, 0.0], ...] }
"""

from __future__ import annotations

from collections.abc import Callable
from importlib import metadata

__all__ = ["ENTRY_POINT_GROUP", "make_system", "system_factories"]

#: the entry-point group other packages register their systems under
ENTRY_POINT_GROUP = "lieint.systems"


def _builtin() -> dict[str, Callable]:
    from .atoms import AtomsBody
    from .chaplygin import ChaplyginBall
    from .euler_top import EulerTop
    from .free_body import FreeBody
    from .heavy_top import HeavyTop
    from .particles import CentralForceParticle, constant_force_particle, surface_particle
    from .prescribed import PrescribedRotation
    from .rolling_ball import RollingBall

    return {
        "euler_top": EulerTop,
        "heavy_top": HeavyTop,
        "free_body": FreeBody,
        "rolling_ball": RollingBall,
        "chaplygin_ball": ChaplyginBall,
        "central_force_particle": CentralForceParticle,
        "constant_force_particle": constant_force_particle,
        "surface_particle": surface_particle,
        "atoms_body": AtomsBody,
        "motor_rigid_body": _motor_rigid_body,
        "prescribed_rotation": PrescribedRotation,
    }


def _motor_rigid_body(**parameters):
    """:class:`lieint.ga.MotorRigidBody` (clifford is imported only when one is built)."""
    from ..ga.motor import MotorRigidBody

    return MotorRigidBody(**parameters)


def system_factories() -> dict[str, Callable]:
    """name → factory of every system a scene can name (built-in first, then entry points)."""
    out = _builtin()
    for ep in metadata.entry_points(group=ENTRY_POINT_GROUP):
        out.setdefault(ep.name, ep)  # loaded on use; a built-in name cannot be taken over
    return out


def make_system(name: str, parameters: dict):
    """Build the system ``name`` from keyword ``parameters``; errors name what went wrong."""
    factories = system_factories()
    if name not in factories:
        raise ValueError(
            f"`system`: no system named {name!r}; known systems are {sorted(factories)} (packages add theirs "
            f"under the entry-point group {ENTRY_POINT_GROUP!r})."
        )
    factory = factories[name]
    if isinstance(factory, metadata.EntryPoint):
        try:
            factory = factory.load()
        except Exception as exc:  # a broken plugin must not look like a lieint bug
            raise ValueError(
                f"`system`: the installed system {name!r} ({factory.value}) failed to load: {exc}"
            ) from None
    try:
        return factory(**parameters)
    except TypeError as exc:
        raise ValueError(f"`parameters` of system {name!r}: {exc}") from None
