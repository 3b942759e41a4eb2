"""Reading run files that may be truncated, damaged or still being written — without hanging.

Two layers keep every read bounded in time:

1. :func:`read_superblock` parses the HDF5 superblock with plain file reads before HDF5 sees the
   file: the signature (at byte 0 or after a user block), the version, the checksum of version 2/3
   superblocks (Jenkins' lookup3, as HDF5 computes it) and the end-of-file address against the
   file's real size. A truncated file or a flipped superblock byte is reported with where it is.
2. Everything that opens the file with HDF5 runs in a child process with a deadline
   (:func:`isolated`): a corrupted metadata block can make the HDF5 library retry or loop (an
   SWMR reader retries checksum failures with growing pauses), and a child can be killed where a
   thread cannot. The child never writes and exits without running the parent's exit handlers.

:func:`read_header` (attributes and dataset shapes), :func:`read_series` (strided rows for
plots) and :func:`verify_series` (every chunk's Fletcher-32 checksum) build on these.
"""

from __future__ import annotations

import os
import stat
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = [
    "Header",
    "IsolatedError",
    "Superblock",
    "isolated",
    "read_header",
    "read_series",
    "read_superblock",
    "verify_series",
]

_SIGNATURE = b"\x89HDF\r\n\x1a\n"
HEADER_SECONDS = 3.0  # deadline of an isolated open + header read (a healthy file takes ~0.1 s)


class IsolatedError(RuntimeError):
    """An isolated read failed (``timed_out`` when it was killed at its deadline)."""

    def __init__(self, message: str, timed_out: bool = False):
        super().__init__(message)
        self.timed_out = timed_out


@dataclass
class Superblock:
    """What the superblock says (addresses are absolute byte offsets in the file)."""

    offset: int  # where the superblock starts (after the user block)
    version: int
    eof: int  # end of the file's data as the superblock records it
    size: int  # actual size of the file
    flags: int  # nonzero: the file was open for writing (a live writer, or one that was killed)


def _lookup3(data: bytes) -> int:
    from .superblock import lookup3

    return lookup3(data)


def read_superblock(path) -> tuple[Superblock | None, str | None]:
    """Parse and check the HDF5 superblock of ``path`` without the HDF5 library.

    Returns ``(superblock, None)``, or ``(None, problem)`` with a sentence saying what is wrong
    and where (e.g. ``"truncated: the file is 40 960 bytes but its superblock records 81 920"``).
    """
    path = Path(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except FileNotFoundError:
        return None, f"no such file {str(path)!r}"
    except OSError as exc:
        return None, f"cannot open {str(path)!r}: {exc.strerror or exc}"
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            from .errors import describe_kind

            return None, f"{str(path)!r} is {describe_kind(st)}, not a run file"
        size = st.st_size
        offset = 0
        head = b""
        while offset == 0 or offset < size:  # the signature sits at 0, 512, 1024, 2048, ...
            head = os.pread(fd, 128, offset)
            if head[:8] == _SIGNATURE:
                break
            offset = 512 if offset == 0 else 2 * offset
        else:
            return None, f"{str(path)!r} is not an HDF5 file (no HDF5 signature; {size} bytes)"
    finally:
        os.close(fd)
    where = f"the superblock at byte {offset}"
    if len(head) < 12:
        return None, f"truncated: the file ends inside {where} ({size} bytes)"
    version = head[8]
    if version in (2, 3):
        so = head[9]
        if so not in (2, 4, 8) or head[10] not in (2, 4, 8):
            return None, f"damaged: {where} has invalid address sizes ({so}, {head[10]})"
        end = 12 + 4 * so
        if len(head) < end + 4:
            return None, f"truncated: the file ends inside {where}"
        stored = int.from_bytes(head[end : end + 4], "little")
        if _lookup3(head[:end]) != stored:
            return None, f"damaged: {where} fails its checksum (a changed byte in bytes {offset}–{offset + end + 3})"
        base = int.from_bytes(head[12 : 12 + so], "little")
        eof = int.from_bytes(head[12 + 2 * so : 12 + 3 * so], "little")
        flags = head[11]
    elif version in (0, 1):
        so = head[13]
        if so not in (2, 4, 8):
            return None, f"damaged: {where} has an invalid address size ({so})"
        start = 24 if version == 0 else 28
        base = int.from_bytes(head[start : start + so], "little")
        eof = int.from_bytes(head[start + 2 * so : start + 3 * so], "little")
        flags = int.from_bytes(head[20:24], "little")
    else:
        return None, f"damaged: {where} has an unknown version {version}"
    # HDF5 compares the stored end-of-file address with (base address + size of the data), i.e.
    # it is an offset from the start of the file, user block included
    del base
    physical_eof = eof
    if physical_eof > size:
        return None, (
            f"truncated: the file is {size} bytes but its superblock (byte {offset}) records data up to byte "
            f"{physical_eof}"
        )
    return Superblock(offset, version, physical_eof, size, flags), None


# -- isolation -------------------------------------------------------------------------------------


def _child(conn, target, args):  # pragma: no cover - runs in the child process
    try:
        target(lambda value: conn.send(("message", value)), *args)
        conn.send(("done", None))
    except BaseException as exc:  # everything goes back to the parent as text
        try:
            conn.send(("error", f"{type(exc).__name__}: {exc}"))
        except Exception:
            pass
    finally:
        conn.close()


def isolated(target, args: tuple, timeout: float) -> tuple[list, bool]:
    """Run ``target(send, *args)`` in a child process for at most ``timeout`` seconds.

    Returns the values the child sent with ``send`` and whether it finished; a child still
    running at the deadline is killed (what it sent until then is kept). A child that raised
    gives :class:`IsolatedError` with its message.
    """
    import multiprocessing as mp

    method = "fork" if "fork" in mp.get_all_start_methods() else "spawn"
    ctx = mp.get_context(method)
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(child, target, args), daemon=True)
    proc.start()
    child.close()
    deadline = time.monotonic() + timeout
    messages, finished = [], False
    try:
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0 or not parent.poll(remaining):
                break
            try:
                kind, value = parent.recv()
            except EOFError:
                raise IsolatedError("the reading process ended without an answer (it crashed)") from None
            if kind == "done":
                finished = True
                break
            if kind == "error":
                raise IsolatedError(value)
            messages.append(value)
    finally:
        parent.close()
        if proc.is_alive():
            proc.kill()
        proc.join()
    return messages, finished


def _open(path: str, swmr: bool):
    import h5py

    return h5py.File(path, "r", swmr=True) if swmr else h5py.File(path, "r")


def _plain(value):
    if isinstance(value, bytes):
        return value.decode(errors="replace")
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


def _series_names(f) -> list[str]:
    names = ["t"] if "t" in f else []
    for group in ("states", "invariants", "outputs"):
        if group in f:
            names += [f"{group}/{k}" for k in f[group]]
    return names


def _header_child(send, path: str, swmr: bool):  # pragma: no cover - runs in the child process
    with _open(path, swmr) as f:
        attrs = {k: _plain(v) for k, v in f.attrs.items()}
        datasets = {}
        for name in _series_names(f):
            ds = f[name]
            datasets[name] = {
                "shape": tuple(ds.shape),
                "chunks": tuple(ds.chunks) if ds.chunks else None,
                "fletcher32": bool(ds.fletcher32),
                "attrs": {k: _plain(v) for k, v in ds.attrs.items() if k in ("kind", "trailing_ndim")},
            }
        send({"attrs": attrs, "datasets": datasets})


@dataclass
class Header:
    """Attributes and dataset layout of a run file, or the problem that prevented reading them."""

    path: Path
    ok: bool
    problem: str = ""
    superblock: Superblock | None = None
    attrs: dict = field(default_factory=dict)
    datasets: dict = field(default_factory=dict)
    #: True when the problem is only that the deadline came first (not damage)
    timed_out: bool = False

    @property
    def rows(self) -> int:
        """Rows present in every series (they can differ by one segment after a kill)."""
        return min((d["shape"][0] for d in self.datasets.values()), default=0)


def read_header(path, timeout: float = HEADER_SECONDS) -> Header:
    """Superblock check, then the attributes and dataset shapes read in an isolated process."""
    path = Path(path)
    sb, problem = read_superblock(path)
    if sb is None:
        return Header(path, False, problem)
    if timeout <= 0:
        return Header(path, False, "no time was left to read it", sb, timed_out=True)
    try:
        messages, finished = isolated(_header_child, (str(path), sb.flags != 0), timeout)
    except IsolatedError as exc:
        return Header(path, False, f"damaged: HDF5 cannot read it ({_short(str(exc))})", sb)
    if not finished or not messages:
        # slow is not damaged: a machine under heavy load can take this long on a good file
        problem = f"reading its metadata did not finish within {timeout:.3g} s"
        return Header(path, False, problem, sb, timed_out=True)
    return Header(path, True, "", sb, messages[0]["attrs"], messages[0]["datasets"])


def _short(text: str, limit: int = 300) -> str:
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _series_child(send, path: str, swmr: bool, max_points: int):  # pragma: no cover - child process
    with _open(path, swmr) as f:
        rows = min(f[name].shape[0] for name in _series_names(f))
        stride = max(1, rows // max_points)
        out = {}
        for name in _series_names(f):
            out[name] = f[name][0:rows:stride]
        send(out)


def read_series(path, max_points: int, timeout: float = 10.0, header: Header | None = None) -> dict[str, np.ndarray]:
    """Every series of the file, rows taken with a stride so that at most ~``max_points`` remain.

    Raises :class:`IsolatedError` when HDF5 cannot read them (a damaged chunk fails its checksum)
    or they are not read within ``timeout`` seconds.
    """
    header = header or read_header(path)
    if not header.ok:
        raise IsolatedError(header.problem)
    messages, finished = isolated(_series_child, (str(path), header.superblock.flags != 0, max_points), timeout)
    if not finished:
        raise IsolatedError(f"reading the rows did not finish within {timeout:g} s", timed_out=True)
    return messages[0]


def _verify_child(send, path: str, swmr: bool, block_chunks: int):  # pragma: no cover - child process
    with _open(path, swmr) as f:
        for name in _series_names(f):
            ds = f[name]
            n = ds.shape[0]
            chunk = ds.chunks[0] if ds.chunks else max(n, 1)
            step = chunk * block_chunks
            for r0 in range(0, n, step):
                r1 = min(n, r0 + step)
                try:
                    ds[r0:r1]
                except OSError:
                    # narrow the damage down to its chunks
                    for c0 in range(r0, r1, chunk):
                        c1 = min(r1, c0 + chunk)
                        try:
                            ds[c0:c1]
                        except OSError as exc:
                            send(("damaged", name, c0, c1, _short(str(exc), 160)))
                send(("verified", name, r1))


def verify_series(path, header: Header, budget: float) -> tuple[list, dict[str, int], bool]:
    """Read every chunk (checking its Fletcher-32 checksum) within ``budget`` seconds.

    Returns the damaged chunks ``(dataset, first_row, end_row, error)``, how many rows of each
    dataset were verified, and whether everything was verified in time.
    """
    try:
        messages, finished = isolated(_verify_child, (str(path), header.superblock.flags != 0, 16), budget)
    except IsolatedError as exc:
        return [("(file)", 0, 0, _short(str(exc)))], {}, False
    damaged = [m[1:] for m in messages if m[0] == "damaged"]
    verified: dict[str, int] = {}
    for m in messages:
        if m[0] == "verified":
            verified[m[1]] = m[2]
    return damaged, verified, finished
