"""Symmetric compositions: the fractions of h at which a symmetric step of order 2 is taken so
that the composed step has a higher even order (Yoshida 1990; Suzuki 1990; Hairer, Lubich &
Wanner, *Geometric Numerical Integration*, §II.4 and §V.3).

Shared by the splittings (:mod:`.splitting`) and the composed Moser–Veselov methods
(:mod:`.moser_veselov`); it registers no method.
"""

from __future__ import annotations

import numpy as np

__all__ = ["COMPOSITIONS", "composition_coefficients"]

#: composition schemes of the higher orders
COMPOSITIONS = ("yoshida", "triple_jump", "suzuki")
#: Yoshida's (1990) sixth-order 7-step symmetric composition, "solution A"
_YOSHIDA6 = (0.784513610477560, 0.235573213359357, -1.17767998417887)


def composition_coefficients(order: int, scheme: str = "yoshida") -> np.ndarray:
    """Fractions of h of the basic symmetric steps of a composition of the given (even) order."""
    if scheme not in COMPOSITIONS:
        raise ValueError(f"`composition` must be one of {list(COMPOSITIONS)}; got {scheme!r}.")
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order < 2 or order % 2:
        raise ValueError(f"`order` of a symmetric composition must be an even integer >= 2; got {order!r}.")
    c, start = np.array([1.0]), 2
    if scheme == "yoshida" and order >= 6:
        w3, w2, w1 = _YOSHIDA6
        c, start = np.array([w3, w2, w1, 1.0 - 2.0 * (w1 + w2 + w3), w1, w2, w3]), 6
    for q in range(start, order, 2):  # raise the order from q to q + 2
        if scheme in ("yoshida", "triple_jump"):
            g1 = 1.0 / (2.0 - 2.0 ** (1.0 / (q + 1)))
            weights = [g1, 1.0 - 2.0 * g1, g1]
        else:
            p = 1.0 / (4.0 - 4.0 ** (1.0 / (q + 1)))
            weights = [p, p, 1.0 - 4.0 * p, p, p]
        c = np.concatenate([w * c for w in weights])
    return c
