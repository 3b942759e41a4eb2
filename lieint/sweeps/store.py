"""The sweep's Zarr (v3) store: one array per quantity along ``member``, committed chunk by chunk.

Layout (``xarray.open_zarr(SWEEP.zarr)`` reads it as one Dataset)::

    member (member)                      member index; coordinates along it:
      point, ensemble_member (member)    the parameter point and the ensemble index
      <key> (member)                     each varied key's value, e.g. body.principal_moments[0]
    time (time)                          the save times
    state_<field> (member, time, ...)    every state field at the save times
    <output> (member, time, ...)         each requested output or invariant
    drift_<invariant> (member)           each requested invariant's drift (lieint.drift)
    megno, lyapunov (member)             the chaos indicators asked for (lieint.sweeps.indicators)
    chunk_committed (chunk)              1 once the chunk is committed
    chunk_sha256 (chunk)                 the size and SHA-256 of each of the chunk's files (JSON)
    chunk_stats (chunk, stat)            per chunk: start, stop, steps, cpu/wall time, pid, ...
    chunk_info (chunk, info)             per chunk: method, backend, worker, host, session, ...

The member arrays are chunked like the sweep, so a sweep chunk is one Zarr chunk of every array.
A chunk is **committed** by writing its data first, then the size and SHA-256 of every file it
wrote, and its ``chunk_committed`` flag last (each Zarr chunk file is written to a temporary file
and renamed), so a killed writer leaves either a committed chunk or one that a resumed sweep
recomputes; a committed chunk damaged later (a file deleted, truncated or changed) fails its
checksum, is named, and is recomputed on resume (:mod:`lieint.sweeps.integrity`).

A new store is built under a temporary name beside ``SWEEP.zarr`` and renamed into place, so a
killed writer never leaves half a layout at the store's name; ``overwrite`` replaces only a
lieint sweep store (:func:`lieint.sweeps.integrity.check_replaceable`). The writer holds the
store's lock (:class:`lieint.runs.lock.RunLock` on ``SWEEP.zarr.lock``) throughout. Root
attributes: the plan, its fingerprint, the scene's TOML data, the lieint version and the status.
"""

from __future__ import annotations

import errno
import json
import os
import re
import secrets
import shutil
from pathlib import Path

import numpy as np

from .chunk import ChunkResult
from .indicators import INDICATORS
from .integrity import (
    DamagedStoreError,
    StoreError,
    check_replaceable,
    digest_file,
    read_root_metadata,
    verify_store,
)
from .plan import SweepPlan

__all__ = ["DamagedStoreError", "NoSpaceError", "StoreError", "SweepStore", "open_sweep"]

#: per-chunk numbers (``chunk_stats``, one column each; times in seconds, since the epoch for
#: ``started``/``finished``) and strings (``chunk_info``)
STATS = (
    "start",
    "stop",
    "nsteps",
    "batches",
    "stacked",
    "success",
    "cpu_time",
    "wall_time",
    "step_cpu_time",
    "step_wall_time",
    "started",
    "finished",
    "pid",
)
INFO = ("method", "backend", "backend_reason", "worker", "host", "session", "message", "warnings")

#: the arrays with one Zarr chunk per sweep chunk besides the member arrays (written at commits)
PER_CHUNK = ("chunk_committed", "chunk_sha256", "chunk_stats", "chunk_info")
#: coordinates along ``member`` are written in blocks of at least this many members
COORDINATE_BLOCK = 1 << 20


class NoSpaceError(StoreError):
    """The disk is full or the file-size limit was reached while committing a chunk; the
    chunks committed before it are intact and the sweep resumes once there is room."""


def _zarr():
    try:
        import zarr
    except ImportError:  # pragma: no cover - the sweep extra is not installed
        raise ImportError('sweeps need zarr, dask and distributed: pip install "lieint[sweep]"') from None
    return zarr


def _always_written() -> dict:
    # every chunk gets its file, even one equal to the fill value: a missing file is damage
    return {"write_empty_chunks": True}


def temporary_names(path: Path) -> re.Pattern:
    """Names of the directories a writer of ``path`` builds or discards beside it."""
    return re.compile(rf"^\.{re.escape(path.name)}\.[0-9a-f]{{16}}\.(tmp|old)$")


def remove_stale_temporaries(path: Path) -> None:
    """Remove what a killed writer left beside ``path`` (call with the store's lock held):
    layouts it was building and stores it was replacing — lieint sweep stores only."""
    pattern = temporary_names(path)
    try:
        entries = list(os.scandir(path.parent))
    except OSError:
        return
    for entry in entries:
        if pattern.match(entry.name) and entry.is_dir(follow_symlinks=False):
            try:
                read_root_metadata(Path(entry.path))  # a lieint sweep store (marked from its creation)
            except StoreError:
                continue  # not something lieint wrote: leave it
            shutil.rmtree(entry.path, ignore_errors=True)


class SweepStore:
    """Create, resume and commit to a sweep's Zarr store (see the module docstring).

    The caller holds the store's lock (:func:`lieint.sweeps.engine.run_sweep` does).

    Parameters
    ----------
    path : path
        The ``.zarr`` directory.
    plan : SweepPlan
    resume : bool
        Continue a store of the same plan (its fingerprint must match); its committed chunks
        are verified, and the damaged ones are recomputed (:attr:`damaged`).
    overwrite : bool
        Replace an existing lieint sweep store (anything else is refused untouched).

    Attributes
    ----------
    damaged : dict
        On resume: ``{chunk: [what was wrong, ...]}`` of the committed chunks that failed their
        checksums and will be recomputed.
    """

    def __init__(self, path, plan: SweepPlan, *, resume: bool = False, overwrite: bool = False):
        self.path, self.plan = Path(path), plan
        self.damaged: dict[int, list[str]] = {}
        self._arrays: dict = {}
        self._times: np.ndarray | None = None  # the time axis, once the member arrays exist
        action = self.check(self.path, plan, resume=resume, overwrite=overwrite)
        if action == "resume":
            self._resume()
        else:
            self._create(replace=action == "replace")

    @staticmethod
    def check(path, plan: SweepPlan, *, resume: bool = False, overwrite: bool = False) -> str:
        """What opening the store would do — ``"create"``, ``"resume"`` or ``"replace"`` — or
        :class:`StoreError` saying why it may not, without writing anything."""
        path = Path(path)
        if not os.path.lexists(path):
            return "create"
        if not (resume or overwrite):
            raise StoreError(f"{path} exists; pass --resume to continue it or --overwrite to replace it")
        if overwrite:
            check_replaceable(path)
            return "replace"
        if path.is_symlink() or not path.is_dir():
            raise StoreError(f"cannot resume {str(path)!r}: it is not a lieint sweep store (not a directory)")
        attrs = read_root_metadata(path)["attributes"]
        if attrs.get("fingerprint") != plan.fingerprint:
            raise StoreError(
                f"{path} holds another sweep (a different scene, keys, values, ensemble, chunking, "
                "integrator or lieint version); resume only the same sweep, or pass --overwrite"
            )
        if "files_sha256" not in attrs:
            raise StoreError(
                f"cannot resume {str(path)!r}: it was written by a lieint without chunk checksums; start again "
                "with --overwrite"
            )
        return "resume"

    # -- opening ---------------------------------------------------------------------------
    def _open(self):
        zarr = _zarr()
        try:
            return zarr.open_group(str(self.path), mode="r+", zarr_format=3, use_consolidated=False)
        except Exception as exc:
            raise StoreError(f"cannot open the store {str(self.path)!r}: {type(exc).__name__}: {exc}") from None

    def _resume(self) -> None:
        attrs = read_root_metadata(self.path)["attributes"]
        self.root = self._open()
        self._drop_half_created_arrays(attrs)
        attrs = dict(self.root.attrs)
        check = verify_store(self.path, self.root, attrs, self.plan.nchunks)
        if check.layout_damaged:
            raise StoreError(
                f"cannot resume {str(self.path)!r}: {check.describe()}. The store's layout is damaged; start again "
                "with --overwrite"
            )
        self.damaged = dict(check.damaged)
        for c in sorted(self.damaged):
            # no longer committed: recomputed by this sweep (the flag first, then the record)
            self.root["chunk_committed"][c] = 0
            self.root["chunk_sha256"][c] = ""
        self.root.attrs.update({"status": "running", "message": ""})

    def _drop_half_created_arrays(self, attrs: dict) -> None:
        """A writer killed while creating the member arrays (at its first commit) leaves arrays
        whose files are not recorded yet; no chunk was committed in them: remove them."""
        recorded = attrs.get("files_sha256") or {}
        arrays = list(attrs.get("arrays") or [])
        half = [name for name in arrays if f"{name}/zarr.json" not in recorded]
        if not half:
            return
        for name in half:
            target = self.path / name
            if target.is_dir() and not target.is_symlink():
                shutil.rmtree(target, ignore_errors=True)
        self.root.attrs["arrays"] = [n for n in arrays if n not in half]

    # -- layout ----------------------------------------------------------------------------
    def _create(self, replace: bool) -> None:
        """Build the layout under a temporary name, then rename it into place."""
        zarr = _zarr()
        temp = self.path.with_name(f".{self.path.name}.{secrets.token_hex(8)}.tmp")
        try:
            # marked as ours from the start: a later writer may remove it if this one is killed
            self.root = zarr.open_group(str(temp), mode="w-", zarr_format=3, attributes={"lieint_sweep": 1})
            self._write_layout(temp)
        except OSError as exc:
            shutil.rmtree(temp, ignore_errors=True)
            raise _os_error(exc, f"cannot create the store {str(self.path)!r}") from None
        except BaseException:
            shutil.rmtree(temp, ignore_errors=True)
            raise
        if replace:
            old = self.path.with_name(f".{self.path.name}.{secrets.token_hex(8)}.old")
            os.rename(self.path, old)  # checked to be a lieint sweep store; a link would be renamed itself
            os.rename(temp, self.path)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.rename(temp, self.path)
        self.root = self._open()

    def _write_layout(self, where: Path) -> None:
        from .._version import __version__

        plan = self.plan
        N, C = plan.nmembers, plan.nchunks
        root = self.root
        block = max(plan.chunk, COORDINATE_BLOCK)
        shape = [len(u.values) for u in plan.variations]

        def by_member(name, dtype, values_of):
            arr = root.create_array(
                name, shape=(N,), chunks=(min(block, N),), dtype=dtype, dimension_names=["member"],
                config=_always_written(),
            )  # fmt: skip
            for m0 in range(0, N, block):  # in blocks: the coordinates of 10⁷ members never sit in memory at once
                members = np.arange(m0, min(N, m0 + block))
                arr[m0 : m0 + members.size] = values_of(members)

        by_member("member", "i8", lambda m: m)
        by_member("point", "i8", lambda m: m // plan.ensemble)
        by_member("ensemble_member", "i8", lambda m: m % plan.ensemble)
        coords = ["point", "ensemble_member"]
        for p_axis, v in enumerate(plan.variations):
            by_member(
                v.key.text, "f8", lambda m, a=p_axis, v=v: v.values[np.unravel_index(m // plan.ensemble, shape)[a]]
            )
            coords.append(v.key.text)
        self._array("chunk", np.arange(C), ["chunk"])
        for name, dtype, fill in (("chunk_committed", "i1", 0), ("chunk_sha256", str, "")):
            root.create_array(
                name, shape=(C,), chunks=(1,), dtype=dtype, fill_value=fill, dimension_names=["chunk"],
                config=_always_written(),
            )  # fmt: skip
        # one row per chunk (a Zarr chunk each): a commit writes a few files, not one per field
        self._array("stat", np.array(STATS, dtype=str), ["stat"])
        self._array("info", np.array(INFO, dtype=str), ["info"])
        root.create_array(
            "chunk_stats",
            shape=(C, len(STATS)),
            chunks=(1, len(STATS)),
            dtype="f8",
            fill_value=np.nan,
            dimension_names=["chunk", "stat"],
            config=_always_written(),
        )
        root.create_array(
            "chunk_info",
            shape=(C, len(INFO)),
            chunks=(1, len(INFO)),
            dtype=str,
            dimension_names=["chunk", "info"],
            config=_always_written(),
        )
        arrays = sorted(name for name in os.listdir(where) if (where / name / "zarr.json").exists())
        root.attrs.update(
            {
                "lieint_sweep": 1,
                "lieint_version": __version__,
                "fingerprint": plan.fingerprint,
                "plan": json.loads(json.dumps(plan.describe(), default=str)),
                "scene": json.loads(json.dumps(plan.scene_data, default=str)) if plan.scene_data else None,
                "title": plan.description,
                "coordinates_along_member": coords,
                "arrays": arrays,
                "files_sha256": _digests(where, arrays, with_chunks=set(arrays) - set(PER_CHUNK)),
                "status": "running",
            }
        )

    def _array(self, name, values, dims):
        values = np.asarray(values)
        dtype = str if values.dtype.kind == "U" else values.dtype  # variable-length strings (in the v3 spec)
        arr = self.root.create_array(
            name, shape=values.shape, chunks=values.shape, dtype=dtype, dimension_names=dims, config=_always_written()
        )
        arr[...] = values
        return arr

    def _ensure_result_arrays(self, result: ChunkResult) -> None:
        """Create the time axis and the member arrays from the first chunk's shapes."""
        if self._times is not None:
            if not np.array_equal(self._times, result.t):
                raise StoreError(f"chunk {result.index} saved at times other than the store's")
            return
        attrs = dict(self.root.attrs)
        if "time/zarr.json" in (attrs.get("files_sha256") or {}):
            self._times = self.root["time"][...]
            self._ensure_result_arrays(result)
            return
        N, M = self.plan.nmembers, self.plan.chunk
        m = result.t.size
        coords = " ".join(attrs["coordinates_along_member"])
        groups = (
            ("state_", result.states, True),
            ("", result.series, True),
            ("drift_", result.drifts, False),
            ("", result.indicators, False),
        )
        names = [prefix + name for prefix, values, _ in groups for name in values] + ["time"]
        # the names first: a writer killed while creating them leaves arrays a resume removes
        self.root.attrs["arrays"] = sorted(set(attrs["arrays"]) | set(names))
        for prefix, values, timed in groups:
            for name, v in values.items():
                described = {"description": INDICATORS[name]} if values is result.indicators else {}
                trailing = v.shape[2:] if timed else ()
                dims = ["member", "time"] if timed else ["member"]
                dims += [f"{name}_{i}" for i in range(len(trailing))]
                shape = (N, m, *trailing) if timed else (N,)
                self.root.create_array(
                    prefix + name,
                    shape=shape,
                    chunks=(M, *shape[1:]),
                    dtype="f8",
                    fill_value=np.nan,
                    dimension_names=dims,
                    attributes={"coordinates": coords} | described,
                    config=_always_written(),
                )
        self._array("time", result.t, ["time"])
        # the time axis's record last: it says the member arrays exist
        files = dict(attrs.get("files_sha256") or {})
        files.update(_digests(self.path, names, with_chunks={"time"}))
        self.root.attrs["files_sha256"] = files
        self._times = np.asarray(result.t)

    # -- chunks ----------------------------------------------------------------------------
    def committed(self) -> np.ndarray:
        """Indices of the committed chunks."""
        return np.flatnonzero(self.root["chunk_committed"][...] == 1)

    def commit(self, result: ChunkResult, session: str = "") -> None:
        """Write the chunk's data, then its metadata, then its checksums, then its commit flag
        (last). A full disk or the file-size limit raises :class:`NoSpaceError`."""
        try:
            self._commit(result, session)
        except OSError as exc:
            raise _os_error(exc, f"cannot commit chunk {result.index} to {str(self.path)!r}") from None

    def _array_of(self, name: str):
        """The array ``name`` (opened once: each opening reads its metadata from the disk)."""
        if name not in self._arrays:
            self._arrays[name] = self.root[name]
        return self._arrays[name]

    def _commit(self, result: ChunkResult, session: str) -> None:
        if (result.start, result.stop) != self.plan.chunk_range(result.index):
            raise StoreError(f"chunk {result.index} covers members {result.start}..{result.stop}, not the plan's")
        self._ensure_result_arrays(result)
        sl = slice(result.start, result.stop)
        written = []
        for prefix, values in (
            ("state_", result.states),
            ("", result.series),
            ("drift_", result.drifts),
            ("", result.indicators),
        ):
            for name, v in values.items():
                self._array_of(prefix + name)[sl] = v
                written.append(prefix + name)
        c = result.index
        meta = dict(result.meta, start=result.start, stop=result.stop, session=session)
        self._array_of("chunk_stats")[c] = np.array([float(meta[name]) for name in STATS])
        self._array_of("chunk_info")[c] = np.array([str(meta.get(name, "")) for name in INFO], dtype=str)
        record = {}
        for name in [*written, "chunk_stats", "chunk_info"]:
            arr = self._array_of(name)
            relative = f"{name}/" + arr.metadata.encode_chunk_key((c,) + (0,) * (arr.ndim - 1))
            record[relative] = list(digest_file(self.path / relative))
        self._array_of("chunk_sha256")[c] = json.dumps(record, sort_keys=True)
        self._array_of("chunk_committed")[c] = 1

    def finish(self, status: str, message: str = "") -> None:
        """Record the status (and why it failed); a complete store gets consolidated metadata."""
        self.root.attrs.update({"status": status, "message": message})
        if status == "complete":
            import warnings

            zarr = _zarr()
            with warnings.catch_warnings():
                # consolidated metadata is a zarr-python extension of format 3, read by xarray
                warnings.simplefilter("ignore")
                zarr.consolidate_metadata(str(self.path))


def _digests(where: Path, arrays, with_chunks) -> dict[str, list]:
    """``{relative path: [size, hex]}`` of the arrays' metadata and of the chunk files of the
    arrays ``with_chunks`` (those written once: the coordinates and the time axis)."""
    out = {}
    for name in arrays:
        out[f"{name}/zarr.json"] = list(digest_file(where / name / "zarr.json"))
        if name not in with_chunks:
            continue
        for directory, _, files in os.walk(where / name / "c"):
            for f in files:
                full = Path(directory) / f
                out[str(full.relative_to(where))] = list(digest_file(full))
    return out


def _os_error(exc: OSError, what: str) -> StoreError:
    if exc.errno in (errno.ENOSPC, errno.EFBIG, errno.EDQUOT):
        return NoSpaceError(
            f"{what}: the disk is full or the file-size limit (ulimit -f) was reached ({exc.strerror or exc}). The "
            "chunks committed so far are intact: free space (or raise the limit) and continue with --resume"
        )
    return StoreError(f"{what}: {exc.strerror or exc}")


# -- reading -----------------------------------------------------------------------------------


def open_sweep(path, *, grid: bool = False, damaged: str = "raise"):
    """Open a sweep store as an :class:`xarray.Dataset`, its chunks verified first.

    Every committed chunk's files are checked against the SHA-256 recorded when it was committed
    (:mod:`lieint.sweeps.integrity`; this reads the whole store once). The members of chunks
    that are not committed (an interrupted sweep) read as NaN, whatever their files hold.

    Parameters
    ----------
    path : path
        The ``.zarr`` store written by :func:`lieint.sweep`.
    grid : bool, default False
        Unstack ``member`` into one dimension per varied key (and ``ensemble_member``), so that
        ``ds.sel({"body.principal_moments[0]": 1.2})`` picks a point of the grid.
    damaged : {"raise", "mask"}
        What to do with committed chunks that fail their checksums: raise
        :class:`~lieint.sweeps.integrity.DamagedStoreError` naming them (``lieint sweep …
        --resume`` recomputes them), or read their members as NaN (``chunk_committed`` 0).

    Returns
    -------
    xarray.Dataset
    """
    import xarray as xr

    if damaged not in ("raise", "mask"):
        raise ValueError(f"`damaged` must be 'raise' or 'mask'; got {damaged!r}")
    store = Path(path)
    if not os.path.lexists(store):
        raise FileNotFoundError(f"no sweep store at {str(store)!r}")
    doc = read_root_metadata(store)
    attrs = doc["attributes"]
    zarr = _zarr()
    try:
        root = zarr.open_group(str(store), mode="r", zarr_format=3, use_consolidated=False)
        nchunks = int(attrs["plan"]["nchunks"])
    except Exception as exc:
        raise StoreError(f"cannot open the sweep store {str(store)!r}: {type(exc).__name__}: {exc}") from None
    check = verify_store(store, root, attrs, nchunks)
    if check.damaged and (damaged == "raise" or check.layout_damaged):
        raise DamagedStoreError(
            f"the sweep store {str(store)!r} is damaged: {check.describe()}. "
            + (
                "Its layout is damaged: run the sweep again with --overwrite."
                if check.layout_damaged
                else "Run the same `lieint sweep … --resume` to recompute these chunks (or open it with "
                "damaged='mask' to read them as NaN)."
            )
        )
    consolidated = "consolidated_metadata" in doc
    try:
        ds = xr.open_zarr(str(store), consolidated=consolidated)
    except Exception as exc:
        raise StoreError(f"cannot open the sweep store {str(store)!r}: {type(exc).__name__}: {exc}") from None
    good = check.good()
    if len(good) < nchunks:
        ds = _mask_chunks(ds, root, good, int(attrs["plan"]["chunk"]))
    if grid:
        keys = list(ds.attrs["plan"]["keys"]) or ["point"]  # systems given as a list: their index
        chunk_vars = [v for v in ds.data_vars if "chunk" in ds[v].dims] + ["chunk", "stat", "info"]
        ds = ds.drop_vars([v for v in chunk_vars if v in ds.variables])
        ds = ds.set_index(member=[*keys, "ensemble_member"]).unstack("member")
    return ds


def _mask_chunks(ds, root, good: list[int], chunk: int):
    """The dataset with the members of every chunk not in ``good`` read as NaN — their files
    are never read (they may be half-written, missing or garbage)."""
    import dask.array as da

    keep = set(good)
    committed = np.zeros(ds.sizes["chunk"], dtype="i1")
    committed[sorted(keep)] = 1
    ds = ds.assign(chunk_committed=(("chunk",), committed))
    for name, var in ds.data_vars.items():
        if not var.dims or var.dims[0] != "member" or var.dtype.kind != "f":
            continue
        arr = root[name]
        chunks = ((chunk,) * (arr.shape[0] // chunk) + ((arr.shape[0] % chunk,) if arr.shape[0] % chunk else ()),)
        chunks += tuple((n,) for n in arr.shape[1:])

        def load(arr=arr, block_info=None):
            (m0, m1), *rest = block_info[None]["array-location"]
            if m0 // chunk in keep:
                return arr[m0:m1]
            return np.full((m1 - m0, *(b - a for a, b in rest)), np.nan)

        lazy = da.map_blocks(load, chunks=chunks, dtype=var.dtype, meta=np.empty((0,) * var.ndim, dtype=var.dtype))
        ds[name] = (var.dims, lazy, var.attrs)
    return ds
