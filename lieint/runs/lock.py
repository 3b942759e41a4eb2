"""One writer per run file: an OS-level lock on ``RUN.h5.lock`` held for the whole run.

HDF5's own file locking cannot be relied on: a writer in SWMR mode holds no lock on the file
(HDF5 ≥ 1.10 releases it), so a second process could open the same file for writing and both
would report success over a corrupted result. Every writer of a run (``run``, ``resume`` and
``overwrite`` alike) therefore first takes an exclusive :func:`fcntl.flock` on the sidecar file
``RUN.h5.lock`` and keeps it until the run has ended; the lock is released by the kernel when the
process dies, so a killed run never leaves a stale lock behind. The holder writes its pid, host
and start time into the file, so that a refused writer can say who holds the run.

The sidecar is removed when the run ends. Removing a lock file is racy unless the taker checks,
after locking, that the path still names the inode it locked (else it retries): that check is
:meth:`RunLock.acquire`'s loop.
"""

from __future__ import annotations

import errno
import json
import os
import socket
import stat
import time
from pathlib import Path

from .store import StoreError

__all__ = ["RunLock", "RunLockedError"]


class RunLockedError(StoreError):
    """Another process is writing the run (its pid, host and start time are in the message)."""


class RunLock:
    """The exclusive lock of one run file (``with RunLock(out):`` or ``acquire`` / ``release``).

    Parameters
    ----------
    out : path
        The run file; the lock is ``out`` + ``".lock"`` in the same directory.
    kind : str
        What ``out`` is, in the message to a refused writer (a sweep store takes the same lock).
    """

    def __init__(self, out, kind: str = "run file"):
        self.out, self.kind = Path(out), kind
        self.path = Path(str(out) + ".lock")
        self.fd: int | None = None

    def acquire(self) -> RunLock:
        """Take the lock at once, or raise :class:`RunLockedError` naming the holder."""
        import fcntl

        for _ in range(100):  # a holder may remove the file between our open and our lock: retry
            try:
                # never follow a symlink planted at the lock's name; never block on a FIFO
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC, 0o644)
            except OSError as exc:
                if exc.errno == errno.ELOOP:
                    raise StoreError(
                        f"the lock file {str(self.path)!r} is a symbolic link; refusing to use it (remove it)"
                    ) from None
                raise StoreError(f"cannot create the lock file {str(self.path)!r}: {exc.strerror or exc}") from None
            try:
                st = os.fstat(fd)
                if not stat.S_ISREG(st.st_mode):
                    raise StoreError(f"the lock file {str(self.path)!r} is not a regular file; refusing to use it")
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except BlockingIOError:
                    raise RunLockedError(self._held_message(fd)) from None
                try:
                    now = os.stat(self.path, follow_symlinks=False)
                except FileNotFoundError:
                    now = None
                if now is None or (now.st_ino, now.st_dev) != (st.st_ino, st.st_dev):
                    os.close(fd)  # the previous holder removed this file after we opened it
                    continue
                holder = {"pid": os.getpid(), "host": socket.gethostname(), "started": _utc_now()}
                os.ftruncate(fd, 0)
                os.pwrite(fd, (json.dumps(holder) + "\n").encode(), 0)
                os.fsync(fd)
            except BaseException:
                os.close(fd)
                raise
            self.fd = fd
            return self
        raise StoreError(f"cannot take the lock {str(self.path)!r}: it keeps being replaced")  # pragma: no cover

    def _held_message(self, fd: int) -> str:
        try:
            holder = json.loads(os.pread(fd, 4096, 0).decode() or "{}")
        except (OSError, ValueError):
            holder = {}
        who = (
            f"process {holder.get('pid', '?')} on host {holder.get('host', '?')} (started {holder.get('started', '?')})"
            if holder
            else "another process"
        )
        return (
            f"{str(self.out)!r} is being written by {who}; only one writer per {self.kind}. Wait for it to "
            f"finish or stop it (its lock is {str(self.path)!r}, released when that process ends)."
        )

    def release(self) -> None:
        """Remove the lock file and release the lock (removal first, while still holding it)."""
        if self.fd is None:
            return
        try:
            try:
                st = os.fstat(self.fd)
                now = os.stat(self.path, follow_symlinks=False)
                if (now.st_ino, now.st_dev) == (st.st_ino, st.st_dev):
                    os.unlink(self.path)
            except OSError:
                pass  # already gone or unreadable: the kernel lock is what counts
        finally:
            os.close(self.fd)
            self.fd = None

    def __enter__(self) -> RunLock:
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


def _utc_now() -> str:
    return time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())
