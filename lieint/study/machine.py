"""The machine and thread settings a study ran with (recorded next to every table).

Timings mean nothing without the machine they were taken on: the processor, the number of
cores, the library versions and, above all, how many threads each layer may use (numba's
thread pool for the compiled kernels, the BLAS behind numpy). :func:`machine_info` gathers
them; :func:`set_threads` fixes numba's pool for the run.
"""

from __future__ import annotations

import os
import platform
import sys
from datetime import datetime, timezone

__all__ = ["machine_info", "set_threads"]

#: environment variables that cap the threads of the BLAS / OpenMP layers under numpy and scipy
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")


def set_threads(threads: int | None) -> int | None:
    """Let numba's compiled kernels use ``threads`` threads (None: leave numba's default).

    Returns the number of threads numba will use, or None when numba is not installed.

    Raises
    ------
    ValueError
        ``threads`` is not a positive integer, or above numba's pool size.
    """
    if threads is not None and (not isinstance(threads, int) or isinstance(threads, bool) or threads < 1):
        raise ValueError(f"`threads` must be a positive integer or None; got {threads!r}.")
    try:
        import numba
    except ImportError:  # pragma: no cover - numba is a dependency
        return None
    if threads is not None:
        pool = int(numba.config.NUMBA_NUM_THREADS)
        if threads > pool:
            raise ValueError(
                f"`threads` = {threads} exceeds numba's thread pool of {pool} (set NUMBA_NUM_THREADS before starting)."
            )
        numba.set_num_threads(threads)
    return int(numba.get_num_threads())


def machine_info(threads: int | None = None) -> dict:
    """What the timings of a study depend on.

    Parameters
    ----------
    threads : int, optional
        The thread count the study asked for (recorded as given; None means the default).

    Returns
    -------
    dict
        ``platform``, ``processor``, ``machine``, ``cpu_count``, ``python``, the versions of
        lieint, numpy, scipy and numba, ``numba_threads`` (threads the compiled kernels use
        now), ``threads_requested``, the thread-capping environment variables, the load average
        (1 minute; on a loaded machine wall times include waiting, CPU times much less) and the
        UTC date.
    """
    import numpy
    import scipy

    from .._version import __version__

    try:
        import numba

        numba_version, numba_threads = numba.__version__, int(numba.get_num_threads())
    except ImportError:  # pragma: no cover - numba is a dependency
        numba_version, numba_threads = None, None
    processor = platform.processor() or platform.machine()
    try:  # the model name is more telling than the architecture where the kernel gives it
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    processor = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {
        "platform": platform.platform(),
        "processor": processor,
        "machine": platform.machine(),
        "cpu_count": os.cpu_count(),
        "python": sys.version.split()[0],
        "lieint": __version__,
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "numba": numba_version,
        "numba_threads": numba_threads,
        "threads_requested": threads,
        "environment": {name: os.environ.get(name) for name in THREAD_VARIABLES},
        "load_average": _load_average(),
        "date": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
    }


def _load_average() -> float | None:
    """The 1-minute load average, where the system reports one."""
    try:
        return round(os.getloadavg()[0], 2)
    except (AttributeError, OSError):  # pragma: no cover - e.g. Windows
        return None
