"""Run a sweep's chunks on dask.distributed and commit them to the store as they finish.

* Default: a :class:`distributed.LocalCluster` of worker *processes* on this machine (one thread
  each, with numba/BLAS limited to that thread, so K workers use K cores);
  ``scheduler="tcp://host:8786"`` runs on an existing cluster unchanged (its workers need
  lieint installed; the client writes the store, so no shared file system is needed);
  ``scheduler="synchronous"`` runs every chunk in this process (the reference).
  :mod:`lieint.sweeps.cluster` reaches and checks the cluster before anything is created.
* One writer per store: the sweep holds the store's lock (``SWEEP.zarr.lock``,
  :class:`lieint.runs.lock.RunLock`) from before it looks at the store until it has ended; a
  second writer is refused at once with the holder's pid, host and start time.
* Sizes are checked before anything is allocated (:mod:`lieint.limits`, in the plan) and the
  store's bytes against the free room and the file-size limit (:func:`check_room`).
* Each chunk is one task. A worker that dies mid-chunk (killed, out of memory) has its task
  rescheduled by the scheduler on another worker; a task that raises is retried ``retries`` times.
* The client commits each finished chunk with its checksums (:class:`~lieint.sweeps.store.SweepStore`),
  so an interrupted sweep keeps every committed chunk and ``resume=True`` computes only the
  others, and the committed ones that fail their checksums.
* A progress bar (dask's ``TextProgressBar``) shows the chunks on a terminal.
"""

from __future__ import annotations

import os
import sys
import threading
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path

from .chunk import compute_chunk
from .cluster import CONNECT_SECONDS, Cluster, check_scheduler, check_workers
from .integrity import StoreError
from .plan import SweepError, SweepPlan
from .store import NoSpaceError, SweepStore, remove_stale_temporaries

__all__ = ["SweepReport", "check_room", "run_sweep"]


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
    damaged : dict
        ``{chunk: [what was wrong, ...]}``: committed chunks that failed their checksums on
        resume and were recomputed.
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
    damaged: dict[int, list[str]] = field(default_factory=dict)


def check_room(plan: SweepPlan, out: Path) -> None:
    """Refuse a sweep whose store cannot fit on the disk, or one of whose files cannot fit
    under the file-size limit (``ulimit -f``) — uncompressed sizes, an upper bound."""
    import resource

    from ..limits import env_flag
    from ..runs.streamed import human_bytes

    if env_flag("LIEINT_SKIP_ROOM_CHECK"):
        return
    how = "or set LIEINT_SKIP_ROOM_CHECK=1 to start anyway (Zstandard may compress it somewhat)"
    need = plan.store_bytes
    try:
        st = os.statvfs(out.parent)
        free = st.f_bavail * st.f_frsize
    except OSError:
        free = None
    if free is not None and need > free:
        raise StoreError(
            f"the sweep's store needs up to {human_bytes(need)} ({plan.nmembers} members × {plan.nsaves} save times × "
            f"{plan.row_bytes} bytes) but only {human_bytes(free)} are free in {str(out.parent)!r}; free space, "
            f"sweep fewer members or raise save_every, {how}"
        )
    soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    if soft != resource.RLIM_INFINITY and plan.chunk_file_bytes > soft:
        raise StoreError(
            f"one chunk's file of the store takes up to {human_bytes(plan.chunk_file_bytes)} but the file-size limit "
            f"(ulimit -f) is {human_bytes(soft)}; raise the limit, a smaller --chunk, {how}"
        )


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


def _check_output(out: Path) -> None:
    if not out.parent.is_dir():
        raise StoreError(f"cannot create the store {str(out)!r}: its directory {str(out.parent)!r} does not exist")


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
    connect_timeout: float = CONNECT_SECONDS,
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
        Worker processes of the LocalCluster (default: the number of CPUs; never more than
        the chunks).
    threads_per_worker : int, default 1
    resume, overwrite : bool
        See :class:`~lieint.sweeps.store.SweepStore`.
    progress : bool or "auto"
        A progress bar ("auto": when standard output is a terminal).
    backend : {"auto", "numpy", "numba"}
        As for :func:`lieint.integrate`.
    retries : int
        Retries of a chunk that raised (a chunk whose worker died is rescheduled regardless).
    connect_timeout : float
        Seconds allowed to reach an existing scheduler, its handshake and checks included.

    Returns
    -------
    SweepReport

    Raises
    ------
    SweepError
        Bad arguments, a store that may not be written (another writer holds it, it is not a
        lieint sweep store, another sweep's), a scheduler that cannot be used, a chunk that
        failed on every retry; :class:`~lieint.sweeps.store.NoSpaceError` for a full disk.
    """
    from ..runs.lock import RunLock
    from ..runs.store import StoreError as RunStoreError

    t0 = time.perf_counter()
    if backend not in ("auto", "numpy", "numba"):
        raise SweepError(f"`backend` must be one of ['auto', 'numpy', 'numba']; got {backend!r}")
    if resume and overwrite:
        raise SweepError(
            "`resume` and `overwrite` exclude each other: resume continues the store, overwrite replaces it"
        )
    synchronous = isinstance(scheduler, str) and scheduler == "synchronous"
    if not synchronous:
        check_scheduler(scheduler)
    nworkers = check_workers(workers, plan.nchunks)
    out = Path(out)
    _check_output(out)
    if not resume:
        check_room(plan, out)
    lock = RunLock(out, kind="sweep store")
    try:
        lock.acquire()  # held until the sweep has ended: one writer per store
    except RunStoreError as exc:
        raise StoreError(str(exc)) from None
    try:
        remove_stale_temporaries(out)
        SweepStore.check(out, plan, resume=resume, overwrite=overwrite)  # before a cluster is started
        from ..runs.runner import file_size_signal_ignored

        with file_size_signal_ignored():
            if synchronous:
                return _run(plan, out, None, resume, overwrite, progress, backend, retries, t0)
            with Cluster(scheduler, nworkers, threads_per_worker, connect_timeout) as cluster:
                return _run(plan, out, cluster, resume, overwrite, progress, backend, retries, t0)
    finally:
        lock.release()


def _run(plan, out, cluster, resume, overwrite, progress, backend, retries, t0) -> SweepReport:
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
        if cluster is None:
            for c in todo:
                commit(compute_chunk(plan, c, backend))
        else:
            _run_distributed(cluster.client, plan, todo, backend, retries, session, commit, show)
    except NoSpaceError as exc:
        _finish_quietly(store, "no-space", str(exc))
        raise
    except KeyboardInterrupt:
        _finish_quietly(store, "interrupted", "interrupted (Ctrl-C); continue with --resume")
        raise
    except Exception as exc:
        _finish_quietly(store, "failed", f"{type(exc).__name__}: {exc}")
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
        workers=0 if cluster is None else cluster.workers,
        scheduler="synchronous" if cluster is None else cluster.where,
        backends=sorted(backends),
        damaged=store.damaged,
    )


def _finish_quietly(store: SweepStore, status: str, message: str) -> None:
    """Record how the sweep ended, where the disk still takes it (a full disk may not)."""
    try:
        store.finish(status, message)
    except OSError:
        pass


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
        for future in as_completed(futures, loop=client.loop):
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
