"""The sweep's Zarr (v3) store: one array per quantity along ``member``, committed chunk by chunk.

Layout (``xarray.open_zarr(SWEEP.zarr)`` reads it as one Dataset)::

    member (member)                      member index; coordinates along it:
      point, ensemble_member (member)    the parameter point and the ensemble index
      <key> (member)                     each varied key's value, e.g. body.principal_moments[0]
    time (time)                          the save times
    state_<field> (member, time, ...)    every state field at the save times
    <output> (member, time, ...)         each requested output or invariant
    drift_<invariant> (member)           each requested invariant's drift (lieint.drift)
    chunk_committed (chunk)              1 once the chunk is committed
    chunk_stats (chunk, stat)            per chunk: start, stop, steps, cpu/wall time, pid, ...
    chunk_info (chunk, info)             per chunk: method, backend, worker, host, session, ...

The member arrays are chunked like the sweep, so a sweep chunk is one Zarr chunk of every array.
A chunk is **committed** by writing its data first and its ``chunk_committed`` flag last (each
Zarr chunk file is written to a temporary file and renamed), so a killed writer leaves either a
committed chunk or one that a resumed sweep recomputes. Root attributes: the plan, its
fingerprint, the scene's TOML data, the lieint version and the status.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np

from .chunk import ChunkResult
from .plan import SweepError, SweepPlan

__all__ = ["StoreError", "SweepStore"]

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


class StoreError(SweepError):
    """A sweep store that cannot be written or resumed; the message says why."""


def _zarr():
    try:
        import zarr
    except ImportError:  # pragma: no cover - the sweep extra is not installed
        raise ImportError('sweeps need zarr, dask and distributed: pip install "lieint[sweep]"') from None
    return zarr


class SweepStore:
    """Create, resume and commit to a sweep's Zarr store (see the module docstring).

    Parameters
    ----------
    path : path
        The ``.zarr`` directory.
    plan : SweepPlan
    resume : bool
        Continue a store of the same plan (its fingerprint must match).
    overwrite : bool
        Replace an existing store.
    """

    def __init__(self, path, plan: SweepPlan, *, resume: bool = False, overwrite: bool = False):
        zarr = _zarr()
        self.path, self.plan = Path(path), plan
        exists = self.path.exists()
        if exists and not (resume or overwrite):
            raise StoreError(f"{self.path} exists; pass --resume to continue it or --overwrite to replace it")
        if resume and exists:
            try:
                self.root = zarr.open_group(str(self.path), mode="r+", zarr_format=3)
                attrs = dict(self.root.attrs)
            except Exception as exc:
                raise StoreError(f"{self.path} is not a lieint sweep store ({type(exc).__name__}: {exc})") from None
            if attrs.get("lieint_sweep") != 1:
                raise StoreError(f"{self.path} is not a lieint sweep store (no 'lieint_sweep' attribute)")
            if attrs.get("fingerprint") != plan.fingerprint:
                raise StoreError(
                    f"{self.path} holds another sweep (a different scene, keys, values, ensemble, chunking, "
                    "integrator or lieint version); resume only the same sweep, or pass --overwrite"
                )
            self.root.attrs.update({"status": "running", "message": ""})
            return
        if exists:
            shutil.rmtree(self.path) if self.path.is_dir() else self.path.unlink()
        self.root = zarr.open_group(str(self.path), mode="w", zarr_format=3)
        self._create(plan)

    # -- layout --------------------------------------------------------------------------
    def _create(self, plan: SweepPlan) -> None:
        from .. import __version__

        N, C = plan.nmembers, plan.nchunks
        root = self.root
        members = np.arange(N)
        self._array("member", members, ["member"])
        self._array("point", members // plan.ensemble, ["member"])
        self._array("ensemble_member", members % plan.ensemble, ["member"])
        coords = ["point", "ensemble_member"]
        for p_axis, v in enumerate(plan.variations):
            shape = [len(u.values) for u in plan.variations]
            idx = np.unravel_index(members // plan.ensemble, shape)[p_axis]
            self._array(v.key.text, v.values[idx], ["member"])
            coords.append(v.key.text)
        self.coords = coords
        self._array("chunk", np.arange(C), ["chunk"])
        root.create_array(
            "chunk_committed", shape=(C,), chunks=(1,), dtype="i1", fill_value=0, dimension_names=["chunk"]
        )
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
        )
        root.create_array(
            "chunk_info", shape=(C, len(INFO)), chunks=(1, len(INFO)), dtype=str, dimension_names=["chunk", "info"]
        )
        root.attrs.update(
            {
                "lieint_sweep": 1,
                "lieint_version": __version__,
                "fingerprint": plan.fingerprint,
                "plan": json.loads(json.dumps(plan.describe(), default=str)),
                "scene": json.loads(json.dumps(plan.scene_data, default=str)) if plan.scene_data else None,
                "title": plan.description,
                "coordinates_along_member": coords,
                "status": "running",
            }
        )

    def _array(self, name, values, dims, chunks=None):
        values = np.asarray(values)
        dtype = str if values.dtype.kind == "U" else values.dtype  # variable-length strings (in the v3 spec)
        arr = self.root.create_array(
            name, shape=values.shape, chunks=chunks or values.shape, dtype=dtype, dimension_names=dims
        )
        arr[...] = values
        return arr

    def _ensure_result_arrays(self, result: ChunkResult) -> None:
        """Create the time axis and the member arrays from the first chunk's shapes."""
        if "time" in self.root:
            t = self.root["time"][...]
            if not np.array_equal(t, result.t):
                raise StoreError(f"chunk {result.index} saved at times other than the store's")
            return
        N, M = self.plan.nmembers, self.plan.chunk
        m = result.t.size
        coords = " ".join(dict(self.root.attrs)["coordinates_along_member"])
        groups = (("state_", result.states, True), ("", result.series, True), ("drift_", result.drifts, False))
        for prefix, values, timed in groups:
            for name, v in values.items():
                trailing = v.shape[2:] if timed else ()
                dims = ["member", "time"] if timed else ["member"]
                dims += [f"{name}_{i}" for i in range(len(trailing))]
                shape = (N, m, *trailing) if timed else (N,)
                arr = self.root.create_array(
                    prefix + name,
                    shape=shape,
                    chunks=(M, *shape[1:]),
                    dtype="f8",
                    fill_value=np.nan,
                    dimension_names=dims,
                )
                arr.attrs["coordinates"] = coords
        # the time axis last: its presence says the member arrays exist
        self._array("time", result.t, ["time"])

    # -- chunks ----------------------------------------------------------------------------
    def committed(self) -> np.ndarray:
        """Indices of the committed chunks."""
        return np.flatnonzero(self.root["chunk_committed"][...] == 1)

    def commit(self, result: ChunkResult, session: str = "") -> None:
        """Write the chunk's data, then its metadata, then its commit flag (last)."""
        if (result.start, result.stop) != self.plan.chunk_range(result.index):
            raise StoreError(f"chunk {result.index} covers members {result.start}..{result.stop}, not the plan's")
        self._ensure_result_arrays(result)
        sl = slice(result.start, result.stop)
        for prefix, values in (("state_", result.states), ("", result.series), ("drift_", result.drifts)):
            for name, v in values.items():
                self.root[prefix + name][sl] = v
        c = result.index
        meta = dict(result.meta, start=result.start, stop=result.stop, session=session)
        self.root["chunk_stats"][c] = np.array([float(meta[name]) for name in STATS])
        self.root["chunk_info"][c] = np.array([str(meta.get(name, "")) for name in INFO], dtype=str)
        self.root["chunk_committed"][c] = 1

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


def open_sweep(path, *, grid: bool = False):
    """Open a sweep store as an :class:`xarray.Dataset`.

    Parameters
    ----------
    path : path
        The ``.zarr`` store written by :func:`lieint.sweep`.
    grid : bool, default False
        Unstack ``member`` into one dimension per varied key (and ``ensemble_member``), so that
        ``ds.sel({"body.principal_moments[0]": 1.2})`` picks a point of the grid.

    Returns
    -------
    xarray.Dataset
    """
    import xarray as xr

    store = Path(path)
    if not store.exists():
        raise FileNotFoundError(f"no sweep store at {str(store)!r}")
    consolidated = (store / "zarr.json").exists() and "consolidated_metadata" in (store / "zarr.json").read_text()
    ds = xr.open_zarr(str(store), consolidated=consolidated)
    if grid:
        keys = list(ds.attrs["plan"]["keys"]) or ["point"]  # systems given as a list: their index
        chunk_vars = [v for v in ds.data_vars if "chunk" in ds[v].dims] + ["chunk", "stat", "info"]
        ds = ds.drop_vars([v for v in chunk_vars if v in ds.variables])
        ds = ds.set_index(member=[*keys, "ensemble_member"]).unstack("member")
    return ds
