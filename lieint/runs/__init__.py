"""Long runs streamed to HDF5 with checkpoints, progress, monitors and plots."""

from .runner import RunReport, run, scene_fingerprint
from .store import Checkpoint, OutputFile, StoreError

__all__ = ["Checkpoint", "OutputFile", "RunReport", "StoreError", "run", "scene_fingerprint"]
