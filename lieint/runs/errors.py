"""What the run files' modules share at the bottom: the errors they raise, the size of the
HDF5 user block that carries the run marker, and the words for what a path is.

Kept apart so that the modules that write (:mod:`.store`, :mod:`.files`), read
(:mod:`.reading`) and mend (:mod:`.superblock`) run files import it and not each other.
"""

from __future__ import annotations

import errno
import os
import stat

__all__ = ["USER_BLOCK", "NoSpaceError", "StoreError", "describe_kind", "is_no_space"]


#: bytes before the HDF5 superblock, left to the application: the run marker goes there
USER_BLOCK = 512


class StoreError(ValueError):
    """An output or checkpoint that cannot be used; the message says which and why."""


class NoSpaceError(StoreError):
    """The disk is full or the file-size limit (``ulimit -f``) was reached while writing."""


#: errno values of a full disk, an exceeded file-size limit or quota
_NO_SPACE = {errno.ENOSPC, errno.EFBIG, errno.EDQUOT}
_NO_SPACE_WORDS = ("no space left", "file too large", "disk quota", "errno = 28", "errno = 27", "errno = 122")


def is_no_space(exc: BaseException) -> bool:
    """True for an OSError of a full disk or file-size limit (h5py's errors carry it in the text)."""
    if getattr(exc, "errno", None) in _NO_SPACE:
        return True
    text = str(exc).lower()
    return any(w in text for w in _NO_SPACE_WORDS)


def describe_kind(st: os.stat_result) -> str:
    """What a non-regular file is, in words."""
    mode = st.st_mode
    for test, name in (
        (stat.S_ISDIR, "a directory"),
        (stat.S_ISLNK, "a symbolic link"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return name
    return "a regular file" if stat.S_ISREG(mode) else "not a regular file"
