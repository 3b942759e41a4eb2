"""What every compiled adaptive kernel takes from an embedded pair's declaration, and how many
rows it writes per call (plain numpy: the kernels' numba code is imported on the first step).

The three adaptive kernels (:mod:`lieint.fast.top3_adaptive`, :mod:`lieint.fast.topn_adaptive`,
:mod:`lieint.fast.generic_adaptive`) differ in their trial step and error measure; the pair's
weights and the bound on the rows a call buffers are the same for all of them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["BYTES_PER_CALL", "ROWS_PER_CALL", "CompiledPair", "row_capacity"]

#: rows a kernel writes per call before handing them back (memory stays bounded) ...
ROWS_PER_CALL = 4096
#: ... and the bytes those rows may take (fewer rows per call for a large batch)
BYTES_PER_CALL = 32_000_000


@dataclass(frozen=True)
class CompiledPair:
    """The embedded weights of an RKMK pair as the compiled loops take them, from the method's
    declaration (``method.compiled()``; for lieint's own pairs the
    :class:`lieint.methods.tableau.EmbeddedPair` behind it).

    ``b_hat`` gives the estimate ``y₁ − ŷ``; ``b_low`` (``has_low``) DOP853's third-order one,
    zeros otherwise (one type signature for every pair); ``error_order`` is the controller's q.
    """

    b_hat: np.ndarray
    b_low: np.ndarray
    has_low: bool
    error_order: int

    @classmethod
    def from_declaration(cls, meth_decl: dict) -> CompiledPair:
        # copies: the tableaux are read-only, and the generic kernel's declared signature
        # takes writable arrays
        b_hat = np.array(meth_decl["b_hat"], dtype=float)
        low = meth_decl.get("b_hat_low")
        b_low = np.array(low if low is not None else np.zeros_like(b_hat), dtype=float)
        return cls(b_hat, b_low, low is not None, int(meth_decl["error_order"]))


def row_capacity(bytes_per_row: int, max_accept: int, save_every: int) -> int:
    """Rows to buffer for one call: at most :data:`ROWS_PER_CALL`, :data:`BYTES_PER_CALL` and
    the rows ``max_accept`` accepted steps can save; at least one."""
    return max(1, min(ROWS_PER_CALL, BYTES_PER_CALL // bytes_per_row, max_accept // save_every + 1))
