"""Size limits checked before anything is allocated, each raisable by an environment variable.

A scene or an argument can ask for more than the machine has: 10¹² steps, an ensemble of 10⁹
members, a body of dimension 10⁵, arrays nested 10⁵ deep, a ``.npy`` file whose header claims
a huge shape. Such requests are refused at once with a message that names the argument, the
value asked for, the limit and the environment variable that raises it — instead of a
``MemoryError`` traceback minutes later, or a machine brought to a halt.

============================  =========================================  ============
limit                         what it bounds                             default
============================  =========================================  ============
``LIEINT_MAX_STEPS``          steps of a fixed-step run                  10¹⁰
``LIEINT_MAX_ENSEMBLE``       members of an ensemble                     10⁶
``LIEINT_MAX_DIMENSION``      dimension n of a body                      256
``LIEINT_MAX_SCENE_BYTES``    size of a scene file                       1 MiB
``LIEINT_MAX_MEMORY``         arrays a run (or a sweep's chunk) holds    4 GiB
``LIEINT_MAX_SWEEP_POINTS``   parameter points of a sweep                10⁶
``LIEINT_MAX_SWEEP_MEMBERS``  members of a sweep (points × ensemble)     10⁷
``LIEINT_MAX_SWEEP_CHUNKS``   chunks of a sweep (files in its store)     10⁵
``LIEINT_MAX_WORKERS``        worker processes of a local cluster        4 × CPUs
============================  =========================================  ============

The rows an adaptive run saves are not known in advance; its loops count them against
``LIEINT_MAX_MEMORY`` as they save them (:class:`RowBudget`).

Arrays in a scene are nested at most :data:`MAX_NESTING` levels (an ensemble of matrices needs
three); this one is structural and cannot be raised.
"""

from __future__ import annotations

import math
import os

__all__ = ["DEFAULTS", "MAX_NESTING", "LimitError", "RowBudget", "check", "env_flag", "limit"]

DEFAULTS: dict[str, int] = {
    "LIEINT_MAX_STEPS": 10**10,
    "LIEINT_MAX_ENSEMBLE": 10**6,
    "LIEINT_MAX_DIMENSION": 256,
    "LIEINT_MAX_SCENE_BYTES": 1 << 20,
    "LIEINT_MAX_MEMORY": 4 << 30,
    "LIEINT_MAX_SWEEP_POINTS": 10**6,
    "LIEINT_MAX_SWEEP_MEMBERS": 10**7,
    "LIEINT_MAX_SWEEP_CHUNKS": 10**5,
    # each worker is a process of its own (~150 MB): more than a few per core only thrashes
    "LIEINT_MAX_WORKERS": 4 * (os.cpu_count() or 1),
}

MAX_NESTING = 8


class LimitError(ValueError):
    """A request beyond a size limit; the message says how to raise the limit."""


def limit(name: str) -> int:
    """The limit ``name`` (one of :data:`DEFAULTS`), from the environment when set there."""
    text = os.environ.get(name)
    if text is None or not text.strip():
        return DEFAULTS[name]
    try:
        value = float(text)
    except ValueError:
        raise LimitError(f"the environment variable {name} must be a positive number; got {text!r}") from None
    if not (value >= 1 and math.isfinite(value)):
        raise LimitError(f"the environment variable {name} must be a positive finite number; got {text!r}")
    return int(value)


def check(name: str, value: float, what, advice: str = "") -> None:
    """Refuse ``value`` above the limit ``name``; ``what`` says what was asked for.

    The message reads ``"<what> is <value>, more than the limit <limit> (raise it with the
    environment variable NAME=...)"``, then ``advice`` (another way out). NaN and infinity are
    always refused. ``what`` may be a callable returning the text, formatted only for the
    message (hot paths check on every call).
    """
    bound = limit(name)
    if not value <= bound:  # also true for NaN
        if callable(what):
            what = what()
        shown = f"{value:.4g}" if isinstance(value, float) else f"{value}"
        raise LimitError(
            f"{what} is {shown}, more than the limit {bound} (to allow it, set the environment variable "
            f"{name} to a larger number, e.g. {name}={_suggest(value, bound)})" + (f"; {advice}" if advice else "")
        )


def _suggest(value: float, bound: int) -> str:
    if not math.isfinite(value) or value > 1e18:
        return str(bound * 10)
    return str(math.ceil(value))


def env_flag(name: str) -> bool:
    """True when the environment variable ``name`` is set to 1, true or yes."""
    return os.environ.get(name, "").strip().lower() in ("1", "true", "yes")


class RowBudget:
    """The rows a run may hold in memory under ``LIEINT_MAX_MEMORY`` when their number is not
    known in advance (adaptive steps, scipy's solvers; a fixed grid's rows are checked before the
    run): ``rows`` of ``row_bytes`` each fit, and :meth:`hold` refuses more with the limit's
    message — instead of a run that fills the machine's memory (a tolerance below round-off once
    collapsed an adaptive run's steps until the process held 24 GB). ``what(rows)`` says what
    was asked for, ``advice`` the other ways out."""

    def __init__(self, row_bytes: int, what, advice: str = ""):
        self.row_bytes, self.what, self.advice = row_bytes, what, advice
        self.rows = limit("LIEINT_MAX_MEMORY") // row_bytes

    def hold(self, rows: int) -> None:
        """Refuse (:class:`LimitError`) to hold ``rows`` rows beyond the limit."""
        if rows > self.rows:
            check("LIEINT_MAX_MEMORY", float(rows * self.row_bytes), lambda: self.what(rows), self.advice)
