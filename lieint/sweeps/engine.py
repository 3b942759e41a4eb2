"""Run a sweep's chunks on dask.distributed and commit them to the store as they finish.

* Default: a :class:`distributed.LocalCluster` of worker *processes* on this machine (one thread
  each, with numba/BLAS limited to that thread, so K workers use K cores);
  ``scheduler="tcp://host:8786"`` runs on an existing cluster unchanged (its workers need
  lieint installed; the client writes the store, so no shared file system is needed);
  ``scheduler="synchronous"`` runs every chunk in this process (the reference).
* Each chunk is one task. A worker that dies mid-chunk (killed, out of memory) has its task
  rescheduled by the scheduler on another worker; a task that raises is retried ``retries`` times.
* The client commits each finished chunk (:class:`~lieint.sweeps.store.SweepStore`), so an
  interrupted sweep keeps every committed chunk and ``resume=True`` computes only the others.
* A progress bar (dask's ``TextProgressBar``) shows the chunks on a terminal.
"""

from __future__ import annotations

import os
import sys
import threading
import time
import uuid
from dataclasses import dataclass, field

from .chunk import compute_chunk
from .plan import SweepError, SweepPlan
from .store import SweepStore

__all__ = ["SweepReport", "run_sweep"]

_THREAD_VARIABLES = ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


@dataclass
class SweepReport:
    """How a sweep went.

    Attributes
    ----------
    path : str
        The store.
    status : {"complete", "failed"}
    nchunks, computed, skipped : int
        Chunks of the plan, computed by this call, and skipped as already committed (resume).
    nmembers : int
    wall_time : float
        Seconds of this call.
    workers : int
        Workers of the cluster (0: synchronous, in this process).
    scheduler : str
        Where it ran.
    backends : list of str
        The back ends the chunks ran on.
    """

    path: str
    status: str
    nchunks: int
    computed: int
    skipped: int
    nmembers: int
    wall_time: float
    workers: int
    scheduler: str
    backends: list[str] = field(default_factory=list)


def _dask():
    try:
        import distributed
    except ImportError:  # pragma: no cover - the sweep extra is not installed
        raise ImportError('sweeps need dask, distributed and zarr: pip install "lieint[sweep]"') from None
    return distributed


def _check_where(scheduler, workers) -> None:
    if isinstance(scheduler, str) and scheduler != "synchronous" and "://" not in scheduler:
        raise SweepError(
            f"`scheduler` must be a scheduler address such as 'tcp://10.0.0.5:8786', 'synchronous' or a "
            f"distributed.Client; got {scheduler!r}"
        )
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise SweepError(f"`workers` must be a positive integer (worker processes); got {workers!r}")


def _connect(scheduler, workers, threads_per_worker):
    """(client, cluster or None, description)."""
    distributed = _dask()
    if isinstance(scheduler, distributed.Client):
        return scheduler, None, str(scheduler.scheduler.address)
    if scheduler is not None:
        if not isinstance(scheduler, str) or "://" not in scheduler:
            raise SweepError(
                f"`scheduler` must be a scheduler address such as 'tcp://10.0.0.5:8786', 'synchronous' or a "
                f"distributed.Client; got {scheduler!r}"
            )
        try:
            client = distributed.Client(scheduler, timeout="20s")
        except OSError as exc:
            raise SweepError(f"cannot reach the dask scheduler at {scheduler}: {exc}") from None
        return client, None, scheduler
    if workers is None:
        workers = os.cpu_count() or 1
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise SweepError(f"`workers` must be a positive integer (worker processes); got {workers!r}")
    env = {name: str(threads_per_worker) for name in _THREAD_VARIABLES}
    cluster = distributed.LocalCluster(
        n_workers=workers,
        threads_per_worker=threads_per_worker,
        processes=True,
        dashboard_address=":0",
        env=env,
    )
    return distributed.Client(cluster), cluster, f"LocalCluster({workers} workers)"


def _progress_thread(futures, client):
    from distributed.diagnostics.progressbar import TextProgressBar

    def show():
        try:
            TextProgressBar(futures, scheduler=client.scheduler.address, complete=True, start=True)
        except Exception:
            pass

    thread = threading.Thread(target=show, name="lieint-sweep-progress", daemon=True)
    thread.start()
    return thread


def run_sweep(
    plan: SweepPlan,
    out,
    *,
    scheduler=None,
    workers: int | None = None,
    threads_per_worker: int = 1,
    resume: bool = False,
    overwrite: bool = False,
    progress="auto",
    backend: str = "auto",
    retries: int = 2,
) -> SweepReport:
    """Compute the plan's chunks that are not committed yet and commit them to ``out``.

    Parameters
    ----------
    plan : SweepPlan
    out : path
        The Zarr store.
    scheduler : None, str or distributed.Client
        None: a LocalCluster of ``workers`` processes; ``"tcp://…"``: an existing cluster;
        ``"synchronous"``: this process; or a connected client.
    workers : int, optional
        Worker processes of the LocalCluster (default: the number of CPUs).
    threads_per_worker : int, default 1
    resume, overwrite : bool
        See :class:`~lieint.sweeps.store.SweepStore`.
    progress : bool or "auto"
        A progress bar ("auto": when standard output is a terminal).
    backend : {"auto", "numpy", "numba"}
        As for :func:`lieint.integrate`.
    retries : int
        Retries of a chunk that raised (a chunk whose worker died is rescheduled regardless).

    Returns
    -------
    SweepReport
    """
    t0 = time.perf_counter()
    if backend not in ("auto", "numpy", "numba"):
        raise SweepError(f"`backend` must be one of ['auto', 'numpy', 'numba']; got {backend!r}")
    _check_where(scheduler, workers)  # before any store is written
    store = SweepStore(out, plan, resume=resume, overwrite=overwrite)
    done = set(store.committed().tolist())
    todo = [c for c in range(plan.nchunks) if c not in done]
    session = uuid.uuid4().hex[:12]
    show = sys.stdout.isatty() if progress == "auto" else bool(progress)
    backends: set[str] = set()

    def commit(result):
        store.commit(result, session)
        backends.add(result.meta["backend"])

    try:
        if scheduler == "synchronous":
            for c in todo:
                commit(compute_chunk(plan, c, backend))
            nworkers, where = 0, "synchronous"
        else:
            client, cluster, where = _connect(scheduler, workers, threads_per_worker)
            try:
                nworkers = (
                    len(client.scheduler_info(n_workers=-1)["workers"]) if cluster is None else len(cluster.workers)
                )
                _run_distributed(client, plan, todo, backend, retries, session, commit, show)
            finally:
                if client is not scheduler:  # a client the caller passed stays open
                    client.close()
                if cluster is not None:
                    cluster.close()
    except Exception as exc:
        store.finish("failed", f"{type(exc).__name__}: {exc}")
        raise
    store.finish("complete")
    return SweepReport(
        path=str(out),
        status="complete",
        nchunks=plan.nchunks,
        computed=len(todo),
        skipped=len(done),
        nmembers=plan.nmembers,
        wall_time=time.perf_counter() - t0,
        workers=nworkers,
        scheduler=where,
        backends=sorted(backends),
    )


def _run_distributed(client, plan, todo, backend, retries, session, commit, show) -> None:
    from distributed import as_completed

    futures = [
        client.submit(
            compute_chunk,
            plan,
            c,
            backend,
            key=f"lieint-sweep-chunk-{c}-{session}",
            retries=retries,
            pure=False,
        )
        for c in todo
    ]
    bar = _progress_thread(futures, client) if show and futures else None
    try:
        for future in as_completed(futures):
            try:
                result = future.result()
            except Exception as exc:
                c = todo[futures.index(future)]
                raise SweepError(
                    f"chunk {c} (members {plan.chunk_range(c)[0]}..{plan.chunk_range(c)[1] - 1}) failed after "
                    f"{retries} retries: {type(exc).__name__}: {exc}; the committed chunks are kept (resume)"
                ) from exc
            commit(result)
            future.release()
    finally:
        for future in futures:
            future.cancel()
        if bar is not None:
            bar.join(timeout=2.0)
            print(file=sys.stdout)
