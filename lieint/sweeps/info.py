"""``lieint info SWEEP.zarr``: what state a sweep store is in, within seconds, on any input.

The answer is one of

* ``complete`` — every chunk committed and every file as committed;
* ``running`` — a live process holds the store's lock (pid, host, start time);
* ``interrupted`` (or ``failed``) with k of C chunks committed, ``resumable`` — the same
  ``lieint sweep … --resume`` computes the others;
* ``damaged`` — with where: the layout (an array's metadata or coordinates) or the committed
  chunks whose files are missing, truncated or changed (their SHA-256); a resume recomputes
  damaged chunks, a damaged layout needs ``--overwrite``;
* ``unreadable`` — not a directory, not a Zarr store, not a lieint sweep store;
* ``unchecked`` — intact as far as it was read, but not every chunk could be checked within
  the deadline (a larger ``--timeout`` checks them all).

Only plain reads of the store's files happen (:mod:`lieint.sweeps.integrity`), each checked
against the deadline, so the whole command ends within about ``timeout`` seconds.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from ..runs.info import EXIT_CODES, lock_holder
from ..text import printable
from .integrity import StoreError, read_root_metadata, verify_store

__all__ = ["SweepInfo", "inspect_sweep", "is_sweep_store"]


def is_sweep_store(path) -> bool:
    """True when ``path`` is a directory holding a ``zarr.json`` (what ``lieint info`` hands here)."""
    path = Path(path)
    return path.is_dir() and (path / "zarr.json").exists()


@dataclass
class SweepInfo:
    """The state of a sweep store (see the module docstring); ``lines`` is the report to print."""

    path: Path
    state: str  # complete | running | interrupted | failed | damaged | unreadable | unchecked
    resumable: bool = False
    lines: list[str] = field(default_factory=list)
    damaged: dict[int, list[str]] = field(default_factory=dict)

    @property
    def exit_code(self) -> int:
        """As for run files: 0 complete, 3 incomplete and intact, 1 damaged or unreadable,
        5 not every part checked within the deadline."""
        return EXIT_CODES[self.state]

    def text(self) -> str:
        return "\n".join(self.lines)


def inspect_sweep(path, timeout: float = 4.0) -> SweepInfo:
    """Inspect a sweep store within about ``timeout`` seconds (see the module docstring)."""
    import zarr

    path = Path(path)
    deadline = time.monotonic() + timeout
    shown = printable(str(path))
    try:
        attrs = read_root_metadata(path)["attributes"]
        root = zarr.open_group(str(path), mode="r", zarr_format=3, use_consolidated=False)
        plan = attrs["plan"]
        nchunks, nmembers = int(plan["nchunks"]), int(plan["nmembers"])
    except StoreError as exc:
        state = "damaged" if str(exc).startswith("damaged") else "unreadable"
        text = str(exc).removeprefix("damaged: ")
        return SweepInfo(path, state, lines=[f"{shown}: {state}: {printable(text)}"])
    except Exception as exc:
        return SweepInfo(path, "damaged", lines=[f"{shown}: damaged: cannot open it ({printable(type(exc).__name__)})"])
    keys = ", ".join(printable(k) for k in plan.get("keys") or []) or "-"
    lines = [
        shown,
        f"  sweep      {printable(str(attrs.get('title', '?')))}: {nmembers} members in {nchunks} chunks "
        f"(keys {keys}; ensemble {plan.get('ensemble', '?')})",
        f"  method     {printable(str((plan.get('options') or {}).get('method', '?')))}, "
        f"h = {(plan.get('options') or {}).get('h', '?')}",
        f"  written by lieint {printable(str(attrs.get('lieint_version', '?')))}",
    ]
    if plan.get("indicators"):
        lines.insert(-1, "  indicators " + ", ".join(printable(str(n)) for n in plan["indicators"]) + " per member")
    check = verify_store(path, root, attrs, nchunks, deadline=deadline)
    status = str(attrs.get("status", "?"))
    holder = lock_holder(path) if status == "running" else None
    committed = len(check.committed)
    if status == "complete" and check.flags_read and committed < nchunks:
        # every flag of a complete store was written: a flag that reads 0 has lost its file
        for c in sorted(set(range(nchunks)) - set(check.committed) - set(check.damaged))[:100]:
            check.damaged[c] = ["its commit flag is missing (the store was complete)"]
    if not check.flags_read and not check.damaged:
        line = f"  state      could not check within the deadline of {timeout:g} s (pass a longer --timeout)"
        return SweepInfo(path, "unchecked", False, [lines[0], line, *lines[1:]])
    if check.finished:
        lines.append(f"  checksums  {check.checked} committed chunks verified (SHA-256 of every file)")
    else:
        lines.append(
            f"  checksums  could not check within the deadline: {check.checked} of {committed} committed chunks "
            f"verified in {timeout:g} s (pass a longer --timeout to verify every chunk)"
        )
    resumable = False
    if check.damaged:
        state = "damaged"
        fix = (
            "its layout is damaged: run the sweep again with --overwrite"
            if check.layout_damaged
            else "the same lieint sweep … --resume recomputes these chunks"
        )
        head = f"damaged: {printable(check.describe())}; {fix}"
        resumable = not check.layout_damaged
    elif holder is not None:
        state = "running"
        head = (
            f"running: being written by process {holder.get('pid')} on host {printable(str(holder.get('host')))} "
            f"(started {printable(str(holder.get('started')))}); {committed} of {nchunks} chunks committed"
        )
    elif status == "complete" and committed == nchunks:
        state = "complete"
        head = f"complete: {nchunks} chunks, {nmembers} members"
    else:
        state = "failed" if status == "failed" else "interrupted"
        why = printable(str(attrs.get("message") or ""))
        word = {"failed": "failed", "no-space": "stopped (no space)"}.get(status, "interrupted")
        head = (
            f"{word}: {committed} of {nchunks} chunks committed; resumable: the same lieint sweep … --resume "
            "computes the others" + (f" (it ended with: {why})" if why else "")
        )
        resumable = True
    if not check.finished and state in ("complete", "interrupted", "failed"):
        head = f"could not check within the deadline; as far as checked: {head}"
        state = "unchecked"
    lines.insert(1, f"  state      {head}")
    return SweepInfo(path, state, resumable, lines, dict(check.damaged))
