"""Long runs streamed to HDF5 with checkpoints, progress, monitors and plots.

A run file is written by exactly one process (:mod:`lieint.runs.lock`), replaced only when it
is a lieint run (:mod:`lieint.runs.files`), checksummed (Fletcher-32 chunks, SHA-256 of the
attributes and of the checkpoint) and read in bounded time (:mod:`lieint.runs.reading`,
:func:`lieint.runs.info.inspect_run`).
"""

from .lock import RunLock, RunLockedError
from .runner import RunReport, StreamedRun, run, scene_fingerprint
from .store import Checkpoint, NoSpaceError, OutputFile, StoreError

__all__ = [
    "Checkpoint",
    "NoSpaceError",
    "OutputFile",
    "RunLock",
    "RunLockedError",
    "RunReport",
    "StoreError",
    "StreamedRun",
    "run",
    "scene_fingerprint",
]
