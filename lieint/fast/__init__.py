"""The compiled engine (numba, cached on disk): one loop for every system and method that
declare a compiled form.

A system's ``compiled()`` returns a *form* (:mod:`lieint.fast.forms`: the 3D Euler top, the Euler
top in n ≥ 4 dimensions, or a system with compiled pieces on SO(n)/SE(n) × Rᵐ — the heavy top,
the free body, the balls, any out-of-tree system that declares pieces), a method's
``compiled()`` a method form (RKMK in exponential or Cayley coordinates, its embedded pairs,
classical RK). :func:`lieint.fast.engine.engine_for` matches the two; the loop of
:mod:`lieint.fast.loop` — fixed steps on the global grid or the step-size controller, saving,
projection, the rows of dense output and events — is written once and compiled per form
(:func:`lieint.fast.engine.bound_loops`). The layout of the layer is docs/architecture.md.

Only imported when first used, so ``import lieint`` stays light; numba compiles a kernel on its
first call in a fresh environment (announced on stderr) and caches the machine code on disk for
later processes; ``lieint warmup`` compiles ahead.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

__all__ = ["LANES_BLOCK"]

#: bodies per block of the SIMD-lanes kernel (:mod:`lieint.fast.lanes`), one block per thread
LANES_BLOCK = 128


@lru_cache(maxsize=32)
def _proper_frame_of(data: bytes, n: int) -> tuple[np.ndarray, bool]:
    P = np.frombuffer(data).reshape(n, n).copy()
    if np.linalg.det(P) < 0:
        P[:, -1] *= -1.0
    P.flags.writeable = False
    return P, bool(np.array_equal(P, np.eye(n)))


def _proper_frame(P) -> tuple[np.ndarray, bool]:
    """The principal frame P with det P = +1 (its last axis turned when det P = −1), read-only,
    and whether it is the identity (a diagonal B); worked out once per frame (keyed on its bytes)."""
    P = np.asarray(P, dtype=float)
    return _proper_frame_of(P.tobytes(), P.shape[-1])
