"""The finiteness check of a compiled segment's output, compiled.

A kernel loop checks every saved row and the final state for NaN and infinity before it accepts
a segment (a non-finite state is reported with the step at which it appeared). For a single
trajectory those are a few small arrays, and numpy's ``isfinite`` and reduction cost a
microsecond or two per array in calls alone; one compiled pass over all of them costs a fraction.

Why the bits. A double is NaN or infinite exactly when its eleven exponent bits are all set.
Testing them is integer arithmetic, which the compiler vectorises, OR-ing the test over a chunk
of 512 values before one branch; ``np.isfinite`` on each value with an early return compiled to
a scalar loop with a branch per value (about 1.5 ns a value: 0.2 ms for the two saved rows of
4,096 3D tops, A and R, and their final state; now a tenth of that).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["all_finite"]

#: the exponent bits of an IEEE 754 double: all set for NaN and ±inf only
_EXPONENT = np.uint64(0x7FF0000000000000)
_CHUNK = 512


@njit(cache=True)
def _all_finite(arrays):
    for arr in arrays:
        bits = arr.view(np.uint64)
        n = np.uint64(bits.shape[0])
        for start in range(np.uint64(0), n, np.uint64(_CHUNK)):
            nonfinite = 0
            # unsigned indices: a signed one may be negative (wrapped around) as far as the
            # compiler knows, which turns the loads into gathers
            for i in range(start, min(start + np.uint64(_CHUNK), n)):
                nonfinite |= (bits[i] & _EXPONENT) == _EXPONENT
            if nonfinite:
                return False
    return True


#: up to this many entries in all, the check sums them as Python floats instead
_SMALL = 256


def all_finite(arrays) -> bool:
    """True when every entry of every array in ``arrays`` (float64, as the kernels write them) is finite.

    A few entries in all (one body's saved rows, up to :data:`_SMALL`): finite when the sum of
    them as Python floats is (1 µs against 3 µs for the compiled call's arguments); a sum that
    overflows, or any larger output, takes the compiled pass."""
    total, size = 0.0, 0
    for a in arrays:
        size += a.size
        if size > _SMALL:
            break
        total += sum(a.ravel().tolist())
    else:
        if total - total == 0.0:
            return True
    return bool(_all_finite(tuple(np.ascontiguousarray(a).ravel() for a in arrays)))
