"""The finiteness check of a compiled segment's output, compiled.

A kernel loop checks every saved row and the final state for NaN and infinity before it accepts
a segment (a non-finite state is reported with the step at which it appeared). For a single
trajectory those are a few small arrays, and numpy's ``isfinite`` and reduction cost a
microsecond or two per array in calls alone; one compiled pass over all of them costs a fraction.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["all_finite"]


@njit(cache=True)
def _all_finite(arrays):
    for arr in arrays:
        for x in arr:
            if not np.isfinite(x):
                return False
    return True


def all_finite(arrays) -> bool:
    """True when every entry of every array in ``arrays`` (float64, as the kernels write them) is finite."""
    return bool(_all_finite(tuple(a.ravel() for a in arrays)))
