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
* ``unreadable`` — not a file, not HDF5, not a lieint run.

Every HDF5 read happens in a child process with a deadline (:mod:`lieint.runs.reading`), so a
file crafted to make the HDF5 library loop is reported, not waited for.
"""

from __future__ import annotations

import json
import os
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path

from .reading import Header, isolated, read_header, verify_series

__all__ = ["RunInfo", "inspect_run"]


@dataclass
class RunInfo:
    """The state of a run file (see the module docstring); ``lines`` is the report to print."""

    path: Path
    state: str  # "complete" | "running" | "interrupted" | "stopped" | "failed" | "damaged" | "unreadable"
    resumable: bool = False
    lines: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)

    @property
    def exit_code(self) -> int:
        """0 complete and intact, 3 incomplete (running, interrupted, stopped, failed) and intact,
        1 damaged or unreadable."""
        if self.state in ("damaged", "unreadable") or self.problems:
            return 1
        return 0 if self.state == "complete" else 3

    def text(self) -> str:
        return "\n".join(self.lines)


def _holder(path: Path) -> dict | None:
    """The live holder of the run's lock on this host, read from ``RUN.h5.lock`` (never locked
    here: taking the lock, even briefly, could refuse a writer that is starting)."""
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
    try:
        messages, finished = isolated(_checkpoint_child, (str(ckpt),), timeout)
    except Exception as exc:
        return {"error": f"unreadable ({exc})"}
    if not finished or not messages:
        return {"error": f"reading it did not finish within {timeout:g} s"}
    return messages[0]


def inspect_run(path, timeout: float = 4.0) -> RunInfo:
    """Inspect a run file within about ``timeout`` seconds (see the module docstring)."""
    from .. import __version__
    from .store import attrs_digest

    path = Path(path)
    start = time.monotonic()
    header: Header = read_header(path, timeout=min(timeout, 3.0))
    if not header.ok:
        state = "damaged" if header.problem.startswith(("damaged", "truncated")) else "unreadable"
        return RunInfo(path, state, lines=[f"{path}: {state}: {header.problem}"], problems=[header.problem])
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
    lines = [
        f"{path}",
        f"  scene      {attrs.get('scene_name', '?')} (fingerprint {str(attrs.get('scene_fingerprint', '?'))[:12]}…)",
        f"  method     {attrs.get('method', '?')}, h = {attrs.get('h', '?')}, "
        f"save_every = {attrs.get('save_every', '?')}, back end {attrs.get('backend', '?')}",
        f"  written by lieint {attrs.get('lieint_version', '?')}",
        f"  rows       {rows}",
    ]

    # every chunk read once: its Fletcher-32 checksum is verified by HDF5
    budget = max(0.5, timeout - (time.monotonic() - start))
    damaged, verified, finished = verify_series(path, header, budget)
    for name, r0, r1, error in damaged:
        where = f"/{name} rows {r0}–{r1 - 1}" if r1 > r0 else f"{name}"
        problems.append(f"{where}: {error}")
    if finished:
        lines.append("  checksums  every chunk verified (Fletcher-32)")
    else:
        done = sum(verified.values())
        lines.append(
            f"  checksums  not all verified within {timeout:g} s ({done} dataset rows verified; "
            "pass a longer --timeout to verify every chunk)"
        )

    holder = _holder(path) if status == "running" else None
    resumable = False
    if status == "complete":
        state = "complete"
        head = f"complete: {attrs.get('steps_done', '?')}{of_n} steps, {rows} rows"
    elif holder is not None:
        state = "running"
        head = (
            f"running: being written by process {holder.get('pid')} on host {holder.get('host')} "
            f"(started {holder.get('started')}); {rows} rows so far"
        )
    else:
        state = status if status in ("interrupted", "stopped", "failed") else "interrupted"
        ckpt = _checkpoint(path, min(3.0, max(0.5, timeout - (time.monotonic() - start))))
        if ckpt.get("missing"):
            k = attrs.get("steps_done", "?")
            why = "no checkpoint (RUN.h5.checkpoint) beside it"
            if status == "failed":
                why = "the run failed (a non-finite state); resuming would fail again"
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
        word = {"stopped": "stopped (--max-drift)", "failed": "failed"}.get(state, "interrupted")
        head = f"{word} at step {k}{of_n}; " + (
            "resumable: lieint run SCENE --out RUN.h5 --resume" if resumable else f"not resumable: {why}"
        )
    if problems:
        state = "damaged"
        head = "damaged: " + "; ".join(problems[:5]) + (f" (and {len(problems) - 5} more)" if len(problems) > 5 else "")
        resumable = resumable and not damaged
    lines.insert(1, f"  state      {head}")
    return RunInfo(path, state, resumable, lines, problems)
