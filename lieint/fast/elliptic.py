"""Jacobi's elliptic functions ``sn, cn, dn`` of ``(u | 1 − p)`` in machine code.

The algorithm of :func:`lieint.systems.euler_top_exact.jacobi_elliptic`, operation for operation:
the descending Landen transformation (A&S 16.12) while the complementary parameter ``p < 1/2``,
each level from ``√p`` alone, then — the parameter ``m = 1 − p ≤ 1/2`` — the arithmetic-geometric
mean scale of Cephes' ``ellpj`` (Moshier; what ``scipy.special.ellipj`` runs; DLMF 22.20(ii)),
and ``tanh``/``sech`` on the separatrix ``p = 0``.

Everything that depends on p alone — the Landen levels and the AGM scale — is computed once
(:func:`elliptic_table`) into a small table, and :func:`sn_cn_dn` evaluates at any u from it: a
step of the exact flow evaluates the functions at up to 113 phases of one parameter.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["TABLE_SIZE", "elliptic_table", "jacobi_elliptic", "sn_cn_dn"]

#: Cephes' MACHEP (2⁻⁵³): the AGM stops when ``|c_i/a_i|`` is below it
_MACHEP = 1.11022302462515654042e-16
#: Landen levels at most (p ≥ 5e-324 reaches 1/2 in ten levels)
_LEVELS = 16
#: AGM levels at most (Cephes stops after 8)
_AGM = 10
_AGM_A = 4 + 2 * _LEVELS
_AGM_C = _AGM_A + _AGM
#: the length of a table
TABLE_SIZE = _AGM_C + _AGM


@njit(cache=True)
def elliptic_table(p, table):
    """Fill ``table`` (length :data:`TABLE_SIZE`) with what ``sn_cn_dn(·, p)`` needs: the
    separatrix flag, the Landen levels ``(s, √p)`` and the AGM scale of the final parameter."""
    if p == 0.0:
        table[0] = 0.0
        return
    table[0] = 1.0
    levels = 0
    while p < 0.5:
        kp = math.sqrt(p)
        table[4 + 2 * levels] = (1.0 - kp) / (1.0 + kp)
        table[5 + 2 * levels] = kp
        p = 4.0 * kp / (1.0 + kp) ** 2
        levels += 1
    table[1] = levels
    m = 1.0 - p
    table[2] = m
    if m < 1.0e-9:
        table[3] = -1.0  # the small-parameter expansion
        return
    a, c = table[_AGM_A : _AGM_A + _AGM], table[_AGM_C : _AGM_C + _AGM]
    a[0] = 1.0
    b = math.sqrt(1.0 - m)
    c[0] = math.sqrt(m)
    i = 0
    while abs(c[i] / a[i]) > _MACHEP:
        if i > 7:
            break
        ai = a[i]
        i += 1
        c[i] = (ai - b) / 2.0
        t = math.sqrt(ai * b)
        a[i] = (ai + b) / 2.0
        b = t
    table[3] = i


@njit(cache=True)
def _ellpj(u, table):
    """Cephes' ``ellpj`` at ``m = table[2] ≤ 1/2`` from the AGM scale in the table."""
    m = table[2]
    if table[3] < 0.0:
        t = math.sin(u)
        b = math.cos(u)
        ai = 0.25 * m * (u - t * b)
        return t - ai * b, b + ai * t, 1.0 - 0.5 * m * t * t
    i = int(table[3])
    a, c = table[_AGM_A : _AGM_A + _AGM], table[_AGM_C : _AGM_C + _AGM]
    phi = float(2**i) * a[i] * u
    b = phi
    while True:
        t = c[i] * math.sin(phi) / a[i]
        b = phi
        phi = (math.asin(t) + phi) / 2.0
        i -= 1
        if i == 0:
            break
    sn = math.sin(phi)
    t = math.cos(phi)
    dnfac = math.cos(phi - b)
    dn = math.sqrt(1.0 - m * sn * sn) if abs(dnfac) < 0.1 else t / dnfac
    return sn, t, dn


@njit(cache=True)
def sn_cn_dn(u, table):
    """``(sn, cn, dn)(u | 1 − p)`` from the table of p (:func:`elliptic_table`)."""
    if table[0] == 0.0:  # m = 1: the separatrix itself
        return math.tanh(u), 1.0 / math.cosh(u), 1.0 / math.cosh(u)
    levels = int(table[1])
    for k in range(levels):
        u = u / (1.0 + table[4 + 2 * k])
    sn, cn, dn = _ellpj(u, table)
    for k in range(levels - 1, -1, -1):
        s, kp = table[4 + 2 * k], table[5 + 2 * k]
        den = 1.0 + s * sn * sn
        sn, cn, dn = (1.0 + s) * sn / den, cn * dn / den, (cn * cn + sn * sn * 2.0 * kp / (1.0 + kp)) / den
    return sn, cn, dn


@njit(cache=True)
def jacobi_elliptic(u, p):
    """``(sn, cn, dn)`` at every u of the array ``u`` for the parameter ``1 − p`` (arrays of u's shape)."""
    table = np.zeros(TABLE_SIZE)
    elliptic_table(p, table)
    sn, cn, dn = np.empty_like(u), np.empty_like(u), np.empty_like(u)
    for k in range(u.size):
        sn[k], cn[k], dn[k] = sn_cn_dn(u[k], table)
    return sn, cn, dn
