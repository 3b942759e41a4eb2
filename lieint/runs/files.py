"""Safe file handling of runs: what may be replaced, and how new files appear.

* A run file carries a marker in its HDF5 user block (the first :data:`USER_BLOCK` bytes, which
  HDF5 leaves to the application): ``lieint run file`` and a format version. ``--overwrite``
  replaces only a regular file that carries it (or an older lieint run, recognised by its root
  attributes) — never a device, a directory, a FIFO, a symbolic link or somebody else's file,
  which are refused untouched (:func:`check_replaceable`).
* New files (the run file, the checkpoint) are first written under a fresh random name in the
  same directory, created exclusively (``O_CREAT | O_EXCL``, which never follows a symbolic
  link, even a dangling one), flushed to disk (``fsync``), and then renamed over their final name
  (atomic on POSIX) before the directory itself is fsynced (:func:`exclusive_temp`,
  :func:`publish`). A reader therefore sees the old file or the new one, never half of one, and a
  link planted at any name lieint uses cannot redirect a write.
"""

from __future__ import annotations

import os
import secrets
import stat
from pathlib import Path

from .errors import USER_BLOCK, StoreError, describe_kind

__all__ = [
    "MARKER",
    "USER_BLOCK",
    "check_replaceable",
    "describe_kind",
    "exclusive_temp",
    "fsync_dir",
    "has_marker",
    "publish",
    "remove_stale_temps",
    "write_marker",
]

MARKER = b"lieint run file\nformat 1\n"
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def _read_head(path: Path, size: int) -> bytes:
    """The first ``size`` bytes of a regular file, opened without following links or blocking."""
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return b""
        return os.pread(fd, size, 0)
    finally:
        os.close(fd)


def has_marker(path) -> bool:
    """True if ``path`` is a regular file starting with the lieint run marker."""
    try:
        return _read_head(Path(path), len(MARKER)) == MARKER
    except OSError:
        return False


def check_replaceable(path) -> None:
    """Refuse (with :class:`StoreError`) unless ``path`` is absent or a lieint run file.

    Only ``lstat`` and a read of the first bytes happen here: a refused path is left untouched.
    """
    path = Path(path)
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return
    except OSError as exc:
        raise StoreError(f"cannot inspect the output {str(path)!r}: {exc.strerror or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        raise StoreError(
            f"--overwrite refused: {str(path)!r} is {describe_kind(st)}, not a lieint run file; it was left "
            "untouched (choose another --out)"
        )
    if has_marker(path):
        return
    try:
        head = _read_head(path, 8)
    except OSError as exc:
        raise StoreError(f"cannot read the output {str(path)!r}: {exc.strerror or exc}") from None
    if head == _HDF5_SIGNATURE:
        # a run written before the marker existed: recognised by its root attributes, read safely
        from .reading import read_header

        header = read_header(path)
        if header.ok and "lieint_version" in header.attrs and "scene_fingerprint" in header.attrs:
            return
    raise StoreError(
        f"--overwrite refused: {str(path)!r} is not a lieint run file (no lieint marker or attributes); it was "
        "left untouched (remove it yourself or choose another --out)"
    )


def exclusive_temp(final: Path) -> Path:
    """A fresh name beside ``final`` for a file to be created with ``O_EXCL`` (e.g. h5py's ``"w-"``).

    The name is random, so a link planted at a predictable name is never met; and the exclusive
    create refuses any existing entry at this one.
    """
    final = Path(final)
    return final.with_name(f".{final.name}.{secrets.token_hex(8)}.tmp")


def write_marker(path: Path) -> None:
    """Write :data:`MARKER` into the user block of a file lieint has just created."""
    fd = os.open(path, os.O_WRONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
    try:
        os.pwrite(fd, MARKER, 0)
    finally:
        os.close(fd)


def fsync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def fsync_dir(directory: Path) -> None:
    """Make a rename in ``directory`` durable (ignored where directories cannot be fsynced)."""
    try:
        fd = os.open(directory, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def publish(tmp: Path, final: Path) -> None:
    """fsync ``tmp``, rename it over ``final`` atomically, fsync the directory."""
    fsync_file(tmp)
    os.replace(tmp, final)  # replaces a link at `final` itself, never the file it points to
    fsync_dir(Path(final).parent)


def remove_stale_temps(final) -> list[Path]:
    """Remove temporary files a killed writer of ``final`` left (``.NAME.<16 hex>.tmp`` beside it,
    for the run and its checkpoint); call with the run's lock held, so that none is in use.
    Links of that form are removed themselves, never what they point to."""
    import re

    final = Path(final)
    pattern = re.compile(rf"^\.{re.escape(final.name)}(\.checkpoint)?\.[0-9a-f]{{16}}\.tmp$")
    removed = []
    try:
        entries = list(os.scandir(final.parent))
    except OSError:
        return removed
    for entry in entries:
        if pattern.match(entry.name) and not entry.is_dir(follow_symlinks=False):
            discard(Path(entry.path))
            removed.append(Path(entry.path))
    return removed


def discard(tmp: Path) -> None:
    """Remove a temporary file of ours if it is still there."""
    try:
        os.unlink(tmp)
    except OSError:
        pass
