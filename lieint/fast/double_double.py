"""Double-double arithmetic for compiled kernels: a number as the unevaluated sum ``hi + lo``.

Two doubles carry about 106 bits (32 digits): enough to stand in for the numpy path's long
double (64 bits) and, with the error-free transformations below, for exact rational arithmetic
of a few terms. The building blocks are Knuth's TwoSum and the fused multiply-add's exact
product error (``a·b − fl(a·b) = fma(a, b, −fl(a·b))``, :func:`lieint.fast.fused.fma`); the
operations are those of Hida, Li & Bailey's QD library ("sloppy" variants excluded), each
returning ``(hi, lo)`` with ``|lo| ≤ ulp(hi)/2``. The kernels call them with plain floats, so a
double ``x`` is ``(x, 0.0)``.

The compiled code must not reassociate floating-point operations (numba's default: no
``fastmath``): TwoSum is exact only in strict IEEE arithmetic.
"""

from __future__ import annotations

import math

from numba import njit

from .fused import fma

__all__ = ["dd_add", "dd_div", "dd_mul", "dd_sqrt", "two_prod", "two_sum"]


@njit(cache=True)
def two_sum(a, b):
    """``a + b = s + e`` exactly, s the rounded sum (Knuth)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@njit(cache=True)
def _fast_two_sum(a, b):
    """``a + b = s + e`` exactly when ``|a| ≥ |b|`` (Dekker)."""
    s = a + b
    return s, b - (s - a)


@njit(cache=True)
def two_prod(a, b):
    """``a · b = p + e`` exactly, p the rounded product (fused multiply-add)."""
    p = a * b
    return p, fma(a, b, -p)


@njit(cache=True)
def dd_add(ah, al, bh, bl):
    """``(ah + al) + (bh + bl)`` to double-double precision (the accurate sum, both parts carried)."""
    s, e = two_sum(ah, bh)
    t, f = two_sum(al, bl)
    e += t
    s, e = _fast_two_sum(s, e)
    e += f
    return _fast_two_sum(s, e)


@njit(cache=True)
def dd_mul(ah, al, bh, bl):
    """``(ah + al) · (bh + bl)`` to double-double precision."""
    p, e = two_prod(ah, bh)
    e += ah * bl + al * bh
    return _fast_two_sum(p, e)


@njit(cache=True)
def dd_div(ah, al, bh, bl):
    """``(ah + al) / (bh + bl)`` to double-double precision (the double quotient and one correction
    from the exact remainder ``a − q·b``)."""
    q1 = ah / bh
    ph, pl = two_prod(q1, bh)
    # a − q₁b, the product's low parts included: the remainder to about 2⁻¹⁰⁶ relative
    rh, rl = two_sum(ah, -ph)
    rl += al - pl - q1 * bl
    q2 = (rh + rl) / bh
    return _fast_two_sum(q1, q2)


@njit(cache=True)
def dd_sqrt(ah, al):
    """``√(ah + al)`` to double-double precision (one Newton step from the double root); 0 at 0."""
    if ah <= 0.0:
        return math.sqrt(ah) if ah == 0.0 else math.nan, 0.0
    x = math.sqrt(ah)
    sh, sl = two_prod(x, x)
    rh, _ = dd_add(ah, al, -sh, -sl)
    return _fast_two_sum(x, rh / (2.0 * x))
