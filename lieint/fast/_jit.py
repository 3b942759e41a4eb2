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
    to other functions (a product, say) or values, and whose calls among themselves go to the
    copies; keyed by the originals' names, compiled with ``njit(cache=True, **options)``.

    One source, two sets of machine code: the n-dimensional top's kernels take the exponential
    with the unrolled products (:data:`lieint.fast.skew.expm_skew_small_into`) and, for n ≤ 8,
    stage functions whose products never reach BLAS, without reference counts
    (:mod:`lieint.fast.topn_step`). A global is a compile-time constant to numba, which drops
    the branches a constant decides before typing them: the generic step's copies per
    coordinates compile only their own coordinate map (:mod:`lieint.fast.generic_step`). Each
    copy has its own qualified name, so numba caches it beside the original."""
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


# -- the first compilation, announced ---------------------------------------------------------------
# numba compiles a function on its first call in an environment whose disk cache does not hold it
# yet (a fresh install, a new numba, a changed source): seconds to a minute of CPU time in which
# nothing else happens. The user is told, once per kernel, on stderr; a compilation that goes on
# gets a line every few seconds. LIEINT_COMPILE_NOTICE=0 silences it.

#: labels of the kernels whose first compilation is announced by name (dispatcher id -> label)
_LABELS: dict[int, str] = {}
#: lieint's functions compiled in this process so far (the disk cache could not spare them)
_COMPILED = [0]


def compilations() -> int:
    """How many of lieint's numba functions this process has compiled (not loaded from the disk
    cache) so far; the listener counts them from the first use of the engine on."""
    _install_notice()
    return _COMPILED[0]


_NOTICE_AFTER = 2.0  # seconds: an unnamed compilation this long is mentioned too
_PROGRESS_EVERY = 10.0  # seconds between "still compiling" lines


def announced(dispatcher, label: str):
    """``dispatcher`` with its first compilation announced on stderr as ``label``."""
    _LABELS[id(dispatcher)] = label
    _install_notice()
    return dispatcher


class _Notice:
    """A numba event listener (``numba:compile``: a compilation the disk cache could not spare)
    that tells the user what is being compiled and, while it lasts, that it still is."""

    def __init__(self):
        import threading

        self.local = threading.local()
        self.lock = threading.Lock()

    def _write(self, text: str) -> None:
        import os
        import sys

        if os.environ.get("LIEINT_COMPILE_NOTICE", "1") == "0":
            return
        with self.lock:
            try:
                sys.stderr.write(f"lieint: {text}\n")
                sys.stderr.flush()
            except (OSError, ValueError):  # a closed stderr: nothing to tell
                pass

    def on_start(self, event) -> None:
        import threading
        import time

        dispatcher = event.data.get("dispatcher")
        module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
        local = self.local
        depth = getattr(local, "depth", 0)
        local.depth = depth + 1
        if module.startswith("lieint"):
            _COMPILED[0] += 1
        if depth or not module.startswith("lieint"):
            return
        label = _LABELS.get(id(dispatcher))
        start = time.perf_counter()
        local.start, local.label = start, label
        done = threading.Event()
        local.done = done
        if label:
            self._write(f"compiling the {label} kernel for first use (numba; cached on disk for later runs) ...")
        name = label or f"{module}.{dispatcher.py_func.__name__}"

        def progress():
            told = bool(label)
            while not done.wait(_NOTICE_AFTER if not told else _PROGRESS_EVERY):
                elapsed = time.perf_counter() - start
                if not told:
                    self._write(f"compiling {name} for first use (numba; cached on disk for later runs) ...")
                    told = True
                else:
                    self._write(f"... still compiling {name} ({elapsed:.0f} s)")

        threading.Thread(target=progress, daemon=True).start()

    def on_end(self, event) -> None:
        import time

        local = self.local
        local.depth = getattr(local, "depth", 1) - 1
        if local.depth or getattr(local, "done", None) is None:
            return
        local.done.set()
        local.done = None
        elapsed = time.perf_counter() - local.start
        if local.label and elapsed >= _NOTICE_AFTER:
            self._write(f"compiled the {local.label} kernel in {elapsed:.0f} s")

    def notify(self, event) -> None:
        if event.is_start:
            self.on_start(event)
        elif event.is_end:
            self.on_end(event)


_NOTICE: list = []


def _install_notice() -> None:
    """Register the listener once per process (and silence numba's note that first-class
    function types are experimental: the compiled pieces rely on them by design)."""
    if _NOTICE:
        return
    import warnings

    from numba.core import event
    from numba.core.errors import NumbaExperimentalFeatureWarning

    warnings.filterwarnings("ignore", message="First-class function type", category=NumbaExperimentalFeatureWarning)

    class Listener(_Notice, event.Listener):
        pass

    listener = Listener()
    event.register("numba:compile", listener)
    _NOTICE.append(listener)
