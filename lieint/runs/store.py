"""Plain-data storage of a run: the HDF5 output and the atomic checkpoint beside it.

Output ``RUN.h5`` (opened in SWMR mode while writing, so a crash leaves it readable):

* ``/t`` (m,) saved times, a dimension scale; ``/states/<field>`` (m, *batch, *shape);
  ``/invariants/<name>`` and ``/outputs/<name>`` likewise; every axis is a labelled
  dimension so that ``xarray.open_dataset(path, engine="h5netcdf", group="states")`` works;
* root attributes: ``lieint_version``, ``scene`` (its TOML text or JSON), ``scene_fingerprint``,
  ``method``, ``h``, ``nsteps``, ``steps_done``, ``status``.

Checkpoint ``RUN.h5.checkpoint`` (HDF5, written to a temporary file, fsynced, then renamed
over the old one, so it is always either the old or the new checkpoint): the engine's internal
arrays, the step reached, the rows written, the counters. Nothing is ever pickled.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

__all__ = ["Checkpoint", "OutputFile", "StoreError"]


class StoreError(ValueError):
    """An output or checkpoint that cannot be used; the message says which and why."""


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
        h5py = _h5py()
        try:
            f = h5py.File(path, "w", libver="latest")
        except OSError as exc:
            raise StoreError(f"cannot create the output file {str(path)!r}: {exc}") from None
        try:
            for key, value in attrs.items():
                f.attrs[key] = value
            t = f.create_dataset("t", data=np.array([t0]), maxshape=(None,), chunks=(4096,), dtype="f8")
            t.make_scale("t")
            for group, arrays in first_rows.items():
                g = f.create_group(group)
                for name, row in arrays.items():
                    row = np.asarray(row, dtype=float)
                    chunk_rows = max(1, min(4096, (1 << 20) // max(row.nbytes, 1)))
                    ds = g.create_dataset(
                        name, data=row[None], maxshape=(None,) + row.shape, chunks=(chunk_rows,) + row.shape, dtype="f8"
                    )
                    cls._label(f, ds, group, name)
                    for key, value in (dataset_attrs or {}).get((group, name), {}).items():
                        ds.attrs[key] = value
            f.swmr_mode = True
            f.flush()
        except Exception:
            f.close()
            raise
        return cls(path, f)

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
        h5py = _h5py()
        _clear_crash_flags(path)
        try:
            f = h5py.File(path, "r+", libver="latest")
        except OSError as exc:
            raise StoreError(
                f"cannot reopen the output file {str(path)!r} to resume (corrupt or unreadable): {exc}"
            ) from None
        try:
            have = f["t"].shape[0]
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
            raise StoreError(
                f"writing to {str(self.path)!r} failed ({exc}); the rows written before, and the "
                "last checkpoint, are intact: free space and resume with --resume"
            ) from None

    def set_attrs(self, **attrs) -> None:
        for key, value in attrs.items():
            self.f.attrs[key] = value
        self.f.flush()

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


def _clear_crash_flags(path) -> None:
    """What ``h5clear -s`` does: reset the "open for writing" flags a killed writer left set.

    HDF5 ≥ 1.10 marks the superblock (version 2/3) while a file is open for writing and
    refuses to open it for writing again until the flag is cleared. The file's data up to the
    writer's last flush is intact (SWMR ordering); the checkpoint says how much of it counts.
    Refused if another process still holds the file's lock (a run still writing it).
    """
    import fcntl

    try:
        with open(path, "rb+") as fh:
            try:
                fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise StoreError(f"{str(path)!r} is still being written by another process; stop it first") from None
            head = bytearray(fh.read(64))
            if head[:8] != b"\x89HDF\r\n\x1a\n" or head[8] not in (2, 3) or head[11] == 0:
                fcntl.flock(fh.fileno(), fcntl.LOCK_UN)
                return
            end = 12 + 4 * head[9]
            head[11] = 0
            head[end : end + 4] = _lookup3(bytes(head[:end])).to_bytes(4, "little")
            fh.seek(0)
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
        h5py = _h5py()
        tmp = self.path.with_name(self.path.name + ".tmp")
        try:
            with h5py.File(tmp, "w") as f:
                for key, value in attrs.items():
                    f.attrs[key] = value
                g = f.create_group("engine")
                for name, arr in arrays.items():
                    g.create_dataset(name, data=arr)
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
            os.replace(tmp, self.path)  # atomic: the old checkpoint or the new, never half of one
        except OSError as exc:
            raise StoreError(
                f"writing the checkpoint {str(self.path)!r} failed ({exc}); the previous checkpoint is intact"
            ) from None

    def read(self) -> tuple[dict[str, np.ndarray], dict]:
        h5py = _h5py()
        if not self.path.exists():
            raise StoreError(
                f"no checkpoint {str(self.path)!r} to resume from (the run never wrote one, or it "
                "finished); start anew with --overwrite"
            )
        try:
            with h5py.File(self.path, "r") as f:
                attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
                arrays = {name: ds[()] for name, ds in f["engine"].items()}
        except (OSError, KeyError) as exc:
            raise StoreError(
                f"the checkpoint {str(self.path)!r} is corrupt or not a lieint checkpoint ({exc})"
            ) from None
        return arrays, attrs

    def remove(self) -> None:
        if self.path.exists():
            self.path.unlink()
