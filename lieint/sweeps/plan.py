"""A sweep's plan: which members there are, how each is built, and how they are cut into chunks.

The members are the product of the varied values (keys in the order given, the last varying
fastest) and the ensemble: member ``m`` is parameter point ``p = m // E`` and ensemble member
``e = m % E``, with ``E`` the ensemble size (1 without an ensemble). Chunks are consecutive
ranges of ``chunk`` members. The plan is plain data (the scene's TOML data, the keys and values,
the ensemble's count, seed and spread), so any worker rebuilds exactly the same systems and
initial states from it, and a fingerprint of it tells a resumed store that it holds this sweep.

A plan may also ask for chaos indicators per member (:mod:`lieint.sweeps.indicators`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from ..limits import check
from .indicators import check_indicators
from .keys import SceneKey, SweepError, SweepKeyError, parse_key, parse_vary

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["SweepError", "SweepPlan", "parse_vary", "plan_from_scene", "plan_from_systems"]

#: the default chunk gives about this many chunks (whatever the number of workers, so that the
#: result does not depend on where it ran)
DEFAULT_CHUNKS = 32


@dataclass(frozen=True)
class Variation:
    """One varied key and its values."""

    key: SceneKey
    values: np.ndarray


@dataclass
class SweepPlan:
    """Members, how to build them, and their chunks (see the module docstring).

    Build one with :func:`plan_from_scene` or :func:`plan_from_systems`.

    Attributes
    ----------
    source : {"scene", "systems"}
    variations : list of Variation
        The varied keys and their values (scenes); ``[]`` for systems.
    ensemble : int
        Members per parameter point (E).
    chunk : int
        Members per chunk.
    t_span : (float, float)
    options : dict
        Keyword arguments of :func:`lieint.integrate` (``h``, ``method``, ``project``, …).
    """

    source: str
    variations: list[Variation]
    ensemble: int
    chunk: int
    t_span: tuple[float, float]
    options: dict
    scene_data: dict | None = None
    scene_source: str = "<scene>"
    ensemble_spec: dict | None = None
    ensemble_members: dict | None = None
    systems: list | None = None
    states: dict | None = None
    outputs: tuple[str, ...] = ()
    #: chaos indicators per member (:data:`lieint.sweeps.indicators.INDICATORS`) and their initial tangent vector
    indicators: tuple[str, ...] = ()
    indicator_vector: tuple[float, ...] | None = None
    coords: dict[str, np.ndarray] = field(default_factory=dict)
    description: str = ""
    #: bytes the store holds per member and save time (state fields, outputs), and save times
    row_bytes: int = 0
    largest_row_bytes: int = 0
    nsaves: int = 0

    # -- sizes ---------------------------------------------------------------------------
    @property
    def npoints(self) -> int:
        """Number of parameter points (product of the numbers of varied values)."""
        if self.source == "systems":
            return len(self.systems)
        return math.prod(len(v.values) for v in self.variations)

    @property
    def nmembers(self) -> int:
        """Number of members (points × ensemble)."""
        return self.npoints * self.ensemble

    @property
    def nchunks(self) -> int:
        """Number of chunks."""
        return -(-self.nmembers // self.chunk)

    @property
    def store_bytes(self) -> int:
        """Bytes of the store's member arrays, uncompressed (an upper bound of what it takes:
        Zstandard compresses trajectories little), plus the drifts and per-chunk metadata."""
        per_member = 8 * (len(self.outputs) + len(self.indicators) + 4)
        return self.nmembers * (self.nsaves * self.row_bytes + per_member) + self.nchunks * 4096

    @property
    def chunk_file_bytes(self) -> int:
        """Bytes of the largest file of the store, uncompressed: one chunk of all its members'
        save times of the state field or output with the most numbers per save time."""
        return self.chunk * self.nsaves * self.largest_row_bytes

    def chunk_range(self, c: int) -> tuple[int, int]:
        """Members ``[start, stop)`` of chunk ``c``."""
        if not 0 <= c < self.nchunks:
            raise IndexError(f"chunk {c} out of range (the plan has {self.nchunks} chunks)")
        return c * self.chunk, min((c + 1) * self.chunk, self.nmembers)

    def point_values(self, p: int) -> tuple[float, ...]:
        """The varied values at parameter point ``p`` (keys in order, the last fastest)."""
        idx = np.unravel_index(p, [len(v.values) for v in self.variations]) if self.variations else ()
        return tuple(float(v.values[i]) for v, i in zip(self.variations, idx, strict=True))

    # -- building members --------------------------------------------------------------
    def point_scene_data(self, p: int) -> dict:
        """The scene data at parameter point ``p`` (the varied values and the ensemble set)."""
        data = self.scene_data
        for v, value in zip(self.variations, self.point_values(p), strict=True):
            data = v.key.set(data, value)
        if self.ensemble_spec is not None or self.ensemble_members is not None:
            data = dict(data)
            data.pop("ensemble", None)
            if self.ensemble_spec is not None:
                data["ensemble"] = dict(self.ensemble_spec)
        return data

    def build_point(self, p: int):
        """``(system, y0)`` of parameter point ``p``; y0 has one batch axis of length E."""
        if self.source == "systems":
            return self.systems[p], self.states
        from ..scenes import SceneError, build_system, parse_scene

        try:
            scene = parse_scene(self.point_scene_data(p), source=self.scene_source)
            if self.ensemble_members is not None:
                # the members the scene read from its file travel with the plan: a remote worker
                # has no access to that file
                scene = dataclasses.replace(scene, ensemble=self.ensemble_members)
            system, y0 = build_system(scene)
        except SceneError as exc:
            values = ", ".join(
                f"{v.key.text} = {x:g}" for v, x in zip(self.variations, self.point_values(p), strict=True)
            )
            raise SweepError(f"the scene at {values or 'the base point'} is invalid: {exc}") from None
        if system.batch_shape(y0) == ():
            y0 = {k: v[None] for k, v in y0.items()}
        return system, y0

    @cached_property
    def fingerprint(self) -> str:
        """SHA-256 of everything that determines the results (the store checks it on resume)."""
        from .._version import __version__

        h = hashlib.sha256()
        spec = {
            "source": self.source,
            "keys": [v.key.text for v in self.variations],
            "ensemble": self.ensemble,
            "ensemble_spec": self.ensemble_spec,
            "chunk": self.chunk,
            "t_span": list(self.t_span),
            "options": {k: repr(v) for k, v in sorted(self.options.items())},
            "outputs": list(self.outputs),
            "version": __version__,
        }
        if self.indicators:  # only then: the fingerprints of sweeps without indicators stay as they were
            spec["indicators"] = list(self.indicators)
            spec["indicator_vector"] = [float(x).hex() for x in self.indicator_vector]
        h.update(json.dumps(spec, sort_keys=True, default=str).encode())
        for v in self.variations:
            h.update(np.ascontiguousarray(v.values, dtype=float).tobytes())
        if self.source == "scene":
            h.update(json.dumps(self.scene_data, sort_keys=True, default=str).encode())
            if self.ensemble_members is not None:
                h.update(np.ascontiguousarray(self.ensemble_members["members"]).tobytes())
        else:
            for system in self.systems:
                h.update(repr(system).encode())
                for name in sorted(getattr(system, "__dict__", {})):
                    value = system.__dict__[name]
                    if isinstance(value, np.ndarray):
                        h.update(name.encode() + np.ascontiguousarray(value).tobytes())
            for name in sorted(self.states):
                h.update(name.encode() + np.ascontiguousarray(self.states[name]).tobytes())
        return h.hexdigest()

    def describe(self) -> dict[str, Any]:
        """Plain data describing the plan (stored in the sweep's attributes)."""
        return {
            "source": self.source,
            "keys": [v.key.text for v in self.variations],
            "values": {v.key.text: v.values.tolist() for v in self.variations},
            "ensemble": self.ensemble,
            "ensemble_spec": self.ensemble_spec,
            "chunk": self.chunk,
            "nmembers": self.nmembers,
            "nchunks": self.nchunks,
            "t_span": list(self.t_span),
            "options": {
                k: v if isinstance(v, (int, float, str, bool, type(None))) else repr(v) for k, v in self.options.items()
            },
        } | (
            {"indicators": list(self.indicators), "indicator_vector": list(self.indicator_vector)}
            if self.indicators
            else {}
        )


def _check_method(options: dict) -> None:
    from ..methods.registry import get_method

    method = options.get("method", "rkmk4")
    stepper = get_method(method, coordinates=options.get("coordinates"))
    if stepper.adaptive or stepper.self_controlled:
        kind = "adaptive" if stepper.adaptive else "self-controlled (scipy)"
        raise SweepError(
            f"a sweep runs fixed-step methods: every member shares one time grid and a chunk's members run as one "
            f"batch, whose step a controller would couple; {stepper.name!r} is {kind}. Use a fixed-step method "
            "(e.g. 'rkmk4', 'rkmk6', 'rk4') with a step `h`"
        )
    if options.get("h") is None:
        raise SweepError(f"a sweep needs the step `h` of the fixed-step method {stepper.name!r}")


def _default_chunk(npoints: int, ensemble: int) -> int:
    return ensemble * max(1, -(-npoints // DEFAULT_CHUNKS))


def _check_chunk(chunk, default: int, nmembers: int) -> int:
    """The members per chunk: ``chunk`` (or the default), never more than the sweep's members
    (a larger chunk is the same single chunk; its Zarr chunk shape must not claim more)."""
    if chunk is None:
        return min(default, nmembers)
    if isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 1:
        raise SweepError(f"`chunk` must be a positive integer (members per chunk); got {chunk!r}")
    return min(int(chunk), nmembers)


# -- sizes, checked before anything is allocated (lieint.limits) ---------------------------------


def _check_points_count(counts: list[int], keys: list[str]) -> None:
    """The product of the numbers of values, computed on integers before any grid exists."""
    points = math.prod(counts)
    if len(counts) > 1:
        check(
            "LIEINT_MAX_SWEEP_POINTS",
            points,
            lambda: (
                "the number of parameter points (the product of the values of "
                + " × ".join(f"{k} ({n})" for k, n in zip(keys, counts, strict=True))
                + ")"
            ),
            "or vary fewer keys or fewer values (--vary KEY=START:STOP:NUM)",
        )


def _check_members(npoints: int, ensemble: int) -> None:
    check(
        "LIEINT_MAX_SWEEP_MEMBERS",
        npoints * ensemble,
        f"the number of members (parameter points {npoints} × --ensemble {ensemble})",
        "or fewer points or a smaller --ensemble",
    )


def _check_chunk_sizes(plan: SweepPlan, point) -> None:
    """Chunks in the store and the memory of one chunk (its member arrays on a worker and on
    the client) against the limits; sets ``plan.row_bytes`` and ``plan.nsaves``."""
    from ..control import Plan

    check(
        "LIEINT_MAX_SWEEP_CHUNKS",
        plan.nchunks,
        f"the number of chunks ({plan.nmembers} members in chunks of --chunk {plan.chunk})",
        "or a larger --chunk (members per chunk); every chunk is a few files of the store",
    )
    system, y0 = point
    steps = Plan.make(float(plan.t_span[0]), float(plan.t_span[1]), float(plan.options["h"])).nsteps
    every = int(plan.options.get("save_every", 1))
    plan.nsaves = steps // every + 1 + (1 if steps % every else 0)
    one = {k: np.asarray(v)[:1] for k, v in y0.items()}
    sizes = [8 * math.prod(shape) for shape in system.fields.values()]
    if plan.outputs:
        values = system.evaluate_outputs(np.zeros(1) + plan.t_span[0], one, list(plan.outputs))
        sizes += [8 * np.asarray(v).size for v in values.values()]
    plan.row_bytes, plan.largest_row_bytes = int(sum(sizes)), int(max(sizes))
    # a chunk's arrays exist twice on a worker (the solution and the member-major copy)
    check(
        "LIEINT_MAX_MEMORY",
        2 * plan.chunk * plan.nsaves * plan.row_bytes,
        lambda: (
            f"the memory of one chunk ({plan.chunk} members × {plan.nsaves} save times × {plan.row_bytes} bytes, "
            "twice) (bytes)"
        ),
        "or a smaller --chunk (members per chunk), or a larger save_every",
    )


def scene_data_of(scene) -> tuple[dict, str]:
    """The TOML data of a scene given as a path, an embedded name, TOML text, a dict or a Scene."""
    from ..scenes import Scene, SceneError, embedded_scenes

    if isinstance(scene, dict):
        return scene, "<scene>"
    if isinstance(scene, Scene):
        if scene.text is None:
            raise SweepError(
                "a sweep varies keys of the scene's TOML data, and this Scene was built without it; give the "
                "scene as a path, an embedded scene's name, TOML text or a dict"
            )
        return tomllib.loads(scene.text), scene.source or "<scene>"
    text_like = isinstance(scene, str) and ("\n" in scene or "[" in scene)
    if isinstance(scene, Path) or (
        isinstance(scene, str) and not text_like and (scene.endswith(".toml") or Path(scene).exists())
    ):
        path = Path(scene)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise SceneError(f"cannot read scene file {str(path)!r}: {exc.strerror or exc}") from None
        try:
            return tomllib.loads(text), str(path)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(f"{path}: not valid TOML: {exc}") from None
    if isinstance(scene, str):
        known = embedded_scenes()
        if scene in known:
            return tomllib.loads(known[scene].text), known[scene].source
        if text_like:
            try:
                return tomllib.loads(scene), "<scene>"
            except tomllib.TOMLDecodeError as exc:
                raise SceneError(f"<scene>: not valid TOML: {exc}") from None
        raise SceneError(f"no scene file {scene!r} and no embedded scene of that name (embedded: {sorted(known)})")
    raise TypeError(
        f"`scene` must be a path, an embedded scene's name, TOML text, a dict or a Scene; got {type(scene).__name__}."
    )


def plan_from_scene(
    scene,
    vary: Sequence | dict | None = None,
    *,
    ensemble: int | None = None,
    seed: int = 0,
    spread: float | None = None,
    chunk: int | None = None,
    indicators: Sequence[str] | None = None,
    indicator_vector=None,
) -> SweepPlan:
    """Plan a sweep of a scene: the product of the varied values, times an ensemble.

    Parameters
    ----------
    scene : path, str, dict or Scene
        A TOML file, an embedded scene's name, TOML text, the equivalent dict, or a Scene
        loaded from TOML.
    vary : dict or sequence, optional
        ``{key: values}`` or ``["KEY=START:STOP:NUM", ...]`` (see :func:`parse_vary`).
    ensemble, seed, spread : optional
        A seeded Gaussian ensemble of ``ensemble`` initial states at every point (the scene's
        ``[ensemble]`` rule: ``spread`` perturbs the initial angular velocity or Ω; default spread:
        the scene's own, else required). Without ``ensemble`` the scene's own ``[ensemble]`` applies.
    chunk : int, optional
        Members per chunk (default: a multiple of the ensemble size giving about 32 chunks).
    indicators : sequence of str, optional
        Chaos indicators to store per member (:mod:`lieint.sweeps.indicators`).
    indicator_vector : array_like, optional
        Their initial tangent vector, the same for every member.
    """
    from ..scenes import SceneError, parse_scene

    data, source = scene_data_of(scene)
    try:
        base = parse_scene(data, source=source)
    except SceneError as exc:
        raise SweepError(str(exc)) from None
    items = list(vary.items()) if isinstance(vary, dict) else [parse_vary(v) for v in (vary or [])]
    variations = []
    for text, values in items:
        try:
            key = parse_key(text, data)
        except SweepKeyError as exc:
            raise SweepError(str(exc)) from None
        arr = np.atleast_1d(np.asarray(values, dtype=float))
        if arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
            raise SweepError(f"the values of {text!r} must be a nonempty 1-D array of finite numbers; got {values!r}")
        if any(v.key.text == key.text for v in variations):
            raise SweepError(f"sweep key {key.text!r} is varied twice")
        variations.append(Variation(key, arr))
    _check_points_count([len(v.values) for v in variations], [v.key.text for v in variations])
    ensemble_spec = ensemble_members = None
    if ensemble is not None:
        if isinstance(ensemble, bool) or not isinstance(ensemble, (int, np.integer)) or ensemble < 1:
            raise SweepError(f"`ensemble` must be a positive integer (initial states per point); got {ensemble!r}")
        check("LIEINT_MAX_ENSEMBLE", int(ensemble), "--ensemble: the number of initial states per point")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise SweepError(f"`seed` must be a nonnegative integer; got {seed!r}")
        own = data.get("ensemble", {})
        if spread is None:
            if "spread" not in own:
                raise SweepError(
                    "`spread` (the standard deviation of the Gaussian perturbation of the initial angular velocity) "
                    "is required for an ensemble: the scene has no [ensemble] spread"
                )
            spread = own["spread"]
        ensemble_spec = {"count": int(ensemble), "seed": int(seed), "spread": spread}
        size = int(ensemble)
    elif base.ensemble is not None:
        size = int(base.ensemble["members"].shape[0])
        if "file" in data.get("ensemble", {}):
            ensemble_members = {"key": base.ensemble["key"], "members": np.array(base.ensemble["members"])}
    else:
        size = 1
    opts = {
        "h": base.step,
        "method": base.method,
        "coordinates": base.coordinates,
        "project": base.project,
        "save_every": base.save_every,
    }
    _check_method(opts)
    plan = SweepPlan(
        source="scene",
        variations=variations,
        ensemble=size,
        chunk=1,
        t_span=(base.t_start, base.t_end),
        options=opts,
        scene_data=data,
        scene_source=source,
        ensemble_spec=ensemble_spec,
        ensemble_members=ensemble_members,
        outputs=tuple(base.outputs),
        description=base.name,
    )
    _check_members(plan.npoints, size)
    plan.chunk = _check_chunk(chunk, _default_chunk(plan.npoints, size), plan.nmembers)
    _check_points(plan)
    first = plan.build_point(0)
    plan.indicators, plan.indicator_vector = check_indicators(
        indicators, indicator_vector, first[0], opts, plan.outputs
    )
    _check_chunk_sizes(plan, first)
    return plan


#: up to this many parameter points are all built on the client before anything runs
CHECK_ALL_POINTS = 2000


def _check_points(plan: SweepPlan) -> None:
    """Build the points here (all of them, or the first and last of a very large sweep) so that
    an invalid value or a change of system kind is reported before any chunk runs."""
    n = plan.npoints
    points = range(n) if n <= CHECK_ALL_POINTS else (0, n - 1)
    first = None
    for p in points:
        system, _ = plan.build_point(p)
        if first is None:
            first = system
        elif system.fields != first.fields:
            values = ", ".join(
                f"{v.key.text} = {x:g}" for v, x in zip(plan.variations, plan.point_values(p), strict=True)
            )
            raise SweepError(
                f"every member of a sweep must have the same state fields; at {values} the scene builds "
                f"{type(system).__name__} with {list(system.fields)}, at the first point {type(first).__name__} with "
                f"{list(first.fields)} (e.g. a centre of mass that becomes zero makes a heavy top an Euler top)"
            )


def plan_from_systems(
    systems,
    y0,
    t_span,
    *,
    h: float,
    method: str = "rkmk4",
    coordinates: str | None = None,
    project: bool = False,
    save_every: int = 1,
    outputs: Sequence[str] = (),
    chunk: int | None = None,
    indicators: Sequence[str] | None = None,
    indicator_vector=None,
) -> SweepPlan:
    """Plan a sweep of given systems × given initial states.

    Parameters
    ----------
    systems : LieGroupSystem or list of them
        The parameter points; all must have the same state fields.
    y0 : state dict or list of state dicts
        Initial states, each with or without batch axes; they are stacked into one ensemble
        that every system runs.
    t_span, h, method, coordinates, project, save_every
        As for :func:`lieint.integrate` (fixed-step methods only).
    outputs : sequence of str
        Outputs or invariants of the systems to store as series (their drift too for invariants).
    chunk : int, optional
        Members per chunk.
    indicators, indicator_vector : optional
        Chaos indicators to store per member and their initial tangent vector
        (:mod:`lieint.sweeps.indicators`).
    """
    from ..systems.base import LieGroupSystem

    systems = [systems] if isinstance(systems, LieGroupSystem) else list(systems)
    if not systems or not all(isinstance(s, LieGroupSystem) for s in systems):
        raise SweepError(f"`systems` must be a lieint system or a nonempty list of them; got {systems!r}")
    states = [y0] if isinstance(y0, dict) else list(y0)
    if not states:
        raise SweepError("`y0` must be a state dict or a nonempty list of them")
    first = systems[0]
    for s in systems[1:]:
        if s.fields != first.fields:
            raise SweepError(
                f"every system of a sweep must have the same state fields; got {first.fields} and {s.fields}"
            )
    flat = []
    for i, y in enumerate(states):
        y = first.validate_state(y, f"y0[{i}]")
        batch = first.batch_shape(y)
        flat.append({k: v.reshape((-1,) + v.shape[len(batch) :]) for k, v in y.items()})
    stacked = {k: np.concatenate([y[k] for y in flat]) for k in first.fields}
    opts = {"h": h, "method": method, "coordinates": coordinates, "project": project, "save_every": save_every}
    _check_method(opts)
    from ..ivp import check_t_span

    t0, t1 = check_t_span(t_span)
    for name in outputs:
        if name not in first.outputs and name not in first.invariants:
            raise SweepError(
                f"`outputs`: {name!r} is not an output of {type(first).__name__}; choose from "
                f"{sorted(set(first.outputs) | set(first.invariants))}"
            )
    size = next(iter(stacked.values())).shape[0]
    _check_members(len(systems), size)
    plan = SweepPlan(
        source="systems",
        variations=[],
        ensemble=size,
        chunk=1,
        t_span=(t0, t1),
        options=opts,
        systems=systems,
        states=stacked,
        outputs=tuple(outputs),
        description=type(first).__name__,
    )
    plan.chunk = _check_chunk(chunk, _default_chunk(plan.npoints, size), plan.nmembers)
    plan.indicators, plan.indicator_vector = check_indicators(indicators, indicator_vector, first, opts, plan.outputs)
    _check_chunk_sizes(plan, (first, stacked))
    return plan
