"""Where a sweep's chunks run: a LocalCluster on this machine, or an existing dask cluster.

An existing cluster is reached and checked **before anything is created** (no store, no lock
left behind), within a bounded time, and every failure is one line saying what was expected:

* the address must be ``tcp://``, ``tls://``, ``ws://``, ``wss://`` or ``ucx://`` with a host
  and a port (``file:///etc/passwd`` is refused as such);
* a probe in a separate Python process (:func:`probe_scheduler`) connects, completes dask's
  handshake and asks the scheduler and its workers for their versions; it is killed at its
  deadline. A server that accepts and never answers (distributed's own ``timeout`` does not
  bound its handshake), or answers with other bytes (whose length prefix can make distributed
  allocate exabytes), is thus refused without touching this process;
* the scheduler must run this Python (major.minor), dask, distributed, msgpack and
  cloudpickle; it must have workers, and each must import this version of lieint.

A LocalCluster runs its workers as processes of this one's (distributed's nannies end them when
this process dies), its logs kept to errors so that a normal end prints nothing.
"""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
import threading
from urllib.parse import urlsplit

from ..limits import check
from .plan import SweepError

__all__ = ["CONNECT_SECONDS", "Cluster", "check_address", "check_scheduler", "check_workers", "probe_scheduler"]

#: seconds allowed for reaching a scheduler and completing the handshake and version check
CONNECT_SECONDS = 20.0
SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")
_THREAD_VARIABLES = ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
#: packages whose versions must agree between this client and the scheduler (the protocol)
_PROTOCOL_PACKAGES = ("dask", "distributed", "msgpack", "cloudpickle")


def _distributed():
    try:
        import distributed
    except ImportError:  # pragma: no cover - the sweep extra is not installed
        raise ImportError('sweeps need dask, distributed and zarr: pip install "lieint[sweep]"') from None
    return distributed


def check_address(address: str) -> str:
    """The scheduler address, checked to be ``SCHEME://HOST:PORT`` of a dask protocol."""
    text = str(address).strip()
    parts = urlsplit(text)
    expected = "a scheduler address such as 'tcp://10.0.0.5:8786', 'synchronous' or a distributed.Client"
    if parts.scheme not in SCHEMES:
        raise SweepError(
            f"`scheduler` must be {expected}; got {text!r}, whose scheme {parts.scheme or '(none)'!r} is not one of "
            f"dask's {list(SCHEMES)}"
        )
    try:
        port = parts.port
    except ValueError:
        port = None
    if not parts.hostname or port is None or parts.path not in ("", "/") or parts.query or parts.fragment:
        raise SweepError(f"`scheduler` must be {expected}: {parts.scheme}://HOST:PORT; got {text!r}")
    return text


_PROBE = r"""
import json, logging, sys
logging.disable(logging.CRITICAL)  # distributed's own lines: the caller says what went wrong
address, timeout = sys.argv[1], float(sys.argv[2])

def lieint_version():
    try:
        import lieint
        return lieint.__version__
    except Exception as exc:
        return "!" + type(exc).__name__ + ": " + str(exc)

try:
    import distributed
    with distributed.Client(address, timeout=timeout, set_as_default=False) as client:
        versions = client.get_versions(check=False)
        workers = client.run(lieint_version) if versions["workers"] else {}
    answer = {"scheduler": versions["scheduler"]["packages"], "workers": workers}
except BaseException as exc:
    answer = {"error": type(exc).__name__ + ": " + " ".join(str(exc).split())[:300]}
sys.stdout.write("\n" + json.dumps(answer) + "\n")
sys.stdout.flush()
import os
os._exit(0)  # without distributed's exit handlers, which can wait on a connection that hangs
"""


def probe_scheduler(address: str, timeout: float = CONNECT_SECONDS) -> dict:
    """Reach the scheduler at ``address`` from a separate process killed after ``timeout`` s.

    Returns ``{"scheduler": {package: version}, "workers": {address: lieint version}}``;
    raises :class:`SweepError` (one line) when it cannot be reached, does not answer in time,
    or does not speak dask's protocol.
    """
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    try:
        done = subprocess.run(
            [sys.executable, "-c", _PROBE, address, str(max(1.0, 0.8 * timeout))],
            capture_output=True,
            text=True,
            timeout=timeout,
            env=env,
            stdin=subprocess.DEVNULL,
        )
    except subprocess.TimeoutExpired as exc:
        said = exc.stdout.decode(errors="replace") if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        if not any(line.startswith("{") for line in said.splitlines()):
            raise SweepError(
                f"the dask scheduler at {address} did not complete dask's handshake within {timeout:g} s (is a dask "
                "scheduler listening there?); nothing was created"
            ) from None
        done = subprocess.CompletedProcess(exc.cmd, -9, said, "")
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    try:
        answer = json.loads(lines[-1])
    except (IndexError, ValueError):
        tail = " ".join(done.stderr.split())[-300:]
        raise SweepError(
            f"cannot reach the dask scheduler at {address}: the probe failed ({tail or 'no answer'})"
        ) from None
    if "error" in answer:
        raise SweepError(
            f"cannot reach the dask scheduler at {address}: {_short_error(answer['error'])}; nothing was created"
        )
    return answer


def _short_error(text: str) -> str:
    if text.startswith(("OSError", "TimeoutError", "CommClosedError")) and "Timed out" in text:
        return "no dask scheduler answered (" + text.split(":", 1)[0] + ": timed out)"
    if text.startswith(("ValueError", "MemoryError", "OverflowError", "TypeError", "KeyError")):
        return f"it does not speak dask's protocol ({text})"
    return text


def check_versions(address: str, answer: dict) -> int:
    """Refuse a scheduler whose protocol packages or whose workers' lieint differ from this
    process's; returns the number of workers."""
    distributed = _distributed()
    from .._version import __version__

    here = distributed.versions.get_versions()["packages"]
    theirs = answer.get("scheduler") or {}
    mine_py, their_py = str(here.get("python", "")), str(theirs.get("python", ""))
    if mine_py.split(".")[:2] != their_py.split(".")[:2]:
        raise SweepError(
            f"the dask scheduler at {address} runs Python {their_py or '?'}, this process {mine_py}: client, scheduler "
            "and workers must run the same Python (major.minor)"
        )
    for name in _PROTOCOL_PACKAGES:
        if str(theirs.get(name)) != str(here.get(name)):
            raise SweepError(
                f"the dask scheduler at {address} runs {name} {theirs.get(name)}, this process {here.get(name)}: "
                f"client and cluster must run the same {', '.join(_PROTOCOL_PACKAGES)}"
            )
    workers = answer.get("workers") or {}
    if not workers:
        raise SweepError(
            f"the dask scheduler at {address} has no workers; start some (dask worker {address}) and try again"
        )
    wrong = {w: v for w, v in workers.items() if v != __version__}
    if wrong:
        worker, version = sorted(wrong.items())[0]
        said = f"cannot import lieint ({version[1:]})" if str(version).startswith("!") else f"runs lieint {version}"
        raise SweepError(
            f"{len(wrong)} of the {len(workers)} workers of {address} cannot run this sweep: {worker} {said}; every "
            f"worker needs lieint {__version__} installed"
        )
    return len(workers)


def _connect_bounded(address: str, timeout: float):
    """A client of ``address``, or :class:`SweepError` once ``timeout`` s have passed."""
    distributed = _distributed()
    box: dict = {}

    def connect():
        try:
            box["client"] = distributed.Client(address, timeout=timeout, set_as_default=False)
        except BaseException as exc:
            box["error"] = exc

    thread = threading.Thread(target=connect, name="lieint-sweep-connect", daemon=True)
    thread.start()
    thread.join(timeout + 1.0)
    if "client" in box:
        return box["client"]
    what = f"{type(box['error']).__name__}: {box['error']}" if "error" in box else f"no answer within {timeout:g} s"
    raise SweepError(f"cannot connect to the dask scheduler at {address}: {what}")


class Cluster:
    """The dask client a sweep runs on, and its cluster when the sweep started one.

    ``with Cluster(scheduler, workers) as cluster:`` — ``cluster.client``, ``cluster.workers``,
    ``cluster.where``; closed quietly at the end (a client the caller passed stays open).

    Parameters
    ----------
    scheduler : None, str or distributed.Client
        None: a LocalCluster of ``workers`` processes; an address: an existing cluster, probed
        and checked first (:func:`probe_scheduler`, :func:`check_versions`); a client: used as is.
    workers : int, optional
        Worker processes of the LocalCluster (default: the number of CPUs).
    threads_per_worker : int
    timeout : float
        Seconds allowed to reach an existing scheduler (handshake and checks included).
    """

    def __init__(self, scheduler=None, workers: int | None = None, threads_per_worker: int = 1,
                 timeout: float = CONNECT_SECONDS):  # fmt: skip
        self.scheduler, self.nworkers = scheduler, workers
        self.threads_per_worker, self.timeout = threads_per_worker, timeout
        self.client = self.cluster = None
        self.workers, self.where = 0, ""
        self._own_client = False

    def __enter__(self) -> Cluster:
        distributed = _distributed()
        if isinstance(self.scheduler, distributed.Client):
            self.client, self.where = self.scheduler, str(self.scheduler.scheduler.address)
            self.workers = len(self.client.scheduler_info(n_workers=-1)["workers"])
            return self
        self._own_client = True
        if self.scheduler is not None:
            address = check_address(self.scheduler)
            self.workers = check_versions(address, probe_scheduler(address, self.timeout))
            self.client, self.where = _connect_bounded(address, self.timeout), address
            return self
        env = {name: str(self.threads_per_worker) for name in _THREAD_VARIABLES}
        self.cluster = distributed.LocalCluster(
            n_workers=self.nworkers,
            threads_per_worker=self.threads_per_worker,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,  # a normal end logs no "still alive, killing" warnings
            env=env,
        )
        self.client = distributed.Client(self.cluster, set_as_default=False)
        self.workers, self.where = len(self.cluster.workers), f"LocalCluster({self.nworkers} workers)"
        return self

    def __exit__(self, *exc) -> None:
        # the logs of closing (a nanny killing a worker that took long to stop) are not news:
        # every committed chunk is on disk by now
        quiet = [logging.getLogger(name) for name in ("distributed", "distributed.nanny", "distributed.worker")]
        levels = [log.level for log in quiet]
        for log in quiet:
            log.setLevel(logging.CRITICAL)
        try:
            if self._own_client and self.client is not None:
                self.client.close(timeout=10)
            if self.cluster is not None:
                self.cluster.close(timeout=20)
        except Exception:
            pass  # closing is best effort: the workers end with this process regardless
        finally:
            for log, level in zip(quiet, levels, strict=True):
                log.setLevel(level)


def check_workers(workers, nchunks: int) -> int:
    """The LocalCluster's worker processes: ``workers`` (default: the CPUs) checked against
    ``LIEINT_MAX_WORKERS``, and no more than there are chunks (the others would sit idle)."""
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise SweepError(f"`workers` must be a positive integer (worker processes); got {workers!r}")
    if workers is not None:
        check(
            "LIEINT_MAX_WORKERS",
            workers,
            "--workers: the number of worker processes",
            f"each is a process of its own; this machine has {os.cpu_count() or 1} CPUs",
        )
    return max(1, min(workers or os.cpu_count() or 1, nchunks))


def check_scheduler(scheduler) -> None:
    """Refuse a ``scheduler`` that is neither None, an address nor a distributed.Client."""
    if scheduler is None:
        return
    if isinstance(scheduler, str):
        check_address(scheduler)
        return
    if "distributed" in sys.modules and isinstance(scheduler, sys.modules["distributed"].Client):
        return
    raise SweepError(
        "`scheduler` must be a scheduler address such as 'tcp://10.0.0.5:8786', 'synchronous' or a "
        f"distributed.Client; got {scheduler!r}"
    )
