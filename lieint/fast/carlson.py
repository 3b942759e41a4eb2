"""Carlson's symmetric elliptic integral of the third kind ``R_J`` in machine code.

:func:`carlson_rj` is the duplication algorithm of B. C. Carlson, "Numerical computation of real
or complex elliptic integrals", Numer. Algorithms 10 (1995) 13–26, Algorithm 3 (DLMF 19.36.2),
for real arguments ``x, y, z ≥ 0`` (at most one of them 0) and ``p > 0``::

    R_J(x, y, z, p) = (3/2) ∫₀^∞ dt / ((t + p) √((t + x)(t + y)(t + z))).

Each duplication replaces the four arguments by ``(a + λ)/4`` with ``λ = √x√y + √x√z + √y√z``
and adds ``6 · 4⁻ᵐ R_C(1, 1 + e_m) / d_m`` (``d_m = (√p + √x)(√p + √y)(√p + √z)``,
``e_m = 4⁻³ᵐ δ / d_m²``, ``δ = (p − x)(p − y)(p − z)``), the form of Carlson's paper that needs
``R_C`` only at ``(1, 1 + e)``, an elementary function (:func:`carlson_rc1`). When the
arguments' spread about their mean ``A`` has shrunk below ``(r/4)^{1/6} |A|`` the rest is
Carlson's fifth-order series in the elementary symmetric functions ``E₂ … E₅`` of the
normalised deviations; its truncation error is about r (here 2⁻⁵³).
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["carlson_rc1", "carlson_rj"]

#: the relative truncation error the duplication stops at (Carlson's r)
_R = 2.0**-53
#: the spread factor of the stopping rule, ``(r/4)^{-1/6}``
_SPREAD = (_R / 4.0) ** (-1.0 / 6.0)


@njit(cache=True)
def carlson_rc1(e):
    """``R_C(1, 1 + e)`` for ``e > −1``: ``atan(√e)/√e`` (e > 0), ``atanh(√−e)/√−e`` (e < 0).

    Near ``e = 0`` both are the series ``Σ (−e)ᵏ/(2k + 1)`` (DLMF 19.2.19–20 with the
    hypergeometric form of ``R_C``), taken to ``e⁷`` below ``|e| = 10⁻³`` so that the closed forms
    never divide a small difference by a small number.
    """
    if abs(e) < 1.0e-3:
        # Horner in −e: 1 − e/3 + e²/5 − … + e⁷/15 (the first term left out is below 10⁻²⁴)
        s = -e
        return 1.0 + s * (
            1.0 / 3.0
            + s * (1.0 / 5.0 + s * (1.0 / 7.0 + s * (1.0 / 9.0 + s * (1.0 / 11.0 + s * (1.0 / 13.0 + s / 15.0)))))
        )
    if e > 0.0:
        r = math.sqrt(e)
        return math.atan(r) / r
    r = math.sqrt(-e)
    if e < -0.5:
        # atanh r = log((1 + r)/√(1 + e)): 1 + e is exact here (Sterbenz), 1 − r would not be
        return (math.log1p(r) - 0.5 * math.log1p(e)) / r
    return math.atanh(r) / r


@njit(cache=True)
def carlson_rj(x, y, z, p):
    """``R_J(x, y, z, p)`` for ``x, y, z ≥ 0`` (at most one 0) and ``p ≥ max(x, y, z)`` (Carlson 1995).

    The domain is the circular case ``δ ≥ 0`` with p the largest argument, where every
    ``e_m ≥ 0`` (measured: within 1ε of mpmath there). For p far below x, y, z the sum
    ``1 + e_m`` cancels (measured: 1.8·10³ ε at ``p/min(x, y, z) ~ 10⁻¹⁰``): not for that case.

    Parameters
    ----------
    x, y, z : float
        The symmetric arguments.
    p : float
        The pole's argument (positive: no Cauchy principal value here).

    Returns
    -------
    float
        The integral, to a few units in the last place (the series' truncation at about 2⁻⁵³
        and the roundings of the duplications).
    """
    a = (x + y + z + p + p) / 5.0
    delta = (p - x) * (p - y) * (p - z)
    # the first level's deviations: the last level's are these times 4⁻ᵐ (no cancellation there)
    dx, dy, dz = a - x, a - y, a - z
    spread = _SPREAD * max(abs(dx), abs(dy), abs(dz), abs(a - p))
    total = 0.0
    scale = 1.0  # 4⁻ᵐ
    while spread * scale >= abs(a):
        sx, sy, sz, sp = math.sqrt(x), math.sqrt(y), math.sqrt(z), math.sqrt(p)
        lam = sx * sy + sx * sz + sy * sz
        d = (sp + sx) * (sp + sy) * (sp + sz)
        e = scale * scale * scale * delta / (d * d)
        total += scale * carlson_rc1(e) / d
        scale *= 0.25
        x, y, z, p, a = 0.25 * (x + lam), 0.25 * (y + lam), 0.25 * (z + lam), 0.25 * (p + lam), 0.25 * (a + lam)
    # the normalised deviations at the last level, X = (A₀ − x₀)/(4ᵐ Aₘ) and so on
    X, Y, Z = scale * dx / a, scale * dy / a, scale * dz / a
    P = -(X + Y + Z) / 2.0
    E2 = X * Y + X * Z + Y * Z - 3.0 * P * P
    E3 = X * Y * Z + 2.0 * E2 * P + 4.0 * P * P * P
    E4 = (2.0 * X * Y * Z + E2 * P + 3.0 * P * P * P) * P
    E5 = X * Y * Z * P * P
    series = (
        1.0
        - 3.0 * E2 / 14.0
        + E3 / 6.0
        + 9.0 * E2 * E2 / 88.0
        - 3.0 * E4 / 22.0
        - 9.0 * E2 * E3 / 52.0
        + 3.0 * E5 / 26.0
    )
    return scale * series / (a * math.sqrt(a)) + 6.0 * total
