"""A compilation flag shared by the kernels' small functions: no reference counting.

A call from one compiled function to another passes each array with its reference count:
numba increments it on entry and decrements it on exit — two calls into its runtime and two
atomic operations per array, several nanoseconds a pair on a virtual machine. The n-dimensional
top's stage makes about a dozen such calls on three to seven arrays each (the unrolled products
two deep, the Cayley map three deep): RKMK6 in Cayley coordinates at n = 6 spent 10.3–10.7 µs
per step, 6.3–7.1 µs with the counts gone (``benchmarks/systems_speed.py``'s 6D top, the two
checkouts alternated, 2026-11-28).

Functions that allocate nothing and keep no array are compiled with :data:`NO_REFCOUNT`
(``_nrt=False``, numba's flag for code that runs without its runtime): the arrays they are given
stay owned by their caller. Numba refuses to compile an allocation under the flag, and compiles
a function's callees under it too, so a function that may allocate (a BLAS fallback that copies
its operands) keeps its counts and is inlined (``inline="always"``) into its callers instead.
"""

from __future__ import annotations

__all__ = ["NO_REFCOUNT"]

#: keyword arguments of ``numba.njit`` for a function that allocates nothing
NO_REFCOUNT = {"_nrt": False}
