"""Reading scene files: regular files only, typed values, errors that point at the line.

* :func:`read_regular` reads at most a given number of bytes of a regular file (never a FIFO,
  device or directory, which could block or never end);
* :class:`TableReader` reads numbers (or expression strings such as ``"pi/4"``), arrays,
  strings and plain values from a parsed TOML document, and its errors (:class:`SceneError`)
  name the file, the table, the key and the line;
* :func:`load_members` reads an ensemble's ``.npy`` file with its header checked before any
  allocation.

The scene schema itself (which tables and keys mean what) is :mod:`lieint.scenes.schema`.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from .expressions import ExpressionError, evaluate

__all__ = ["SceneError", "TableReader", "load_members", "looks_numeric", "max_nesting", "read_regular"]


class SceneError(ValueError):
    """A scene that cannot be used; the message names the file, table, key and line."""


def read_regular(path: Path, at_most: int) -> bytes:
    """At most ``at_most`` bytes of a regular file; OSError (with a reason) for anything else."""
    import os
    import stat

    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)  # a FIFO must not block the open
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            kind = "a directory" if stat.S_ISDIR(st.st_mode) else "a device, FIFO or socket"
            raise OSError(f"it is {kind}, not a regular file (scenes and ensemble files are read from files)")
        chunks, total = [], 0
        while total < at_most:
            chunk = os.read(fd, min(1 << 20, at_most - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        return b"".join(chunks)
    finally:
        os.close(fd)


class TableReader:
    """Typed reading of a parsed TOML document whose errors name the file, table, key and line.

    Parameters
    ----------
    data : dict
        The parsed document.
    text : str or None
        Its TOML text (None for a dict given directly: errors then carry no line).
    source : str
        The file's name in messages.
    tables : dict of str to set of str
        The allowed keys of each table.
    """

    def __init__(self, data: dict, text: str | None, source: str, tables: dict[str, set[str]]):
        self.data, self.text, self.source, self.tables = data, text, source, tables
        #: the body's dimension once known (array shapes are reported with it)
        self.n: int | None = None

    # -- error reporting ---------------------------------------------------------------
    def line_of(self, table: str, key: str | None = None) -> int | None:
        """1-based line of ``key`` in ``[table]`` (or of the table header) in the TOML text."""
        if self.text is None:
            return None
        current = None
        for number, raw in enumerate(self.text.splitlines(), start=1):
            line = raw.strip()
            header = re.match(r"^\[\s*([A-Za-z0-9_.\-]+)\s*\]", line)
            if header:
                current = header.group(1).split(".")[0]
                if key is None and current == table:
                    return number
                continue
            if current == table and key is not None and re.match(rf"^{re.escape(key)}\s*[=.]", line):
                return number
        return None

    def fail(self, table: str, key: str | None, message: str) -> SceneError:
        from ..text import printable

        where = f"[{table}]" + (f" {key}" if key else "")
        line = self.line_of(table, key)
        at = f" (line {line})" if line else ""
        # escaped: a table or key name of the file may hold control characters
        return SceneError(printable(f"{self.source}: {where}{at}: {message}"))

    # -- typed readers -----------------------------------------------------------------
    def table(self, name: str, check_keys: bool = True) -> dict:
        value = self.data.get(name, {})
        if not isinstance(value, dict):
            raise self.fail(name, None, f"must be a table; got {type(value).__name__}")
        if check_keys:
            self.check_keys(name, value)
        return value

    def check_keys(self, name: str, value: dict) -> None:
        allowed = self.tables[name]
        unknown = sorted(set(value) - allowed)
        if unknown:
            raise self.fail(name, unknown[0], f"unknown key {unknown[0]!r}; allowed keys are {sorted(allowed)}")

    def number(self, table: str, key: str, value: Any) -> float:
        if isinstance(value, bool):
            raise self.fail(table, key, f"expected a number; got {value!r}")
        if isinstance(value, (int, float)):
            v = float(value)
            if not np.isfinite(v):
                raise self.fail(table, key, f"expected a finite number; got {value!r}")
            return v
        if isinstance(value, str):
            try:
                return evaluate(value)
            except ExpressionError as exc:
                raise self.fail(table, key, str(exc)) from None
        raise self.fail(table, key, f'expected a number or an expression string such as "pi/4"; got {value!r}')

    def nested(self, table: str, key: str, value: Any) -> Any:
        """Nested lists of numbers (each checked, at most :data:`lieint.limits.MAX_NESTING` deep)."""

        def convert(v, depth):
            if isinstance(v, list):
                if depth >= max_nesting():
                    raise self.fail(table, key, f"arrays nested more than {max_nesting()} levels deep")
                return [convert(x, depth + 1) for x in v]
            return self.number(table, key, v)

        return convert(value, 0)

    def array(self, table: str, key: str, value: Any, shape: tuple[int, ...]) -> np.ndarray:
        if not isinstance(value, list):
            raise self.fail(table, key, f"expected an array of shape {shape}; got {value!r}")
        numbers = self.nested(table, key, value)  # a NaN or a bad entry is reported as such
        try:
            arr = np.array(numbers, dtype=float)
        except ValueError:
            raise self.fail(table, key, f"expected an array of shape {shape}; got a ragged array") from None
        if arr.shape != shape:
            raise self.fail(
                table, key, f"expected an array of shape {shape} (dimension n = {self.n}); got shape {arr.shape}"
            )
        return arr

    def string(self, table: str, key: str, value: Any, choices=None) -> str:
        if not isinstance(value, str):
            raise self.fail(table, key, f"expected a string; got {value!r}")
        if choices is not None and value not in choices:
            raise self.fail(table, key, f"must be one of {list(choices)}; got {value!r}")
        return value

    def positive(self, table: str, key: str, value: Any) -> float:
        v = self.number(table, key, value)
        if v <= 0:
            raise self.fail(table, key, f"must be > 0; got {v:g}")
        return v

    def plain_value(self, table: str, key: str, value: Any):
        """A number, an (n-dimensional) array of numbers, a boolean or a string, as data."""
        if isinstance(value, (bool, str)) and not (isinstance(value, str) and looks_numeric(value)):
            return value
        if isinstance(value, list):
            numbers = self.nested(table, key, value)
            try:
                return np.array(numbers, dtype=float)
            except ValueError:
                raise self.fail(table, key, "expected a rectangular array of numbers; got a ragged array") from None
        return self.number(table, key, value)

    def within(self, name: str, value: int, table: str, key: str, what: str) -> None:
        """Refuse a size above a limit of :mod:`lieint.limits` (before anything is allocated)."""
        from ..limits import LimitError, check

        try:
            check(name, value, what)
        except LimitError as exc:
            raise self.fail(table, key, str(exc)) from None

    def required(self, table_data: dict, table: str, key: str):
        if key not in table_data:
            raise self.fail(table, None, f"missing required key {key!r}")
        return table_data[key]


def max_nesting() -> int:
    """How deep arrays may nest (:data:`lieint.limits.MAX_NESTING`)."""
    from ..limits import MAX_NESTING

    return MAX_NESTING


def load_members(path: Path) -> np.ndarray:
    """An ensemble's members from a ``.npy`` file, its header checked before any allocation:
    a regular file, one plain numeric array (not a ``.npz`` archive), a shape the file's size
    can hold, at most ``LIEINT_MAX_ENSEMBLE`` members."""
    import io

    from ..limits import check

    head = read_regular(path, 1 << 16)
    if head[:2] == b"PK":
        raise ValueError("it is a .npz archive (several arrays); save one array with numpy.save to a .npy file")
    try:
        fh = io.BytesIO(head)
        version = np.lib.format.read_magic(fh)
        shape, _, dtype = (
            np.lib.format.read_array_header_1_0(fh) if version == (1, 0) else np.lib.format.read_array_header_2_0(fh)
        )
    except (ValueError, EOFError) as exc:
        raise ValueError(f"not a .npy file: {exc}") from None
    if dtype.hasobject or dtype.kind not in "fiub":
        raise ValueError(f"expected an array of real numbers; got dtype {dtype}")
    if shape:
        check("LIEINT_MAX_ENSEMBLE", int(shape[0]), "the number of members in the file")
    need = fh.tell() + int(np.prod(shape, dtype=object)) * dtype.itemsize
    size = path.stat().st_size
    if need != size:
        raise ValueError(f"its header claims shape {shape} ({need} bytes) but the file has {size} bytes")
    return np.load(path, allow_pickle=False)


def looks_numeric(text: str) -> bool:
    """Strings of the expression grammar ("pi/4") are numbers; other strings stay strings."""
    try:
        evaluate(text)
    except ExpressionError:
        return False
    return True
