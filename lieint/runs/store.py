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

import hashlib
import json
import os
import stat
from pathlib import Path

import numpy as np

from .errors import USER_BLOCK, NoSpaceError, StoreError, is_no_space

__all__ = ["Checkpoint", "NoSpaceError", "OutputFile", "StoreError", "attrs_digest"]


#: target size of a chunk of a series (the unit of Fletcher-32 checksums and of file growth)
CHUNK_BYTES = 1 << 16

#: HDF5 objects of a file whose write failed: HDF5 cannot close them cleanly any more, so they are
#: kept alive (closing or collecting them repeats the failure; see :func:`hdf5_broken`)
_BROKEN: list = []


def hdf5_broken() -> bool:
    """True once a write failure left HDF5 objects that cannot be closed; a command-line process
    should then end with ``os._exit`` (HDF5's own exit handler would retry the failed writes)."""
    return bool(_BROKEN)


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
        self.broken = False  # a write failed: HDF5 cannot flush or close this file any more

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
        # a chunk of every series is written at once: refuse before HDF5 meets a full disk
        first = sum(
            max(1, min(4096, CHUNK_BYTES // max(np.asarray(r).nbytes, 1))) * np.asarray(r).nbytes
            for a in first_rows.values()
            for r in a.values()
        )
        need = first + 4096 * 8 + (128 << 10)
        room, where = available_room(path)
        if need > room:
            raise NoSpaceError(f"{where}; creating the output file {str(path)!r} needs {need / 1e3:.0f} kB")
        tmp = exclusive_temp(path)
        try:
            # "w-" creates exclusively (O_CREAT | O_EXCL): never through a link, never over a file
            f = h5py.File(tmp, "w-", libver="latest", userblock_size=USER_BLOCK)
        except OSError as exc:
            raise StoreError(f"cannot create the output file {str(path)!r}: {_reason(exc)}") from None
        try:
            made: list = []  # every HDF5 object made: kept alive if the file cannot be closed
            try:
                cls._populate(f, made, attrs, first_rows, t0, dataset_attrs)
                f.close()
                made.clear()
            finally:
                if made:
                    _BROKEN.append((f, made))
            write_marker(tmp)
            publish(tmp, path)  # fsync, atomic rename over the old run, fsync of the directory
        except (OSError, RuntimeError) as exc:  # h5py raises either when a write fails
            discard(tmp)
            if is_no_space(exc):
                raise NoSpaceError(f"no room to create the output file {str(path)!r}: {_reason(exc)}") from None
            raise StoreError(f"cannot create the output file {str(path)!r}: {_reason(exc)}") from None
        except BaseException:
            discard(tmp)
            raise
        return cls._open_for_append(path, None)

    @classmethod
    def _populate(cls, f, made: list, attrs, first_rows, t0, dataset_attrs) -> None:
        """Attributes, the first row of every series (chunked, Fletcher-32), dimension scales."""
        for key, value in attrs.items():
            f.attrs[key] = value
        t = f.create_dataset("t", data=np.array([t0]), maxshape=(None,), chunks=(4096,), dtype="f8", fletcher32=True)
        made.append(t)
        t.make_scale("t")
        for group, arrays in first_rows.items():
            g = f.create_group(group)
            made.append(g)
            for name, row in arrays.items():
                row = np.asarray(row, dtype=float)
                chunk_rows = max(1, min(4096, CHUNK_BYTES // max(row.nbytes, 1)))
                ds = g.create_dataset(
                    name,
                    data=row[None],
                    maxshape=(None,) + row.shape,
                    chunks=(chunk_rows,) + row.shape,
                    dtype="f8",
                    fletcher32=True,  # each chunk checksummed: a changed byte is detected
                )
                made.append(ds)
                cls._label(f, ds, group, name)
                for key, value in (dataset_attrs or {}).get((group, name), {}).items():
                    ds.attrs[key] = value
        f.attrs["attrs_sha256"] = attrs_digest(f.attrs)

    def growth(self, rows: int) -> int:
        """Bytes the file grows by when ``rows`` rows are appended: the chunks newly allocated
        (each series grows a whole chunk at a time) and a share for the chunk indices."""
        n = self.rows
        total = 0
        for ds in self._series(self.f):
            cr = ds.chunks[0]
            chunk_bytes = cr * ds.dtype.itemsize * int(np.prod(ds.shape[1:], dtype=np.int64))
            total += (-(-(n + rows) // cr) - -(-n // cr)) * (chunk_bytes + 4)
        return int(total * 1.02) + (32 << 10)

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
        from .superblock import clear_crash_flags

        repaired = clear_crash_flags(path)
        out = cls._open_for_append(path, rows)
        if repaired:
            out.verify(rows)
        return out

    def verify(self, rows: int) -> None:
        """Read the first ``rows`` rows of every series (each chunk's Fletcher-32 checksum is
        checked); :class:`StoreError` naming the first damaged series."""
        for ds in self._series(self.f):
            step = max(1, ds.chunks[0]) * 64
            for r0 in range(0, rows, step):
                try:
                    ds[r0 : min(rows, r0 + step)]
                except OSError as exc:
                    self.close()
                    raise StoreError(
                        f"the output file {str(self.path)!r} is damaged in {ds.name} rows "
                        f"{r0}–{min(rows, r0 + step) - 1} ({_reason(exc)}); it cannot be resumed: start anew "
                        "with --overwrite"
                    ) from None

    @classmethod
    def _open_for_append(cls, path, rows: int | None) -> OutputFile:
        h5py = _h5py()
        try:
            # Without HDF5's own file lock: one writer is guaranteed by the run's lock
            # (lieint.runs.lock), and a reader that opens the file at this instant (`lieint
            # info`, a user's h5py.File) holds HDF5's shared lock, which made this reopen fail.
            f = h5py.File(path, "r+", libver="latest", locking=False)
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
        made: list = []  # HDF5 objects in use: kept alive if a write fails (closing them would retry it)
        try:
            ds = self.f["t"]
            made.append(ds)
            ds.resize((n + m,))
            ds[n:] = t
            for group, arrays in groups.items():
                g = self.f[group]
                made.append(g)
                for name, values in arrays.items():
                    ds = g[name]
                    made.append(ds)
                    ds.resize((n + m,) + ds.shape[1:])
                    ds[n:] = values
            self.f.flush()
        except (OSError, RuntimeError) as exc:  # h5py raises either when a write fails
            _BROKEN.append(made)
            self.broken = True
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
        except (OSError, RuntimeError) as exc:  # h5py raises either when a write fails
            self.broken = True
            if is_no_space(exc):
                raise NoSpaceError(f"writing to {str(self.path)!r} failed: {_reason(exc)}") from None
            raise StoreError(f"writing the attributes of {str(self.path)!r} failed: {_reason(exc)}") from None

    def abandon(self) -> None:
        """Drop the handle after a failed write without flushing again (the file stays as the
        last successful flush left it; resuming truncates it to the checkpoint's rows)."""
        _BROKEN.append(self.f)
        self.broken = True

    def close(self) -> None:
        if self.f.id.valid:
            self.f.close()


def available_room(path) -> tuple[int, str]:
    """Bytes ``path`` may still grow by (free disk space, and the file-size limit ``ulimit -f``),
    with a phrase saying which bound it is."""
    import resource

    path = Path(path)
    try:
        size = os.stat(path).st_size
    except OSError:
        size = 0
    try:
        st = os.statvfs(path.parent)
        room = st.f_bavail * st.f_frsize
        where = f"{room / 1e6:.3g} MB are free on the disk of {str(path)!r}"
    except OSError:
        room, where = 1 << 62, ""
    soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    if soft != resource.RLIM_INFINITY and soft - size < room:
        room = soft - size
        where = f"{str(path)!r} is {size / 1e3:.0f} kB and the file-size limit (ulimit -f) is {soft / 1e3:.0f} kB"
    return room, where


def _reason(exc: BaseException) -> str:
    """The useful part of an OSError (h5py's messages are long)."""
    if getattr(exc, "strerror", None):
        return str(exc.strerror)
    text = " ".join(str(exc).split())
    import re

    system = re.search(r"errno = (\d+), error message = '([^']*)'", text)
    if system:  # HDF5 quotes the operating system's error inside its own
        return f"{system.group(2)} (errno {system.group(1)})"
    return text if len(text) <= 200 else text[:199] + "…"


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
        except (OSError, RuntimeError) as exc:
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
            try:
                self.path.unlink()  # a link is removed itself, never what it points to
            except OSError as exc:
                raise StoreError(f"cannot remove the old checkpoint {str(self.path)!r}: {_reason(exc)}") from None
