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

import functools
import sys
import warnings
from collections.abc import Callable
from importlib import metadata

__all__ = ["ENTRY_POINT_GROUP", "PluginWarning", "make_system", "system_factories"]

#: the entry-point group other packages register their systems under
ENTRY_POINT_GROUP = "lieint.systems"


class PluginWarning(UserWarning):
    """An installed system that is not used: its name is a built-in's or another plugin's."""


def _builtin() -> dict[str, Callable]:
    from .systems.atoms import AtomsBody
    from .systems.chaplygin import ChaplyginBall
    from .systems.euler_top import EulerTop
    from .systems.free_body import FreeBody
    from .systems.heavy_top import HeavyTop
    from .systems.particles import CentralForceParticle, constant_force_particle, surface_particle
    from .systems.prescribed import PrescribedRotation
    from .systems.rolling_ball import RollingBall

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
    from .ga.motor import MotorRigidBody

    return MotorRigidBody(**parameters)


def system_factories() -> dict[str, Callable]:
    """name → factory of every system a scene can name (built-in first, then entry points).

    A built-in name cannot be taken over; an installed system under such a name (or under the
    name of one installed before it) is ignored with a :class:`PluginWarning` naming it, so
    that a scene never runs another system than the one its author sees."""
    out = _builtin()
    for ep in _installed(tuple(sys.path)):
        if ep.name not in out:
            out[ep.name] = ep  # loaded on use
            continue
        kept = out[ep.name]
        which = f"the installed system {ep.name!r} ({ep.value}{_distribution(ep)})"
        if isinstance(kept, metadata.EntryPoint):
            why = f"another installed system of that name ({kept.value}{_distribution(kept)}) is used instead"
        else:
            why = "it has the name of a built-in system, which is used instead"
        warnings.warn(PluginWarning(f"{which} is ignored: {why}; rename its entry point"), stacklevel=2)
    return out


@functools.lru_cache(maxsize=8)
def _installed(path: tuple[str, ...]) -> tuple[metadata.EntryPoint, ...]:
    """The entry points of the group on this import path, found once: the scan reads every
    installed distribution's metadata (about 0.1 s), and a sweep or a scene builds a system per
    chunk. :func:`make_system` scans again before it reports an unknown name, so a plugin
    installed while the process runs is still found."""
    return tuple(metadata.entry_points(group=ENTRY_POINT_GROUP))


def _distribution(ep: metadata.EntryPoint) -> str:
    dist = getattr(ep, "dist", None)
    name = getattr(dist, "name", None) if dist is not None else None
    return f", from the package {name}" if name else ""


def _plugin_failure(exc: BaseException) -> str:
    """A plugin's exception in words (SystemExit and the like too: a plugin must not end lieint)."""
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def make_system(name: str, parameters: dict):
    """Build the system ``name`` from keyword ``parameters``; errors name what went wrong."""
    factories = system_factories()
    if name not in factories:
        _installed.cache_clear()  # installed since the last scan?
        factories = system_factories()
    if name not in factories:
        raise ValueError(
            f"`system`: no system named {name!r}; known systems are {sorted(factories)} (packages add theirs "
            f"under the entry-point group {ENTRY_POINT_GROUP!r})."
        )
    factory = factories[name]
    plugin = isinstance(factory, metadata.EntryPoint)
    if plugin:
        try:
            factory = factory.load()
        except KeyboardInterrupt:
            raise
        except BaseException as exc:  # a broken plugin (even one calling sys.exit) must not look like a lieint bug
            raise ValueError(
                f"`system`: the installed system {name!r} ({factory.value}) failed to load: {_plugin_failure(exc)}"
            ) from None
    try:
        return factory(**parameters)
    except TypeError as exc:
        raise ValueError(f"`parameters` of system {name!r}: {exc}") from None
    except (KeyboardInterrupt, ValueError):
        raise
    except BaseException as exc:
        if not plugin:
            raise
        raise ValueError(f"`system`: the installed system {name!r} failed to build: {_plugin_failure(exc)}") from None
