"""What a sweep store's files must hold: SHA-256 digests written at commit, checked on reading.

A sweep store is a directory of small files (Zarr v3: a ``zarr.json`` per array and one file per
Zarr chunk). Every file lieint writes is recorded with its size and SHA-256:

* the layout (the arrays' ``zarr.json`` and the coordinates along ``member``) in the root
  attribute ``files_sha256`` (``{relative path: [size, hex]}``), when the arrays are created;
* each committed chunk's files (its piece of every member array and its rows of ``chunk_stats``
  and ``chunk_info``) in ``chunk_sha256[c]``, written before its ``chunk_committed`` flag.

:func:`verify_store` reads the files back with plain reads (never through a link, never
blocking on a FIFO) and names what is missing, truncated or changed, chunk by chunk, within a
deadline. A resumed sweep recomputes the damaged chunks; :func:`lieint.sweeps.open_sweep` refuses
to return them as data. :func:`check_replaceable` decides what ``--overwrite`` may remove.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import stat
import time
from dataclasses import dataclass, field
from pathlib import Path

from .plan import SweepError

__all__ = [
    "Verification",
    "check_replaceable",
    "digest_file",
    "read_root_metadata",
    "verify_store",
]

#: the root ``zarr.json`` of a store is read whole; one bigger than this is not ours
MAX_METADATA_BYTES = 256 << 20
#: zarr writes each file as ``NAME.<32 hex>.partial`` and renames it; a killed writer leaves some
_PARTIAL = re.compile(r"^.+\.[0-9a-f]{32}\.partial$")


class StoreError(SweepError):
    """A sweep store that cannot be written, replaced or resumed; the message says why."""


class DamagedStoreError(StoreError):
    """Committed chunks of a store fail their checksums (they are named in the message)."""


def _open_regular(path: Path) -> int:
    """A descriptor of the regular file ``path``; never through a link, never a FIFO's wait."""
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        os.close(fd)
        from ..runs.files import describe_kind

        raise OSError(f"it is {describe_kind(st)}, not a file lieint wrote")
    return fd


def digest_file(path: Path, limit: int | None = None) -> tuple[int, str]:
    """``(size, SHA-256 hex)`` of a regular file (read at most ``limit`` + 1 bytes)."""
    fd = _open_regular(path)
    try:
        h, size = hashlib.sha256(), 0
        while True:
            block = os.read(fd, 1 << 20)
            if not block:
                break
            size += len(block)
            h.update(block)
            if limit is not None and size > limit:
                break
        return size, h.hexdigest()
    finally:
        os.close(fd)


def check_file(root: Path, relative: str, expected) -> str | None:
    """None if the file holds what was committed, else what is wrong with it (a phrase)."""
    try:
        size, hexdigest = int(expected[0]), str(expected[1])
    except (TypeError, ValueError, IndexError):
        return "its recorded checksum is unreadable"
    try:
        got_size, got = digest_file(root / relative, limit=size)
    except FileNotFoundError:
        return "its file is missing"
    except OSError as exc:
        return f"its file cannot be read ({exc.strerror or exc})"
    if got_size < size:
        return f"its file is truncated ({got_size} of {size} bytes)"
    if got_size > size:
        return f"its file is longer than committed (more than {size} bytes)"
    if got != hexdigest:
        return "its file fails its SHA-256 (changed bytes)"
    return None


def read_root_metadata(path: Path) -> dict:
    """The root ``zarr.json`` of a store, checked to be a Zarr v3 group; raises
    :class:`StoreError` saying why it is not readable."""
    meta = Path(path) / "zarr.json"
    try:
        fd = _open_regular(meta)
    except FileNotFoundError:
        raise StoreError(f"{str(path)!r} is not a lieint sweep store (it has no zarr.json)") from None
    except OSError as exc:
        raise StoreError(f"cannot read {str(meta)!r}: {exc.strerror or exc}") from None
    try:
        data = os.read(fd, MAX_METADATA_BYTES + 1)
    finally:
        os.close(fd)
    if len(data) > MAX_METADATA_BYTES:
        raise StoreError(
            f"{str(path)!r} is not a lieint sweep store (its zarr.json is over {MAX_METADATA_BYTES >> 20} MiB)"
        )
    try:
        doc = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise StoreError(f"damaged: the store's root metadata {str(meta)!r} is not valid JSON ({exc})") from None
    if not isinstance(doc, dict) or doc.get("zarr_format") != 3 or doc.get("node_type") != "group":
        raise StoreError(f"{str(path)!r} is not a lieint sweep store (its zarr.json is not a Zarr v3 group)")
    attrs = doc.get("attributes")
    if not isinstance(attrs, dict) or attrs.get("lieint_sweep") != 1:
        raise StoreError(f"{str(path)!r} is not a lieint sweep store (no 'lieint_sweep' attribute)")
    return doc


def check_replaceable(path) -> None:
    """Refuse (:class:`StoreError`) unless ``path`` is absent or a lieint sweep store: a real
    directory (not a link) whose root ``zarr.json`` carries the ``lieint_sweep`` attribute and
    which holds nothing but the arrays lieint wrote. Only ``lstat``, a directory listing and a
    read of the root ``zarr.json`` happen here: a refused path is left untouched."""
    from ..runs.files import describe_kind

    path = Path(path)
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return
    except OSError as exc:
        raise StoreError(f"cannot inspect the output {str(path)!r}: {exc.strerror or exc}") from None
    refused = f"--overwrite refused: {str(path)!r}"
    if not stat.S_ISDIR(st.st_mode):
        raise StoreError(
            f"{refused} is {describe_kind(st)}, not a lieint sweep store; it was left untouched (choose another --out)"
        )
    try:
        attrs = read_root_metadata(path)["attributes"]
    except StoreError as exc:
        raise StoreError(
            f"--overwrite refused: {exc}; it was left untouched (remove it yourself or choose another --out)"
        ) from None
    ours = attrs.get("arrays")  # absent in a store of an older lieint: its arrays are the directories with zarr.json
    try:
        entries = list(os.scandir(path))
    except OSError as exc:
        raise StoreError(f"cannot list {str(path)!r}: {exc.strerror or exc}") from None
    foreign = []
    for entry in entries:
        if entry.name == "zarr.json" or (_PARTIAL.match(entry.name) and entry.is_file(follow_symlinks=False)):
            continue
        if entry.is_dir(follow_symlinks=False) and (
            entry.name in ours if ours is not None else os.path.isfile(os.path.join(entry.path, "zarr.json"))
        ):
            continue
        foreign.append(entry.name + ("/" if entry.is_dir(follow_symlinks=False) else ""))
    if foreign:
        shown = ", ".join(repr(n) for n in sorted(foreign)[:5]) + (" …" if len(foreign) > 5 else "")
        raise StoreError(
            f"{refused} holds entries lieint did not write ({shown}); it was left untouched (move them away, or "
            "choose another --out)"
        )


@dataclass
class Verification:
    """What :func:`verify_store` found.

    Attributes
    ----------
    committed : list of int
        The chunks flagged committed (whose flag could be read).
    damaged : dict
        ``{chunk: [phrase, ...]}``: committed chunks whose files are not what was committed
        (chunk ``-1``: the layout, i.e. an array's metadata or the coordinates).
    unreadable_flags : list of int
        Chunks whose commit flag cannot be read (they count as not committed).
    checked : int
        Committed chunks verified.
    finished : bool
        False when the deadline came first (the chunks after ``checked`` were not looked at).
    flags_read : bool
        Whether the commit flags were read (not when the layout is damaged or the deadline
        came while the layout was being checked).
    """

    committed: list[int] = field(default_factory=list)
    damaged: dict[int, list[str]] = field(default_factory=dict)
    unreadable_flags: list[int] = field(default_factory=list)
    checked: int = 0
    finished: bool = True
    flags_read: bool = False

    @property
    def layout_damaged(self) -> bool:
        return -1 in self.damaged

    def good(self) -> list[int]:
        """The committed chunks verified intact."""
        return [c for c in self.committed if c not in self.damaged]

    def describe(self, limit: int = 5) -> str:
        """The damage in words: ``"chunk 3: state_A: its file is missing; …"``."""
        parts = []
        for c in sorted(self.damaged)[:limit]:
            where = "the layout" if c < 0 else f"chunk {c}"
            parts.append(f"{where}: " + "; ".join(self.damaged[c][:3]))
        more = len(self.damaged) - limit
        return "; ".join(parts) + (f" (and {more} more chunks)" if more > 0 else "")


def _read_flags(root, nchunks: int) -> tuple[list[int], list[int]]:
    """(committed chunks, chunks whose flag is unreadable): one read of the whole array, and
    chunk by chunk only when that fails (a damaged flag file)."""
    import numpy as np

    arr = root["chunk_committed"]
    try:
        flags = np.asarray(arr[...])
        return np.flatnonzero(flags == 1).tolist(), []
    except Exception:
        committed, unreadable = [], []
        for c in range(nchunks):
            try:
                if int(arr[c]) == 1:
                    committed.append(c)
            except Exception:
                unreadable.append(c)
        return committed, unreadable


def _read_digests(root, chunks: list[int]) -> dict[int, object]:
    """``{chunk: {relative path: [size, hex]} or an error phrase}``."""
    import numpy as np

    arr = root["chunk_sha256"]
    out: dict[int, object] = {}
    try:
        values = np.asarray(arr[...])
        raw = {c: values[c] for c in chunks}
    except Exception:
        raw = {}
        for c in chunks:
            try:
                raw[c] = arr[c]
            except Exception:
                out[c] = "its checksum record cannot be read"
    for c, text in raw.items():
        try:
            record = json.loads(str(text))
            if not isinstance(record, dict) or not record:
                raise ValueError
            out[c] = record
        except ValueError:
            out[c] = "its checksum record is missing or unreadable"
    return out


def verify_store(path, root, attrs: dict, nchunks: int, deadline: float | None = None) -> Verification:
    """Check the layout and every committed chunk of the store against their SHA-256 digests.

    Parameters
    ----------
    path : path
        The store's directory.
    root : zarr.Group
        The store opened (read-only is enough).
    attrs : dict
        Its root attributes.
    nchunks : int
        Chunks of its plan.
    deadline : float, optional
        ``time.monotonic()`` by which to stop (the result then says ``finished=False``).
    """
    path = Path(path)
    result = Verification()
    layout = attrs.get("files_sha256") or {}
    for relative, expected in sorted(layout.items()):
        if deadline is not None and time.monotonic() > deadline:
            result.finished = False
            return result
        problem = check_file(path, relative, expected)
        if problem:
            result.damaged.setdefault(-1, []).append(f"{relative}: {problem}")
    if result.layout_damaged:
        return result  # the arrays themselves cannot be trusted: their chunks are not looked at
    try:
        result.committed, result.unreadable_flags = _read_flags(root, nchunks)
    except Exception as exc:  # an array the layout does not record (a store of an older lieint)
        result.damaged[-1] = [f"chunk_committed: cannot be read ({type(exc).__name__}: {exc})"]
        return result
    result.flags_read = True
    for c in result.unreadable_flags:
        result.damaged.setdefault(c, []).append("its commit flag cannot be read")
    digests = _read_digests(root, result.committed)
    for c in result.committed:
        if deadline is not None and time.monotonic() > deadline:
            result.finished = False
            break
        record = digests.get(c)
        if isinstance(record, str):
            result.damaged.setdefault(c, []).append(record)
        else:
            for relative, expected in sorted(record.items()):
                problem = check_file(path, relative, expected)
                if problem:
                    result.damaged.setdefault(c, []).append(f"{relative.split('/', 1)[0]}: {problem}")
        result.checked += 1
    return result
