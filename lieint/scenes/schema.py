"""Scenes as data: the TOML schema, its Python object, and errors that point at the file line.

A scene declares the body, the support (``fixed_point`` | ``rolling`` | ``free``), the forces
(gravity or none), the initial state, the integrator and the outputs wanted::

    [scene]       name, description
    [body]        mass_tensor | principal_moments | uniform = true (+ dimension),
                  mass, center_of_mass, radius
                  | system = "name", parameters = {…}  (a system by name, see below),
                  orientation = "matrix" | "rotor"  (R on SO(n), or a rotor of Spin(n))
    [support]     type, normal
    [forces]      gravity = [gx, gy, gz] | {magnitude = 9.81, incline = "pi/6"}
    [initial]     angular_velocity (n = 3) | omega (bivector) | momentum (bivector),
                  orientation, center, velocity
    [integrator]  method, step, t_end, t_start, coordinates, project, save_every, rtol, atol, backend
    [output]      quantities = ["energy", "orientation", "contact_path", ...]
    [ensemble]    count, seed, spread  (Gaussian spread of the initial angular velocity) | file

A body given as ``system = "name"`` is built by that system's factory from the numeric
``parameters`` (a built-in system such as ``"heavy_top"``, or one another package installs under
the entry-point group ``lieint.systems``, see :mod:`lieint.catalog`); then ``[support]``
and ``[forces]`` are not used and the ``[initial]`` keys go to ``system.initial_state``.

Every number may be written as a string in a small safe grammar (``"pi/4"``), see
:mod:`lieint.scenes.expressions`; nothing in a scene is evaluated as code.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..text import printable
from .reader import SceneError, TableReader, load_members, max_nesting, read_regular

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["SUPPORTS", "Scene", "SceneError", "load_scene", "parse_scene"]

SUPPORTS = ("fixed_point", "rolling", "free")
#: how a body carries its orientation: a rotation matrix, or a rotor of Spin(n) (lieint.ga)
ORIENTATIONS = ("matrix", "rotor")

TABLES: dict[str, set[str]] = {
    "scene": {"name", "description"},
    "body": {
        "mass_tensor",
        "principal_moments",
        "uniform",
        "dimension",
        "mass",
        "center_of_mass",
        "radius",
        "system",
        "parameters",
        "orientation",
    },
    "support": {"type", "normal"},
    "forces": {"gravity"},
    "initial": {"angular_velocity", "omega", "momentum", "orientation", "center", "velocity"},
    "integrator": {
        "method",
        "step",
        "t_end",
        "t_start",
        "coordinates",
        "project",
        "save_every",
        "rtol",
        "atol",
        "backend",
    },
    "output": {"quantities"},
    "ensemble": {"count", "seed", "spread", "file"},
    "events": {"name", "output", "component", "value", "direction", "terminal"},
}
_REQUIRED_TABLES = ("scene", "body", "initial", "integrator", "output")


@dataclass(frozen=True)
class Scene:
    """A validated scene (see the module docstring for the keys).

    Build one from a TOML file with :func:`load_scene`, from a dict with :func:`parse_scene`,
    or directly; :func:`lieint.scenes.build_system` assembles the system it calls for.
    """

    name: str
    dimension: int | None
    support: str | None
    mass_tensor: np.ndarray | None
    mass: float | None = None
    center_of_mass: np.ndarray | None = None
    radius: float | None = None
    normal: np.ndarray | None = None
    gravity: np.ndarray | None = None
    initial: dict[str, np.ndarray] = field(default_factory=dict)
    method: str = "rkmk4"
    step: float = 0.01
    t_end: float = 10.0
    t_start: float = 0.0
    coordinates: str | None = None
    project: bool = False
    save_every: int = 1
    outputs: tuple[str, ...] = ("energy",)
    ensemble: dict | None = None
    description: str = ""
    source: str | None = None
    text: str | None = field(default=None, repr=False)
    system: str | None = None
    parameters: dict[str, Any] = field(default_factory=dict)
    rtol: float = 1e-8
    atol: float = 1e-10
    #: ``"auto"`` (the compiled engine where it applies), ``"numba"`` (it or an error), ``"numpy"``
    #: (the generic path: the reference the engine is tested against)
    backend: str = "auto"
    #: ``[[events]]``: dicts with name, output, component, value, direction, terminal
    events: tuple = ()
    #: "matrix" (R ∈ SO(n)) or "rotor" (the rotor form, lieint.ga.RotorForm)
    orientation: str = "matrix"


def load_scene(path) -> Scene:
    """Read and validate a scene TOML file.

    Only a regular file is read (never a device, FIFO or ``/dev/stdin``, which could block or
    never end), and only up to ``LIEINT_MAX_SCENE_BYTES`` (:mod:`lieint.limits`).
    """
    from ..limits import LimitError, check, limit

    path = Path(path)
    try:
        data = read_regular(path, limit("LIEINT_MAX_SCENE_BYTES") + 1)
        check("LIEINT_MAX_SCENE_BYTES", len(data), f"the size of the scene file {str(path)!r} (bytes)")
        text = data.decode("utf-8")
    except (OSError, LimitError) as exc:
        raise SceneError(f"cannot read scene file {str(path)!r}: {getattr(exc, 'strerror', None) or exc}") from None
    except UnicodeDecodeError as exc:
        raise SceneError(f"cannot read scene file {str(path)!r}: not UTF-8 text ({exc.reason})") from None
    return parse_scene(text, source=str(path))


def parse_scene(text_or_dict, source: str | None = None) -> Scene:
    """Validate a scene given as TOML text or as the equivalent dict."""
    if isinstance(text_or_dict, str):
        text = text_or_dict
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(f"{source or '<scene>'}: not valid TOML: {exc}") from None
        except RecursionError:
            raise SceneError(
                f"{source or '<scene>'}: arrays or tables nested too deeply to read (scenes need at most "
                f"{max_nesting()} levels)"
            ) from None
    elif isinstance(text_or_dict, dict):
        text, data = None, text_or_dict
    else:
        raise TypeError(f"`scene` must be TOML text or a dict; got {type(text_or_dict).__name__}.")
    return _Reader(data, text, source).scene()


class _Reader(TableReader):
    """The scene schema on top of the typed readers: one method per table."""

    def __init__(self, data: dict, text: str | None, source: str | None):
        super().__init__(data, text, source or "<scene>", TABLES)

    # -- the scene ---------------------------------------------------------------------
    def scene(self) -> Scene:
        scene = self._scene()
        events = self.events(self.data.get("events", []))
        return replace(scene, events=events) if events else scene

    def events(self, items) -> tuple[dict, ...]:
        """``[[events]]``: ``g(t, y) = output[component] − value`` (see :mod:`lieint.events`)."""
        items = [items] if isinstance(items, dict) else items
        if not isinstance(items, list) or not all(isinstance(e, dict) for e in items):
            raise self.fail("events", None, "must be tables [[events]] with keys output, component, value, …")
        out = []
        for ev in items:
            self.check_keys("events", ev)
            output = self.string("events", "output", self.required(ev, "events", "output"))
            component = ev.get("component", [])
            component = [component] if isinstance(component, int) and not isinstance(component, bool) else component
            if not isinstance(component, list) or not all(
                isinstance(c, int) and not isinstance(c, bool) and c >= 0 for c in component
            ):
                raise self.fail("events", "component", f"expected indices >= 0 (e.g. [0, 2]); got {component!r}")
            terminal = ev.get("terminal", False)
            if not isinstance(terminal, (bool, int)) or terminal < 0:
                raise self.fail("events", "terminal", f"expected true, false or a count >= 0; got {terminal!r}")
            out.append(
                {
                    "name": printable(self.string("events", "name", ev.get("name", output))),
                    "output": output,
                    "component": tuple(component),
                    "value": self.number("events", "value", ev.get("value", 0.0)),
                    "direction": self.number("events", "direction", ev.get("direction", 0.0)),
                    "terminal": terminal,
                }
            )
        return tuple(out)

    def _scene(self) -> Scene:
        unknown = sorted(set(self.data) - set(TABLES))
        if unknown:
            raise self.fail(unknown[0], None, f"unknown table; allowed tables are {sorted(TABLES)}")
        for name in _REQUIRED_TABLES:
            if name not in self.data:
                raise SceneError(f"{self.source}: missing required table [{name}]")
        meta, body, support = self.table("scene"), self.table("body"), self.table("support")
        forces, integ, output = (self.table(t) for t in ("forces", "integrator", "output"))
        # a named system's [initial] keys are its initial_state's parameters (checked when built)
        initial = self.table("initial", check_keys="system" not in body)

        # the scene's own words are printed by every front end (and drawn in figures): their control
        # characters are escaped once here, so that no terminal ever receives them
        name = printable(self.string("scene", "name", self.required(meta, "scene", "name")))
        description = printable(self.string("scene", "description", meta.get("description", "")))
        orientation = self.string("body", "orientation", body.get("orientation", "matrix"), ORIENTATIONS)
        if "system" in body:
            scene = self.named_system_scene(name, description, body, initial, integ, output)
            return replace(scene, orientation=orientation)
        if "support" not in self.data:
            raise SceneError(f"{self.source}: missing required table [support] (or name a [body] system)")
        kind = self.string("support", "type", self.required(support, "support", "type"), SUPPORTS)

        mass = self.positive("body", "mass", body["mass"]) if "mass" in body else None
        radius = self.positive("body", "radius", body["radius"]) if "radius" in body else None
        if "parameters" in body:
            raise self.fail("body", "parameters", 'applies to a body given as `system = "name"`')
        B = self.mass_tensor(body, mass, radius)
        n = self.n
        XG = self.array("body", "center_of_mass", body["center_of_mass"], (n,)) if "center_of_mass" in body else None
        if kind in ("rolling", "free") and mass is None:
            raise self.fail("body", None, f"missing key 'mass' (required for support type {kind!r})")
        if kind == "rolling" and radius is None:
            raise self.fail("body", None, "missing key 'radius' (required for a rolling ball)")
        if kind != "rolling" and radius is not None:
            raise self.fail("body", "radius", f"applies to rolling balls only; support type is {kind!r}")
        if XG is not None and np.any(XG != 0) and kind == "fixed_point" and mass is None:
            raise self.fail("body", None, "missing key 'mass' (required with an offset centre of mass under gravity)")
        normal = self.array("support", "normal", support["normal"], (n,)) if "normal" in support else None
        if normal is not None and kind != "rolling":
            raise self.fail("support", "normal", f"applies to rolling supports only; support type is {kind!r}")
        gravity = self.gravity(forces) if "gravity" in forces else None
        free_top = kind == "fixed_point" and not (gravity is not None and XG is not None and np.any(XG != 0))
        if "principal_moments" in body and not free_top:
            self.check_moments(np.asarray(body["principal_moments"], dtype=float), kind)

        init = self.initial(initial, kind)
        integrator = self.integrator(integ)
        quantities = self.quantities(output)
        ensemble = self.ensemble(self.table("ensemble"), init) if "ensemble" in self.data else None
        return Scene(
            orientation=orientation,
            ensemble=ensemble,
            name=name,
            dimension=n,
            support=kind,
            mass_tensor=B,
            mass=mass,
            center_of_mass=XG,
            radius=radius,
            normal=normal,
            gravity=gravity,
            initial=init,
            outputs=quantities,
            description=description,
            source=self.source,
            text=self.text,
            **integrator,
        )

    def named_system_scene(self, name, description, body, initial, integ, output) -> Scene:
        """A body given by a system's name and numeric parameters (see the module docstring)."""
        system = self.string("body", "system", body["system"])
        extra = sorted(set(body) - {"system", "parameters", "orientation"})
        if extra:
            raise self.fail("body", extra[0], 'does not apply to a body given as `system = "name"`; use `parameters`')
        for table in ("support", "forces"):
            if self.data.get(table):
                raise self.fail(table, None, f"does not apply to a body given as system = {system!r}")
        params = body.get("parameters", {})
        if not isinstance(params, dict):
            raise self.fail("body", "parameters", f"expected a table of numbers; got {params!r}")
        parameters = {k: self.plain_value("body", "parameters", v) for k, v in params.items()}
        init = {k: self.plain_value("initial", k, v) for k, v in initial.items()}
        if "ensemble" in self.data:
            raise self.fail("ensemble", None, f"ensembles are not available for a body given as system = {system!r}")
        return Scene(
            name=name,
            dimension=None,
            support=None,
            mass_tensor=None,
            initial=init,
            outputs=self.quantities(output),
            description=description,
            source=self.source,
            text=self.text,
            system=system,
            parameters=parameters,
            **self.integrator(integ),
        )

    def integrator(self, integ: dict) -> dict:
        from ..methods.registry import method_specs

        specs = method_specs()
        method = self.string("integrator", "method", self.required(integ, "integrator", "method"))
        if method not in specs:
            raise self.fail("integrator", "method", f"unknown method {method!r}; valid names are {list(specs)}")
        spec = specs[method]
        step = self.positive("integrator", "step", self.required(integ, "integrator", "step"))
        t_end = self.number("integrator", "t_end", self.required(integ, "integrator", "t_end"))
        t_start = self.number("integrator", "t_start", integ.get("t_start", 0.0))
        if not t_end > t_start:
            raise self.fail("integrator", "t_end", f"must be greater than t_start = {t_start:g}; got {t_end:g}")
        coordinates = None
        if "coordinates" in integ:
            if not spec.coordinates:
                raise self.fail(
                    "integrator", "coordinates", f"does not apply to {method!r}, which has no coordinate map"
                )
            coordinates = self.string("integrator", "coordinates", integ["coordinates"], spec.coordinates)
        project = integ.get("project", False)
        if not isinstance(project, bool):
            raise self.fail("integrator", "project", f"expected true or false; got {project!r}")
        save_every = integ.get("save_every", 1)
        if isinstance(save_every, bool) or not isinstance(save_every, int) or save_every < 1:
            raise self.fail("integrator", "save_every", f"expected a positive integer; got {save_every!r}")
        tolerances = {}
        for key, default in (("rtol", 1e-8), ("atol", 1e-10)):
            if key in integ and not spec.adaptive:
                raise self.fail("integrator", key, f"applies to adaptive methods only; {method!r} has a fixed step")
            tolerances[key] = self.positive("integrator", key, integ[key]) if key in integ else default
        backend = self.string("integrator", "backend", integ.get("backend", "auto"), ("auto", "numba", "numpy"))
        return {
            "method": method,
            "step": step,
            "t_end": t_end,
            "t_start": t_start,
            "coordinates": coordinates,
            "project": project,
            "save_every": save_every,
            "backend": backend,
            **tolerances,
        }

    def quantities(self, output: dict) -> tuple[str, ...]:
        quantities = self.required(output, "output", "quantities")
        if not isinstance(quantities, list) or not quantities or not all(isinstance(q, str) for q in quantities):
            raise self.fail("output", "quantities", f"expected a nonempty list of names; got {quantities!r}")
        return tuple(quantities)

    def ensemble(self, ens: dict, init: dict) -> dict:
        """Many initial conditions: ``count`` members with a seeded Gaussian ``spread`` added to the
        initial angular velocity (or to the entries of ``omega``), or the members from ``file``
        (a .npy array of angular velocities (N, 3) or omegas (N, n, n)), integrated as one batch."""
        key = "angular_velocity" if "angular_velocity" in init else "omega" if "omega" in init else None
        if key is None:
            raise self.fail("ensemble", None, "an ensemble spreads 'angular_velocity' or 'omega' of [initial]")
        base = init[key]
        if "file" in ens:
            if set(ens) - {"file"}:
                raise self.fail("ensemble", "file", "give either 'file' or 'count', 'seed' and 'spread'")
            name = self.string("ensemble", "file", ens["file"])
            path = Path(name) if self.source in (None, "<scene>") else Path(self.source).parent / name
            try:
                members = load_members(path)  # plain arrays only: never code; sizes checked first
            except (OSError, ValueError) as exc:
                raise self.fail("ensemble", "file", f"cannot read {str(path)!r} as a .npy array ({exc})") from None
            if members.ndim != base.ndim + 1 or members.shape[1:] != base.shape or not np.all(np.isfinite(members)):
                raise self.fail(
                    "ensemble",
                    "file",
                    f"expected a finite array of shape (N, {', '.join(map(str, base.shape))}) "
                    f"of initial {key}; got shape {members.shape}",
                )
            return {"key": key, "members": members.astype(float)}
        missing = [k for k in ("count", "seed", "spread") if k not in ens]
        if missing:
            raise self.fail("ensemble", None, f"missing key {missing[0]!r} (count, seed and spread, or file)")
        count, seed = ens["count"], ens["seed"]
        for k, v in (("count", count), ("seed", seed)):
            if isinstance(v, bool) or not isinstance(v, int) or v < (1 if k == "count" else 0):
                raise self.fail(
                    "ensemble", k, f"expected a {'positive' if k == 'count' else 'nonnegative'} integer; got {v!r}"
                )
        self.within("LIEINT_MAX_ENSEMBLE", count, "ensemble", "count", "the ensemble count")
        self.within(
            "LIEINT_MAX_MEMORY",
            count * base.size * 8,
            "ensemble",
            "count",
            f"the memory of {count} initial {key} (bytes)",
        )
        spread = self.number("ensemble", "spread", ens["spread"])
        if spread < 0:
            raise self.fail("ensemble", "spread", f"must be >= 0; got {spread:g}")
        noise = np.random.default_rng(seed).normal(size=(count,) + base.shape) * spread
        if key == "omega":
            noise = 0.5 * (noise - np.swapaxes(noise, -1, -2))
        return {"key": key, "members": base + noise}

    def mass_tensor(self, body: dict, mass, radius) -> np.ndarray:
        given = [k for k in ("mass_tensor", "principal_moments", "uniform") if k in body]
        if len(given) != 1:
            raise self.fail(
                "body",
                given[1] if len(given) > 1 else None,
                f"give exactly one of 'mass_tensor', 'principal_moments' or 'uniform = true'; got {given or 'none'}",
            )
        key = given[0]
        if key == "principal_moments":
            self.n = 3
            I = self.array("body", key, body[key], (3,))
            if np.any(I <= 0):
                raise self.fail("body", key, f"must be positive; got {I.tolist()}")
            # the triangle inequality of a mass distribution is checked once the support is known
            # (a free top takes any positive moments: _check_moments)
            return np.diag((I.sum() - 2 * I) / 2)
        if key == "uniform":
            if body[key] is not True:
                raise self.fail("body", key, f"expected true; got {body[key]!r}")
            if "dimension" not in body:
                raise self.fail("body", None, "missing key 'dimension' (required with 'uniform = true')")
            dim = body["dimension"]
            if isinstance(dim, bool) or not isinstance(dim, int) or dim < 2:
                raise self.fail("body", "dimension", f"expected an integer >= 2; got {dim!r}")
            self.within("LIEINT_MAX_DIMENSION", dim, "body", "dimension", "the dimension n")
            self.n = dim
            if mass is None or radius is None:
                raise self.fail("body", key, "a uniform solid ball needs 'mass' and 'radius'")
            return mass * radius**2 / (dim + 2) * np.eye(dim)
        value = body[key]
        if not isinstance(value, list) or not value or not isinstance(value[0], list):
            raise self.fail("body", key, f"expected an (n, n) array; got {value!r}")
        self.within("LIEINT_MAX_DIMENSION", len(value), "body", key, "the dimension n (rows of the mass tensor)")
        self.n = len(value)
        B = self.array("body", key, value, (self.n, self.n))
        if "dimension" in body and body["dimension"] != self.n:
            raise self.fail("body", "dimension", f"is {body['dimension']!r} but mass_tensor is {self.n} x {self.n}")
        return B

    def check_moments(self, I: np.ndarray, kind: str) -> None:
        """The triangle inequality ``I_i <= I_j + I_k`` of a body's moments, which every scene but
        a free top needs (its potential, its rolling or its motion in space involve the mass
        distribution; the free top's equations take any positive moments)."""
        if np.any(I.sum() - 2 * I < -1e-12 * I.max()):
            raise self.fail(
                "body",
                "principal_moments",
                f"must satisfy I_i <= I_j + I_k (a mass distribution's moments) for support type {kind!r} "
                f"with these forces; got {I.tolist()} (only a free top, a fixed point without a gravity torque, "
                "takes any positive moments)",
            )

    def gravity(self, forces: dict) -> np.ndarray:
        g = forces["gravity"]
        n = self.n
        if isinstance(g, dict):
            unknown = sorted(set(g) - {"magnitude", "incline"})
            if unknown or "magnitude" not in g:
                raise self.fail(
                    "forces",
                    "gravity",
                    f"as a table takes 'magnitude' and optionally 'incline' (an angle); got keys {sorted(g)}",
                )
            mag = self.number("forces", "gravity", g["magnitude"])
            theta = self.number("forces", "gravity", g.get("incline", 0.0))
            e = np.eye(n)
            # a plane tilted by θ about e_2: gravity gains a component along e_1
            return mag * (np.sin(theta) * e[0] - np.cos(theta) * e[-1])
        return self.array("forces", "gravity", g, (n,))

    def initial(self, initial: dict, kind: str) -> dict[str, np.ndarray]:
        n = self.n
        given = [k for k in ("angular_velocity", "omega", "momentum") if k in initial]
        if len(given) != 1:
            raise self.fail(
                "initial",
                given[1] if len(given) > 1 else None,
                f"give exactly one of 'angular_velocity' (n = 3), 'omega' or 'momentum'; got {given or 'none'}",
            )
        out: dict[str, np.ndarray] = {}
        if "angular_velocity" in initial:
            if n != 3:
                raise self.fail(
                    "initial",
                    "angular_velocity",
                    f"is a 3-vector (n = 3 only); this scene has n = {n}, use 'omega' (a bivector matrix)",
                )
            out["angular_velocity"] = self.array("initial", "angular_velocity", initial["angular_velocity"], (3,))
        for key in ("omega", "momentum", "orientation"):
            if key in initial:
                out[key] = self.array("initial", key, initial[key], (n, n))
        for key in ("center", "velocity"):
            if key in initial:
                if kind == "fixed_point":
                    raise self.fail("initial", key, "does not apply to a body with a fixed point")
                out[key] = self.array("initial", key, initial[key], (n,))
        if "momentum" in initial and kind == "rolling":
            raise self.fail("initial", "momentum", "a rolling ball starts from 'omega' or 'angular_velocity'")
        return out
