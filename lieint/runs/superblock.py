"""The HDF5 superblock of a run file, read and mended without the HDF5 library.

A writer killed mid-run leaves HDF5's "open for writing" flags set in the superblock (versions
2 and 3), and HDF5 then refuses to open the file for writing; :func:`clear_crash_flags` does what
``h5clear -s`` does, under the file's lock, after checking the superblock's checksum
(:func:`lookup3`, Bob Jenkins' hash that HDF5 uses). :mod:`lieint.runs.reading` parses the same
superblock to say whether a file is complete.
"""

from __future__ import annotations

import os

from .errors import StoreError

__all__ = ["clear_crash_flags", "lookup3", "superblock_offset"]


def lookup3(data: bytes, initval: int = 0) -> int:
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


def superblock_offset(fh) -> int | None:
    """Where the HDF5 signature is (0 or after a user block of 512, 1024, ... bytes)."""
    size = os.fstat(fh.fileno()).st_size
    offset = 0
    while offset == 0 or offset < size:
        fh.seek(offset)
        if fh.read(8) == b"\x89HDF\r\n\x1a\n":
            return offset
        offset = 512 if offset == 0 else 2 * offset
    return None


def clear_crash_flags(path) -> bool:
    """What ``h5clear -s`` does: reset the "open for writing" flags a killed writer left set.

    HDF5 ≥ 1.10 marks the superblock (version 2/3) while a file is open for writing and
    refuses to open it for writing again until the flag is cleared. The file's data up to the
    writer's last flush is intact (SWMR ordering); the checkpoint says how much of it counts.
    Refused if another process still holds the file's lock (a run still writing it).
    A file shorter than its superblock records (a write that failed on a full disk) is given
    its length back; returns True then, and the caller verifies the rows it keeps.
    """
    import fcntl

    try:
        fd = os.open(path, os.O_RDWR | os.O_NOFOLLOW | os.O_CLOEXEC)
        with os.fdopen(fd, "rb+") as fh:
            try:
                fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise StoreError(f"{str(path)!r} is still being written by another process; stop it first") from None
            offset = superblock_offset(fh)
            fh.seek(offset or 0)
            head = bytearray(fh.read(64))
            if offset is None or head[8] not in (2, 3):
                return False
            end = 12 + 4 * head[9]
            if lookup3(bytes(head[:end])) != int.from_bytes(head[end : end + 4], "little"):
                raise StoreError(f"the output file {str(path)!r} is damaged: its superblock fails its checksum")
            so = head[9]
            stored_eof = int.from_bytes(head[12 + 2 * so : 12 + 3 * so], "little")
            repaired = stored_eof > os.fstat(fh.fileno()).st_size
            if repaired:
                # a write failed (full disk, file-size limit) after HDF5 had reserved the space:
                # give the file its recorded length back (zeros) so that HDF5 opens it; the rows
                # the checkpoint counts are verified against their checksums after reopening
                os.ftruncate(fh.fileno(), stored_eof)
            if head[11] != 0:
                head[11] = 0
                head[end : end + 4] = lookup3(bytes(head[:end])).to_bytes(4, "little")
                fh.seek(offset)
                fh.write(bytes(head[: end + 4]))
            fh.flush()
            os.fsync(fh.fileno())
            return repaired
    except OSError as exc:
        raise StoreError(f"cannot open {str(path)!r} to resume: {exc}") from None
