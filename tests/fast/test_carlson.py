"""Carlson's R_J and R_C(1, 1 + e) (:mod:`lieint.fast.carlson`) against mpmath at 30 digits."""

from __future__ import annotations

import mpmath
import numpy as np

from lieint.fast.carlson import carlson_rc1, carlson_rj

EPS = np.finfo(float).eps


def test_rj_agrees_with_mpmath_where_p_is_the_largest_argument():
    rng = np.random.default_rng(11)
    worst = 0.0
    for k in range(300):
        x, y, z = 10.0 ** rng.uniform(-12, 6, 3)
        if k % 5 == 0:
            x = 0.0  # the singular edge: one argument 0
        if k % 7 == 0:
            y = z * (1 + 1e-9)  # two arguments nearly equal
        p = max(x, y, z) * 10.0 ** rng.uniform(0, 8)
        if k % 11 == 0:
            p = max(x, y, z)  # δ = 0
        with mpmath.workdps(30):
            want = mpmath.elliprj(x, y, z, p)
            worst = max(worst, float(abs(carlson_rj(x, y, z, p) - want) / want))
    assert worst <= 4 * EPS, worst / EPS


def test_rc1_agrees_with_mpmath_on_both_branches_and_near_zero():
    es = np.concatenate([-np.logspace(-18, np.log10(0.999999999), 200), np.logspace(-18, 12, 200)])
    worst = 0.0
    for e in es:
        with mpmath.workdps(30):
            want = mpmath.elliprc(1, 1 + mpmath.mpf(float(e)))
            worst = max(worst, float(abs(carlson_rc1(float(e)) - want) / want))
    assert worst <= 4 * EPS, worst / EPS
