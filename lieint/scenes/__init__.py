"""Scenes: declare body, support, forces, initial state, integrator and outputs as data."""

from importlib import resources

from .engine import SceneRun, build_system, collect_outputs, run_scene, scene_solver_options
from .expressions import ExpressionError, evaluate
from .schema import SUPPORTS, Scene, SceneError, load_scene, parse_scene

__all__ = [
    "SUPPORTS",
    "ExpressionError",
    "Scene",
    "SceneError",
    "SceneRun",
    "build_system",
    "collect_outputs",
    "embedded_scene",
    "embedded_scenes",
    "evaluate",
    "load_scene",
    "parse_scene",
    "run_scene",
    "scene_solver_options",
]


def embedded_scenes() -> dict[str, Scene]:
    """The example scenes shipped with lieint, by file stem."""
    folder = resources.files(__package__) / "examples"
    out = {}
    for entry in sorted(folder.iterdir(), key=lambda p: p.name):
        if entry.name.endswith(".toml"):
            out[entry.name[:-5]] = parse_scene(entry.read_text(encoding="utf-8"), source=f"lieint:{entry.name}")
    return out


def embedded_scene(name: str) -> Scene:
    """One embedded scene by name (see :func:`embedded_scenes`)."""
    scenes = embedded_scenes()
    if name not in scenes:
        raise SceneError(f"no embedded scene {name!r}; the embedded scenes are {sorted(scenes)}")
    return scenes[name]
