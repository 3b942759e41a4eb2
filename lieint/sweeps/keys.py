"""Scene keys a sweep varies: ``table.key``, ``table.key[i]``, ``table.key.sub``.

A key names one number of a scene's TOML data::

    body.principal_moments[0]      the first principal moment I₁
    body.mass                      the mass
    body.center_of_mass[2]         a component of X_G
    forces.gravity.incline         the incline angle of gravity given as a table
    forces.gravity.magnitude       its magnitude
    initial.angular_velocity[2]    a component of the initial angular velocity
    initial.omega[0][1]            an entry of the initial Ω (its skew partner is set too)
    body.parameters.mass           a parameter of a body given as ``system = "name"``

Keys of ``[initial]`` change the initial state only; every other key changes the system. The
``[integrator]``, ``[output]`` and ``[ensemble]`` tables are part of the sweep's definition and
cannot be varied (every member must share one time grid and one set of outputs).

A varied key and its values are written ``KEY=START:STOP:NUM`` or ``KEY=V1,V2,...``
(:func:`parse_vary`, the command line's ``--vary``).
"""

from __future__ import annotations

import copy
import re
from dataclasses import dataclass

import numpy as np

from ..scenes.schema import TABLES

__all__ = ["VARIABLE_TABLES", "SceneKey", "SweepError", "SweepKeyError", "parse_key", "parse_vary"]

#: the tables whose numbers a sweep may vary
VARIABLE_TABLES = ("body", "support", "forces", "initial")

_KEY = re.compile(r"^(?P<path>[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*)(?P<index>(?:\[\d+\])*)$")


class SweepError(ValueError):
    """A sweep that cannot run as asked; the message says what was expected and what was given."""


class SweepKeyError(ValueError):
    """A sweep key that does not name one number of the scene."""


@dataclass(frozen=True)
class SceneKey:
    """One number of a scene, addressed by table, key, sub-keys and indices.

    Attributes
    ----------
    text : str
        The key as written (``"body.principal_moments[0]"``); also its coordinate name.
    path : tuple of str
        ``(table, key, *sub_keys)``.
    index : tuple of int
        Indices into the array the path names (empty for a scalar).
    """

    text: str
    path: tuple[str, ...]
    index: tuple[int, ...] = ()

    @property
    def table(self) -> str:
        """The scene table (``body``, ``support``, ``forces`` or ``initial``)."""
        return self.path[0]

    @property
    def changes_system(self) -> bool:
        """True unless the key is one of the initial state (``[initial]``)."""
        return self.table != "initial"

    def get(self, data: dict):
        """The current value of the key in the scene data (a number, or an expression string)."""
        return _resolve(data, self, create=False)[0]

    def set(self, data: dict, value: float) -> dict:
        """A deep copy of the scene data with this key set to ``value``."""
        out = copy.deepcopy(data)
        container, last = _resolve(out, self, create=True)[1:]
        container[last] = float(value)
        if self.path[:2] == ("initial", "omega") and len(self.index) == 2:
            i, j = self.index
            # Ω is a bivector: keep the skew partner consistent
            row = _resolve(out, SceneKey(self.text, self.path, (j,)), create=False)[0]
            row[i] = -float(value)
        return out


def parse_key(text: str, data: dict) -> SceneKey:
    """Parse and check a key against the scene's data and the scene schema.

    Parameters
    ----------
    text : str
        The key, e.g. ``"body.principal_moments[0]"``.
    data : dict
        The scene's TOML data (as :func:`tomllib.loads` gives it).

    Raises
    ------
    SweepKeyError
        When the key is malformed, names a table or key the schema does not know or a sweep cannot
        vary, is missing from the scene, or its index is out of range.
    """
    if not isinstance(text, str):
        raise SweepKeyError(f"a sweep key must be a string such as 'body.principal_moments[0]'; got {text!r}")
    m = _KEY.match(text.strip())
    if not m:
        raise SweepKeyError(
            f"sweep key {text!r} is not of the form table.key, table.key[i] or table.key.sub "
            "(e.g. 'body.principal_moments[0]', 'forces.gravity.incline', 'initial.angular_velocity[2]')"
        )
    path = tuple(m.group("path").split("."))
    index = tuple(int(i) for i in re.findall(r"\[(\d+)\]", m.group("index")))
    key = SceneKey(text.strip(), path, index)
    table = path[0]
    if table not in TABLES:
        raise SweepKeyError(f"sweep key {text!r}: unknown table {table!r}; the scene tables are {sorted(TABLES)}")
    if table not in VARIABLE_TABLES:
        raise SweepKeyError(
            f"sweep key {text!r}: the [{table}] table cannot be varied (every member shares the integrator, "
            f"outputs and ensemble); vary keys of {list(VARIABLE_TABLES)}"
        )
    if len(path) < 2:
        raise SweepKeyError(f"sweep key {text!r} names a table, not a number; add the key (e.g. '{table}.mass')")
    named = "system" in data.get("body", {})
    allowed = TABLES[table]
    if not (named and table == "initial") and path[1] not in allowed:
        raise SweepKeyError(
            f"sweep key {text!r}: unknown key {path[1]!r} of [{table}]; allowed keys are {sorted(allowed)}"
        )
    if path[:2] == ("forces", "gravity") and len(path) == 3 and path[2] not in ("magnitude", "incline"):
        raise SweepKeyError(f"sweep key {text!r}: gravity as a table has 'magnitude' and 'incline'; got {path[2]!r}")
    value = key.get(data)
    if isinstance(value, (list, dict)) or isinstance(value, bool):
        what = "an array" if isinstance(value, list) else "a table" if isinstance(value, dict) else "a boolean"
        hint = f"; index it, e.g. '{text}[0]'" if isinstance(value, list) else ""
        raise SweepKeyError(f"sweep key {text!r} names {what}, not a number{hint}")
    if not isinstance(value, (int, float, str)):
        raise SweepKeyError(f"sweep key {text!r} names {value!r}, not a number")
    return key


def _resolve(data: dict, key: SceneKey, create: bool):
    """(value, container, last) for the key; ``create`` adds missing tables of the path."""
    node = data
    where = ""
    for depth, name in enumerate(key.path):
        where = f"{where}.{name}" if where else name
        if not isinstance(node, dict):
            raise SweepKeyError(f"sweep key {key.text!r}: {where.rsplit('.', 1)[0]!r} is not a table")
        last_name = depth == len(key.path) - 1 and not key.index
        if name not in node:
            if depth == 0 and create:
                node[name] = {}
            else:
                present = sorted(node) if isinstance(node, dict) else []
                raise SweepKeyError(
                    f"sweep key {key.text!r}: the scene has no {where!r} to vary (present here: {present}); "
                    "write the base value into the scene first"
                )
        if last_name:
            return node[name], node, name
        parent, node = node, node[name]
    for depth, i in enumerate(key.index):
        if not isinstance(node, list):
            raise SweepKeyError(f"sweep key {key.text!r}: {where!r} is not an array and cannot be indexed")
        if i >= len(node):
            raise SweepKeyError(
                f"sweep key {key.text!r}: index {i} is out of range for {where!r}, which has {len(node)} entries"
            )
        where = f"{where}[{i}]"
        if depth == len(key.index) - 1:
            return node[i], node, i
        parent, node = node, node[i]
    del parent
    raise AssertionError("unreachable")  # pragma: no cover


def parse_vary(text: str) -> tuple[str, np.ndarray]:
    """Parse ``KEY=START:STOP:NUM`` (``NUM`` values, ends included) or ``KEY=v1,v2,...``.

    Examples
    --------
    >>> key, values = parse_vary("body.principal_moments[0]=1:1.5:3")
    >>> key, values.tolist()
    ('body.principal_moments[0]', [1.0, 1.25, 1.5])
    """
    from ..scenes.expressions import ExpressionError, evaluate

    key, sep, spec = str(text).partition("=")
    if not sep or not key.strip() or not spec.strip():
        raise SweepError(f"--vary expects KEY=START:STOP:NUM or KEY=V1,V2,...; got {text!r}")

    def number(s: str) -> float:
        try:
            return float(s) if _plain_float(s) else evaluate(s.strip())
        except (ExpressionError, ValueError):
            raise SweepError(f"--vary {key.strip()}: {s.strip()!r} is not a number or expression") from None

    parts = spec.split(":")
    if len(parts) == 3:
        start, stop = number(parts[0]), number(parts[1])
        try:
            num = int(parts[2])
        except ValueError:
            num = 0
        if num < 1:
            raise SweepError(f"--vary {key.strip()}: NUM must be a positive integer; got {parts[2]!r}")
        from ..limits import check

        # before the values are allocated (NUM = 10⁹ would be 8 GB)
        check("LIEINT_MAX_SWEEP_POINTS", num, f"--vary {key.strip()}: the number of values NUM")
        values = np.linspace(start, stop, num)
    elif len(parts) == 1:
        values = np.array([number(s) for s in spec.split(",")])
    else:
        raise SweepError(f"--vary {key.strip()}: expected START:STOP:NUM or V1,V2,...; got {spec!r}")
    return key.strip(), values


def _plain_float(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True
