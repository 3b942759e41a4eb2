"""Parameter and initial-condition sweeps on dask.distributed, stored in Zarr.

``lieint.sweep(scene, vary=[...], ensemble=N, out="SWEEP.zarr")`` (or ``lieint sweep`` on the
command line) integrates the product of the varied scene keys and an ensemble of initial states,
cut into chunks that run as batched ensembles on a dask cluster, and commits each chunk to one
Zarr store that ``xarray.open_zarr`` reads (:mod:`lieint.sweeps.store`).

Modules: :mod:`~lieint.sweeps.keys` (scene keys such as ``body.principal_moments[0]``),
:mod:`~lieint.sweeps.plan` (members and chunks, their sizes checked), :mod:`~lieint.sweeps.chunk`
(one chunk, one worker), :mod:`~lieint.sweeps.indicators` (MEGNO and the largest Lyapunov
exponent per member), :mod:`~lieint.sweeps.store` (the Zarr store),
:mod:`~lieint.sweeps.integrity` (checksums; what ``--overwrite`` may replace),
:mod:`~lieint.sweeps.info` (``lieint info SWEEP.zarr``), :mod:`~lieint.sweeps.cluster` (where the
chunks run, reached and checked first), :mod:`~lieint.sweeps.engine` (dask, the lock, commits).
dask, distributed and zarr are imported only when a sweep runs (``pip install "lieint[sweep]"``).
"""

from __future__ import annotations

from .api import sweep
from .integrity import DamagedStoreError, StoreError
from .keys import SceneKey, SweepKeyError, parse_key
from .plan import SweepError, SweepPlan, parse_vary, plan_from_scene, plan_from_systems

__all__ = [
    "DamagedStoreError",
    "SceneKey",
    "StoreError",
    "SweepError",
    "SweepKeyError",
    "SweepPlan",
    "open_sweep",
    "parse_key",
    "parse_vary",
    "plan_from_scene",
    "plan_from_systems",
    "sweep",
]


def open_sweep(path, *, grid: bool = False, damaged: str = "raise"):
    """Open a sweep store as an xarray Dataset, its chunks verified first (see
    :func:`lieint.sweeps.store.open_sweep`)."""
    from .store import open_sweep as _open

    return _open(path, grid=grid, damaged=damaged)
