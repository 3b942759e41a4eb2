"""``lieint info RUN.h5``: what state a run file is in, within seconds, on any input.

The answer is one of

* ``complete`` — the run ended and every row is intact;
* ``running`` — another process holds the run's lock (pid, host, start time);
* ``interrupted at step k of N`` (or ``stopped``/``failed``) — with ``resumable`` when its
  checkpoint is intact, of the same scene and lieint version, and covered by the file's rows,
  else why not;
* ``damaged`` — with where: the superblock (truncated file, changed byte), a chunk of a dataset
  whose Fletcher-32 checksum fails (dataset and row range), the attributes (SHA-256), or the
  checkpoint;
* ``unreadable`` — not a file, not HDF5, not a lieint run;
* ``unchecked`` — nothing wrong found, but the deadline came before every part was read (a
  machine under heavy load, a large file): "could not check within the deadline", never
  "damaged" (a user might delete a good run); a longer ``--timeout`` checks it all.

Every HDF5 read happens in a child process with a deadline (:mod:`lieint.runs.reading`), so a
file crafted to make the HDF5 library loop is reported, not waited for. The whole inspection
shares one deadline (``timeout`` seconds from the start), not one per stage.
"""

from __future__ import annotations

import json
import os
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path

from .reading import Header, isolated, read_header, verify_series

__all__ = ["EXIT_CODES", "RunInfo", "inspect_run", "lock_holder"]

#: the exit status of ``lieint info`` for each state (of a run file or a sweep store)
EXIT_CODES = {
    "complete": 0,
    "running": 3,
    "interrupted": 3,
    "stopped": 3,
    "failed": 3,
    "damaged": 1,
    "unreadable": 1,
    "unchecked": 5,
}


@dataclass
class RunInfo:
    """The state of a run file (see the module docstring); ``lines`` is the report to print."""

    path: Path
    state: str  # complete | running | interrupted | stopped | failed | damaged | unreadable | unchecked
    resumable: bool = False
    lines: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)

    @property
    def exit_code(self) -> int:
        """0 complete and intact, 3 incomplete (running, interrupted, stopped, failed) and intact,
        1 damaged or unreadable, 5 not every part checked within the deadline (:data:`EXIT_CODES`)."""
        return 1 if self.problems else EXIT_CODES[self.state]

    def text(self) -> str:
        return "\n".join(self.lines)


def lock_holder(path: Path) -> dict | None:
    """The live holder of the lock of a run file or sweep store (``PATH.lock``), on this host
    (never locked here: taking the lock, even briefly, could refuse a writer that is starting)."""
    lock = Path(str(path) + ".lock")
    try:
        fd = os.open(lock, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError:
        return None
    try:
        holder = json.loads(os.pread(fd, 4096, 0).decode() or "{}")
    except (OSError, ValueError):
        return None
    finally:
        os.close(fd)
    if holder.get("host") != socket.gethostname():
        return holder or None  # another host: cannot tell if it lives, report what it says
    try:
        os.kill(int(holder.get("pid", -1)), 0)
    except (OSError, ValueError, TypeError):
        return None  # that process is gone (the kernel released its lock)
    return holder


def _int(value, default: int) -> int:
    """An attribute as an integer (a damaged file may hold anything there)."""
    try:
        return int(value)
    except (TypeError, ValueError, OverflowError):
        return default


def _checkpoint_child(send, path: str):  # pragma: no cover - runs in the child process
    from .store import Checkpoint

    try:
        _, attrs = Checkpoint(path[: -len(".checkpoint")]).read()
    except Exception as exc:
        send({"error": str(exc)})
        return
    send({"attrs": {k: (v.item() if hasattr(v, "item") else v) for k, v in attrs.items()}})


def _checkpoint(path: Path, timeout: float) -> dict:
    ckpt = Path(str(path) + ".checkpoint")
    if not os.path.lexists(ckpt):
        return {"missing": True}
    if timeout <= 0:
        return {"unchecked": "no time was left to read its checkpoint"}
    try:
        messages, finished = isolated(_checkpoint_child, (str(ckpt),), timeout)
    except Exception as exc:
        return {"error": f"unreadable ({exc})"}
    if not finished or not messages:
        return {"unchecked": f"reading its checkpoint did not finish within {timeout:.3g} s"}
    return messages[0]


def _without_state(problem: str) -> str:
    """A problem's text without a leading "damaged: " (the state word says it once)."""
    return problem[len("damaged: ") :] if problem.startswith("damaged: ") else problem


def inspect_run(path, timeout: float = 4.0) -> RunInfo:
    """Inspect a run file within about ``timeout`` seconds (see the module docstring)."""
    from .._version import __version__
    from ..text import printable
    from .store import attrs_digest

    path = Path(path)
    deadline = time.monotonic() + timeout

    def left() -> float:
        return deadline - time.monotonic()

    shown = printable(str(path))
    header: Header = read_header(path, timeout=left())
    if header.timed_out:
        line = f"{shown}: could not check within the deadline of {timeout:g} s ({header.problem}); pass a longer "
        line += "--timeout"
        return RunInfo(path, "unchecked", lines=[line])
    if not header.ok:
        state = "damaged" if header.problem.startswith(("damaged", "truncated")) else "unreadable"
        problem = _without_state(header.problem)
        return RunInfo(path, state, lines=[f"{shown}: {state}: {printable(problem)}"], problems=[problem])
    attrs = header.attrs
    if "lieint_version" not in attrs or "t" not in header.datasets:
        problem = "not a lieint run (no lieint attributes or no /t series)"
        return RunInfo(path, "unreadable", lines=[f"{path}: unreadable: {problem}"], problems=[problem])

    problems: list[str] = []
    stored = attrs.get("attrs_sha256")
    if stored is not None and stored != attrs_digest(attrs):
        problems.append("the file's attributes fail their SHA-256 (one was changed outside lieint)")
    status = str(attrs.get("status", "?"))
    planned = _int(attrs.get("planned_steps"), -1)
    of_n = f" of {planned}" if planned > 0 else ""
    rows = header.rows
    # every text of the file is printed escaped: a scene name may hold terminal control codes
    lines = [
        shown,
        f"  scene      {printable(str(attrs.get('scene_name', '?')))} "
        f"(fingerprint {printable(str(attrs.get('scene_fingerprint', '?'))[:12])}…)",
        f"  method     {printable(str(attrs.get('method', '?')))}, h = {printable(str(attrs.get('h', '?')))}, "
        f"save_every = {printable(str(attrs.get('save_every', '?')))}, "
        f"back end {printable(str(attrs.get('backend', '?')))}",
        f"  written by lieint {printable(str(attrs.get('lieint_version', '?')))}",
        f"  rows       {rows}",
    ]
    unchecked: list[str] = []

    # every chunk read once: its Fletcher-32 checksum is verified by HDF5
    damaged, verified, finished = verify_series(path, header, left()) if left() > 0 else ([], {}, False)
    for name, r0, r1, error in damaged:
        where = f"/{name} rows {r0}–{r1 - 1}" if r1 > r0 else f"{name}"
        problems.append(f"{where}: {error}")
    if finished:
        lines.append("  checksums  every chunk verified (Fletcher-32)")
    else:
        done = sum(verified.values())
        lines.append(
            f"  checksums  could not check within the deadline: not all verified in {timeout:g} s ({done} dataset "
            "rows verified; pass a longer --timeout to verify every chunk)"
        )
        unchecked.append("not every chunk")

    holder = lock_holder(path) if status == "running" else None
    resumable = False
    if status == "complete":
        state = "complete"
        head = f"complete: {attrs.get('steps_done', '?')}{of_n} steps, {rows} rows"
    elif holder is not None:
        state = "running"
        head = (
            f"running: being written by process {holder.get('pid')} on host {printable(str(holder.get('host')))} "
            f"(started {printable(str(holder.get('started')))}); {rows} rows so far"
        )
    else:
        state = status if status in ("interrupted", "stopped", "failed") else "interrupted"
        ckpt = _checkpoint(path, left())
        if ckpt.get("missing"):
            k = attrs.get("steps_done", "?")
            why = "no checkpoint (RUN.h5.checkpoint) beside it"
            if status == "failed":
                why = "the run failed (a non-finite state); resuming would fail again"
        elif "unchecked" in ckpt:
            k = attrs.get("steps_done", "?")
            why = f"could not check its checkpoint within the deadline ({ckpt['unchecked']})"
            unchecked.append("the checkpoint")
        elif "error" in ckpt:
            k = attrs.get("steps_done", "?")
            why = f"its checkpoint is damaged: {ckpt['error']}"
            problems.append(why)
        else:
            c = ckpt["attrs"]
            k = c.get("k", "?")
            if c.get("scene_fingerprint") != attrs.get("scene_fingerprint"):
                why = "its checkpoint belongs to another scene"
            elif c.get("lieint_version") != __version__:
                why = f"its checkpoint was written by lieint {c.get('lieint_version')}, this is {__version__}"
            elif _int(c.get("rows"), 0) > rows:
                why = f"the file has {rows} rows but its checkpoint records {c.get('rows')} (truncated)"
                problems.append(why)
            else:
                why, resumable = "", True
        stopped = "stopped (--max-drift or --stop-at-horizon)" if "trust_horizon" in attrs else "stopped (--max-drift)"
        word = {"stopped": stopped, "failed": "failed"}.get(state, "interrupted")
        head = f"{word} at step {k}{of_n}; " + (
            "resumable: lieint run SCENE --out RUN.h5 --resume" if resumable else f"not resumable: {why}"
        )
    if problems:
        state = "damaged"
        shown_problems = [_without_state(p) for p in problems[:5]]
        more = f" (and {len(problems) - 5} more)" if len(problems) > 5 else ""
        head = "damaged: " + "; ".join(shown_problems) + more
        resumable = resumable and not damaged
    elif unchecked:
        state = "unchecked"
        head = (
            f"could not check within the deadline ({' and '.join(unchecked)} read in {timeout:g} s; pass a longer "
            f"--timeout); as far as checked: {head}"
        )
    lines.extend(_horizon_lines(attrs.get("trust_horizon")))
    lines.insert(1, f"  state      {printable(head)}")
    return RunInfo(path, state, resumable, lines, problems)


def _horizon_lines(text) -> list[str]:
    """The ``trust`` lines of a run carrying its error estimate (``--max-error-estimate``)."""
    if text is None:
        return []
    from ..text import printable
    from .trust import describe_horizon

    try:
        described = describe_horizon(json.loads(str(text)))
    except (ValueError, KeyError, TypeError) as exc:
        return [f"  horizon    its trust_horizon record is unreadable ({type(exc).__name__})"]
    return [
        f"  horizon    {printable(line.removeprefix('trust horizon: ').removeprefix('trust horizon '))}"
        for line in described.splitlines()
    ]
