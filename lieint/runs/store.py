"""Plain-data storage of a run: the HDF5 output and the atomic checkpoint beside it.

Output ``RUN.h5`` (opened in SWMR mode while writing, so a crash leaves it readable with
``h5py.File(path, "r", swmr=True)``; a completed or resumed file opens with plain ``h5py.File(path)``):

* a 512-byte user block that starts with the marker ``lieint run file`` (:mod:`lieint.runs.files`);

* ``/t`` (m,) saved times, a dimension scale; ``/states/<field>`` (m, *batch, *shape);
  ``/invariants/<name>`` and ``/outputs/<name>`` likewise; every axis is a labelled
  dimension so that ``xarray.open_dataset(path, engine="h5netcdf", group="states")`` works;
* root attributes: ``lieint_version``, ``scene`` (its TOML text or JSON), ``scene_fingerprint``,
  ``method``, ``h``, ``nsteps``, ``steps_done``, ``status``, and ``attrs_sha256``, the SHA-256 of all
  the others (:func:`attrs_digest`);
* every series is chunked with HDF5's Fletcher-32 checksum filter, so a changed byte in a
  committed row is detected when it is read (``lieint info RUN.h5`` reads them all).

Checkpoint ``RUN.h5.checkpoint`` (HDF5, written to a temporary file, fsynced, then renamed
over the old one, so it is always either the old or the new checkpoint): the engine's internal
arrays, the step reached, the rows written, the counters, and ``sha256`` of all of them, checked
when it is read. Nothing is ever pickled.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import stat
from pathlib import Path

import numpy as np

__all__ = ["Checkpoint", "NoSpaceError", "OutputFile", "StoreError", "attrs_digest"]


#: bytes before the HDF5 superblock, left to the application: the run marker goes there
USER_BLOCK = 512


class StoreError(ValueError):
    """An output or checkpoint that cannot be used; the message says which and why."""


class NoSpaceError(StoreError):
    """The disk is full or the file-size limit (``ulimit -f``) was reached while writing."""


#: errno values of a full disk, an exceeded file-size limit or quota
_NO_SPACE = {errno.ENOSPC, errno.EFBIG, errno.EDQUOT}
_NO_SPACE_WORDS = ("no space left", "file too large", "disk quota", "errno = 28", "errno = 27", "errno = 122")


def is_no_space(exc: BaseException) -> bool:
    """True for an OSError of a full disk or file-size limit (h5py's errors carry it in the text)."""
    if getattr(exc, "errno", None) in _NO_SPACE:
        return True
    text = str(exc).lower()
    return any(w in text for w in _NO_SPACE_WORDS)


def _plain_attr(value):
    if isinstance(value, bytes):
        return value.decode(errors="replace")
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


def attrs_digest(attrs) -> str:
    """SHA-256 of a file's attributes (every one but ``attrs_sha256`` itself), in a canonical JSON form."""
    plain = {k: _plain_attr(v) for k, v in attrs.items() if k not in ("attrs_sha256", "sha256")}
    return hashlib.sha256(json.dumps(plain, sort_keys=True, default=repr).encode()).hexdigest()


def _arrays_digest(arrays: dict, attrs: dict) -> str:
    h = hashlib.sha256(attrs_digest(attrs).encode())
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}:{a.dtype.str}:{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _regular_or_absent(path: Path, what: str) -> None:
    """Refuse a symbolic link or a non-regular file where lieint reads or writes its own file."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return
    if not stat.S_ISREG(st.st_mode):
        from .files import describe_kind

        raise StoreError(f"the {what} {str(path)!r} is {describe_kind(st)}, not a regular file; refusing to use it")


def _h5py():
    import h5py

    return h5py


class OutputFile:
    """Append-only writer of the saved series (rows along the first axis)."""

    def __init__(self, path, handle):
        self.path = Path(path)
        self.f = handle

    # -- creation and reopening ------------------------------------------------------------
    @classmethod
    def create(
        cls,
        path,
        attrs: dict,
        first_rows: dict[str, dict[str, np.ndarray]],
        t0: float,
        dataset_attrs: dict[tuple[str, str], dict] | None = None,
    ) -> OutputFile:
        """A new output with its first row; ``dataset_attrs[(group, name)]`` are attributes of a
        dataset (what it holds, e.g. ``kind = "defect"`` and ``trailing_ndim``, for readers)."""
        from .files import discard, exclusive_temp, publish, write_marker

        h5py = _h5py()
        path = Path(path)
        tmp = exclusive_temp(path)
        try:
            # "w-" creates exclusively (O_CREAT | O_EXCL): never through a link, never over a file
            f = h5py.File(tmp, "w-", libver="latest", userblock_size=USER_BLOCK)
        except OSError as exc:
            raise StoreError(f"cannot create the output file {str(path)!r}: {_reason(exc)}") from None
        try:
            try:
                for key, value in attrs.items():
                    f.attrs[key] = value
                t = f.create_dataset(
                    "t", data=np.array([t0]), maxshape=(None,), chunks=(4096,), dtype="f8", fletcher32=True
                )
                t.make_scale("t")
                for group, arrays in first_rows.items():
                    g = f.create_group(group)
                    for name, row in arrays.items():
                        row = np.asarray(row, dtype=float)
                        chunk_rows = max(1, min(4096, (1 << 20) // max(row.nbytes, 1)))
                        ds = g.create_dataset(
                            name,
                            data=row[None],
                            maxshape=(None,) + row.shape,
                            chunks=(chunk_rows,) + row.shape,
                            dtype="f8",
                            fletcher32=True,  # each chunk checksummed: a changed byte is detected
                        )
                        cls._label(f, ds, group, name)
                        for key, value in (dataset_attrs or {}).get((group, name), {}).items():
                            ds.attrs[key] = value
                f.attrs["attrs_sha256"] = attrs_digest(f.attrs)
            finally:
                f.close()
            write_marker(tmp)
            publish(tmp, path)  # fsync, atomic rename over the old run, fsync of the directory
        except OSError as exc:
            discard(tmp)
            if is_no_space(exc):
                raise NoSpaceError(f"no room to create the output file {str(path)!r}: {_reason(exc)}") from None
            raise StoreError(f"cannot create the output file {str(path)!r}: {_reason(exc)}") from None
        except BaseException:
            discard(tmp)
            raise
        return cls._open_for_append(path, None)

    @staticmethod
    def _label(f, ds, group: str, name: str) -> None:
        """Attach a dimension scale to every axis (netCDF/xarray need all or none labelled)."""
        ds.dims[0].attach_scale(f["t"])
        for axis in range(1, ds.ndim):
            dim = f"{group}_{name}_{axis}"
            if dim not in f:
                scale = f.create_dataset(dim, data=np.arange(ds.shape[axis]), dtype="i8")
                scale.make_scale(dim)
            ds.dims[axis].attach_scale(f[dim])

    @classmethod
    def reopen(cls, path, rows: int) -> OutputFile:
        """Open an existing output for appending, truncated to ``rows`` rows (the checkpoint's)."""
        _regular_or_absent(Path(path), "output file")
        _clear_crash_flags(path)
        return cls._open_for_append(path, rows)

    @classmethod
    def _open_for_append(cls, path, rows: int | None) -> OutputFile:
        h5py = _h5py()
        try:
            f = h5py.File(path, "r+", libver="latest")
        except OSError as exc:
            raise StoreError(
                f"cannot reopen the output file {str(path)!r} to resume (corrupt or unreadable): {exc}"
            ) from None
        try:
            if rows is not None:
                have = min(ds.shape[0] for ds in cls._series(f))
                if have < rows:
                    raise StoreError(
                        f"the output file {str(path)!r} has {have} saved rows but its checkpoint "
                        f"records {rows}: the file was truncated or replaced; start anew with --overwrite"
                    )
                for ds in cls._series(f):
                    ds.resize((rows,) + ds.shape[1:])
            f.swmr_mode = True
            f.flush()
        except KeyError as exc:
            f.close()
            raise StoreError(f"the output file {str(path)!r} is not a lieint run (missing {exc})") from None
        except Exception:
            f.close()
            raise
        return cls(path, f)

    @staticmethod
    def _series(f):
        yield f["t"]
        for group in ("states", "invariants", "outputs"):
            if group in f:
                yield from f[group].values()

    # -- appending ---------------------------------------------------------------------------
    @property
    def rows(self) -> int:
        return self.f["t"].shape[0]

    def append(self, t: np.ndarray, groups: dict[str, dict[str, np.ndarray]]) -> None:
        m = len(t)
        if m == 0:
            return
        n = self.rows
        try:
            ds = self.f["t"]
            ds.resize((n + m,))
            ds[n:] = t
            for group, arrays in groups.items():
                for name, values in arrays.items():
                    ds = self.f[group][name]
                    ds.resize((n + m,) + ds.shape[1:])
                    ds[n:] = values
            self.f.flush()
        except OSError as exc:
            if is_no_space(exc):
                raise NoSpaceError(f"writing to {str(self.path)!r} failed: {_reason(exc)}") from None
            raise StoreError(
                f"writing to {str(self.path)!r} failed ({exc}); the rows written before, and the "
                "last checkpoint, are intact: free space and resume with --resume"
            ) from None

    def set_attrs(self, **attrs) -> None:
        try:
            for key, value in attrs.items():
                self.f.attrs[key] = value
            self.f.attrs["attrs_sha256"] = attrs_digest(self.f.attrs)
            self.f.flush()
        except OSError as exc:
            if is_no_space(exc):
                raise NoSpaceError(f"writing to {str(self.path)!r} failed: {_reason(exc)}") from None
            raise StoreError(f"writing the attributes of {str(self.path)!r} failed: {_reason(exc)}") from None

    def abandon(self) -> None:
        """Drop the handle after a failed write without flushing again (the file stays as the
        last successful flush left it; resuming truncates it to the checkpoint's rows)."""
        try:
            if self.f.id.valid:
                self.f.close()
        except Exception:  # a second failure of the same full disk: nothing more to save here
            pass

    def close(self) -> None:
        if self.f.id.valid:
            self.f.close()


def _lookup3(data: bytes, initval: int = 0) -> int:
    """Bob Jenkins' lookup3 ``hashlittle``: the checksum HDF5 puts on its superblock."""
    M = 0xFFFFFFFF

    def rot(x, k):
        return ((x << k) | (x >> (32 - k))) & M

    length = len(data)
    a = b = c = (0xDEADBEEF + length + initval) & M
    i = 0
    while length > 12:
        a = (a + int.from_bytes(data[i : i + 4], "little")) & M
        b = (b + int.from_bytes(data[i + 4 : i + 8], "little")) & M
        c = (c + int.from_bytes(data[i + 8 : i + 12], "little")) & M
        a = ((a - c) & M) ^ rot(c, 4)
        c = (c + b) & M
        b = ((b - a) & M) ^ rot(a, 6)
        a = (a + c) & M
        c = ((c - b) & M) ^ rot(b, 8)
        b = (b + a) & M
        a = ((a - c) & M) ^ rot(c, 16)
        c = (c + b) & M
        b = ((b - a) & M) ^ rot(a, 19)
        a = (a + c) & M
        c = ((c - b) & M) ^ rot(b, 4)
        b = (b + a) & M
        length -= 12
        i += 12
    if length == 0:
        return c
    tail = data[i:] + bytes(12 - length)
    a = (a + int.from_bytes(tail[0:4], "little")) & M
    b = (b + int.from_bytes(tail[4:8], "little")) & M
    c = (c + int.from_bytes(tail[8:12], "little")) & M
    c = ((c ^ b) - rot(b, 14)) & M
    a = ((a ^ c) - rot(c, 11)) & M
    b = ((b ^ a) - rot(a, 25)) & M
    c = ((c ^ b) - rot(b, 16)) & M
    a = ((a ^ c) - rot(c, 4)) & M
    b = ((b ^ a) - rot(a, 14)) & M
    c = ((c ^ b) - rot(b, 24)) & M
    return c


def _reason(exc: BaseException) -> str:
    """The useful part of an OSError (h5py's messages are long)."""
    if getattr(exc, "strerror", None):
        return str(exc.strerror)
    text = " ".join(str(exc).split())
    return text if len(text) <= 200 else text[:199] + "…"


def _superblock_offset(fh) -> int | None:
    """Where the HDF5 signature is (0 or after a user block of 512, 1024, ... bytes)."""
    size = os.fstat(fh.fileno()).st_size
    offset = 0
    while offset == 0 or offset < size:
        fh.seek(offset)
        if fh.read(8) == b"\x89HDF\r\n\x1a\n":
            return offset
        offset = 512 if offset == 0 else 2 * offset
    return None


def _clear_crash_flags(path) -> None:
    """What ``h5clear -s`` does: reset the "open for writing" flags a killed writer left set.

    HDF5 ≥ 1.10 marks the superblock (version 2/3) while a file is open for writing and
    refuses to open it for writing again until the flag is cleared. The file's data up to the
    writer's last flush is intact (SWMR ordering); the checkpoint says how much of it counts.
    Refused if another process still holds the file's lock (a run still writing it).
    """
    import fcntl

    try:
        fd = os.open(path, os.O_RDWR | os.O_NOFOLLOW | os.O_CLOEXEC)
        with os.fdopen(fd, "rb+") as fh:
            try:
                fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise StoreError(f"{str(path)!r} is still being written by another process; stop it first") from None
            offset = _superblock_offset(fh)
            if offset is None:
                fcntl.flock(fh.fileno(), fcntl.LOCK_UN)
                return
            fh.seek(offset)
            head = bytearray(fh.read(64))
            if head[8] not in (2, 3) or head[11] == 0:
                fcntl.flock(fh.fileno(), fcntl.LOCK_UN)
                return
            end = 12 + 4 * head[9]
            if _lookup3(bytes(head[:end])) != int.from_bytes(head[end : end + 4], "little"):
                raise StoreError(f"the output file {str(path)!r} is damaged: its superblock fails its checksum")
            head[11] = 0
            head[end : end + 4] = _lookup3(bytes(head[:end])).to_bytes(4, "little")
            fh.seek(offset)
            fh.write(bytes(head[: end + 4]))
            fh.flush()
            os.fsync(fh.fileno())
            fcntl.flock(fh.fileno(), fcntl.LOCK_UN)
    except OSError as exc:
        raise StoreError(f"cannot open {str(path)!r} to resume: {exc}") from None


class Checkpoint:
    """The full integrator state at a segment boundary, written atomically."""

    def __init__(self, path):
        self.path = Path(str(path) + ".checkpoint")

    def write(self, arrays: dict[str, np.ndarray], attrs: dict) -> None:
        """Write a new checkpoint beside the old one and rename it over it (see the module docstring)."""
        from .files import discard, exclusive_temp, publish

        h5py = _h5py()
        tmp = exclusive_temp(self.path)
        try:
            try:
                # exclusive create under a random name: a link planted beside the run is never followed
                with h5py.File(tmp, "w-") as f:
                    for key, value in attrs.items():
                        f.attrs[key] = value
                    f.attrs["sha256"] = _arrays_digest(arrays, dict(f.attrs))
                    g = f.create_group("engine")
                    for name, arr in arrays.items():
                        g.create_dataset(name, data=arr)
                publish(tmp, self.path)  # atomic: the old checkpoint or the new, never half of one
            except BaseException:
                discard(tmp)
                raise
        except OSError as exc:
            cls = NoSpaceError if is_no_space(exc) else StoreError
            raise cls(
                f"writing the checkpoint {str(self.path)!r} failed ({_reason(exc)}); the previous checkpoint is intact"
            ) from None

    def read(self) -> tuple[dict[str, np.ndarray], dict]:
        h5py = _h5py()
        if not os.path.lexists(self.path):
            raise StoreError(
                f"no checkpoint {str(self.path)!r} to resume from (the run never wrote one, or it "
                "finished); start anew with --overwrite"
            )
        _regular_or_absent(self.path, "checkpoint")
        try:
            with h5py.File(self.path, "r") as f:
                attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
                arrays = {name: ds[()] for name, ds in f["engine"].items()}
        except (OSError, KeyError) as exc:
            raise StoreError(
                f"the checkpoint {str(self.path)!r} is corrupt or not a lieint checkpoint ({exc})"
            ) from None
        stored = attrs.pop("sha256", None)
        if stored is not None and stored != _arrays_digest(arrays, attrs):
            raise StoreError(
                f"the checkpoint {str(self.path)!r} is damaged: its SHA-256 does not match its contents; "
                "start anew with --overwrite"
            )
        return arrays, attrs

    def remove(self) -> None:
        if os.path.lexists(self.path):
            self.path.unlink()
