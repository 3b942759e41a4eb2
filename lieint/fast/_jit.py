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

import types

from numba import njit

__all__ = ["NO_REFCOUNT", "compiled_copies"]

#: keyword arguments of ``numba.njit`` for a function that allocates nothing
NO_REFCOUNT = {"_nrt": False}


def compiled_copies(dispatchers, replacements: dict, suffix: str, **options) -> dict:
    """Compiled copies of numba ``dispatchers`` whose global names in ``replacements`` are bound
    to other functions (a product, say), and whose calls among themselves go to the copies;
    keyed by the originals' names, compiled with ``njit(cache=True, **options)``.

    One source, two sets of machine code: the n-dimensional top's kernels take the exponential
    with the unrolled products (:data:`lieint.fast.skew.expm_skew_small_into`) and, for n ≤ 8,
    stage functions whose products never reach BLAS, without reference counts
    (:mod:`lieint.fast.topn_step`). Each copy has its own qualified name, so numba caches it
    beside the original."""
    scopes, copies = [], {}
    for dispatcher in dispatchers:
        f = dispatcher.py_func
        scope = {**f.__globals__, **replacements}
        clone = types.FunctionType(f.__code__, scope, f.__name__ + suffix, f.__defaults__, f.__closure__)
        clone.__qualname__ = f.__qualname__ + suffix
        clone.__module__, clone.__doc__ = f.__module__, f.__doc__
        copies[f.__name__] = njit(cache=True, **options)(clone)
        scopes.append(scope)
    for scope in scopes:  # names are resolved when a copy compiles, on its first call
        scope.update(copies)
    return copies
