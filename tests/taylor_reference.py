"""An extended-precision Taylor integrator of the free 3D top with its attitude: the reference
for the exact flow (independent of the elliptic formulas under test). :func:`taylor_flow` sums
one short step's series in mpmath, to the working precision (50 digits and more).

``I ẇ = (I w) × w`` is integrated in fixed-point arithmetic on Python integers (120 fraction
bits, ~36 digits): the Taylor coefficients of a quadratic vector field follow from Cauchy
products, ``(k + 1) w_{k+1} = c ⊙ Σ_l w_l ⊗ w_{k−l}``. Near the separatrix the period depends
on the energy like ``log(1/p)``, which amplifies round-off of w; 36 digits keep it far below
1e-16 over t = 1000. The attitude ``Q̇ = Q ŵ`` is linear in Q and does not amplify its
round-off, so it is stepped with the same series in numpy's extended (80-bit) precision.
"""

from __future__ import annotations

from fractions import Fraction

import mpmath as mp
import numpy as np

BITS = 120
ONE = 1 << BITS
LD = np.longdouble


def _fixed(x) -> int:
    return round(Fraction(x) * ONE)  # doubles are dyadic: exact


def _to_ld(v: int):
    shift = max(v.bit_length() - 62, 0)
    return np.ldexp(LD(v >> shift), shift - BITS)


def taylor_top(moments, w0, t_end: float, h: float = 0.2, degree: int = 30):
    """``(w(t_end), Q(t_end))`` of ``I ẇ = (Iw) × w``, ``Q̇ = Q ŵ``, ``Q(0) = I`` (doubles in, doubles out)."""
    I = [Fraction(float(x)) for x in moments]
    c = [_fixed((I[1] - I[2]) / I[0]), _fixed((I[2] - I[0]) / I[1]), _fixed((I[0] - I[1]) / I[2])]
    w = [_fixed(float(x)) for x in w0]
    Q = np.eye(3, dtype=LD)
    nsteps = int(np.ceil(t_end / h))
    step = Fraction(t_end) / nsteps
    hh = _fixed(step)
    hh_ld = LD(step.numerator) / LD(step.denominator)
    for _ in range(nsteps):
        W = [w]
        for k in range(degree):
            conv = [0, 0, 0]
            for j, (a, b) in enumerate(((1, 2), (2, 0), (0, 1))):
                conv[j] = sum(W[l][a] * W[k - l][b] for l in range(k + 1))
            W.append([(c[j] * conv[j]) // ((k + 1) << (2 * BITS)) for j in range(3)])
        Wl = np.array([[_to_ld(x) for x in row] for row in W])  # (degree + 1, 3)
        R = np.zeros((degree + 1, 3, 3), dtype=LD)
        R[0] = Q
        for k in range(degree):
            b = Wl[k::-1]
            Wh = np.zeros((k + 1, 3, 3), dtype=LD)
            Wh[:, 0, 1], Wh[:, 0, 2], Wh[:, 1, 2] = -b[:, 2], b[:, 1], -b[:, 0]
            Wh[:, 1, 0], Wh[:, 2, 0], Wh[:, 2, 1] = b[:, 2], -b[:, 1], b[:, 0]
            R[k + 1] = np.einsum("lij,ljm->im", R[: k + 1], Wh) / LD(k + 1)
        w = list(W[degree])
        for k in range(degree - 1, -1, -1):  # Horner
            w = [W[k][j] + (hh * w[j] >> BITS) for j in range(3)]
        Qn = R[degree].copy()
        for k in range(degree - 1, -1, -1):
            Qn = R[k] + hh_ld * Qn
        Q = Qn
    return np.array([float(Fraction(x, ONE)) for x in w]), Q.astype(float)


# -- one short step in mpmath (the current precision) --------------------------------------------


def mp_cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def mp_hat(w):
    return mp.matrix([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def taylor_flow(I, Pi0, h):
    """``(Π(h), R(h))`` of ``Π' = Π × w``, ``R' = R ŵ``, ``w = Π/I``, ``R(0) = Id``, summed from the
    Taylor series (Cauchy products of the quadratic field) until the terms fall below 1e-45."""
    P, R = [list(Pi0)], [mp.eye(3)]
    Pi, Rh = list(Pi0), mp.eye(3)
    for k in range(200):
        s, S = [mp.mpf(0)] * 3, mp.zeros(3, 3)
        for j in range(k + 1):
            w = [P[k - j][i] / I[i] for i in range(3)]
            s = [a + b for a, b in zip(s, mp_cross(P[j], w), strict=True)]
            S += R[j] * mp_hat(w)
        P.append([v / (k + 1) for v in s])
        R.append(S / (k + 1))
        hk = h ** (k + 1)
        Pi = [a + b * hk for a, b in zip(Pi, P[-1], strict=True)]
        Rh += R[-1] * hk
        if max(abs(v) for v in P[-1]) * abs(hk) < mp.mpf(10) ** -45:
            return Pi, Rh
    raise AssertionError("Taylor series did not converge")
