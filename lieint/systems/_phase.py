"""Long phases of the exact free-top solution, reduced without losing digits (docs/theory.md §2, §11).

Over a long time the elliptic phase ``u = u₀ + λt`` and the precession angle ψ reach
``10²…10³``, and a double carries them only to ``|u|·ε``, ``|ψ|·ε`` (≈ 2e-13 at 10³): the
error of R(t) and w(t) then grows linearly with t although the motion itself is periodic.
Only the reduced phases matter — ``r = u − 2jK`` in ``[−K, K]`` and ``ψ mod 2π`` — so they are
formed here from constants known to ~32 digits and error-free products:

* the constants ``λ``, ``2K``, ``G/I₁`` and the precession per half period
  ``κ = 2 G (I₃ − I₁) Π(ν|m) / (I₁ I₃ λ)`` are computed once per solution in 50-digit
  ``decimal`` arithmetic from the doubles given (exact there), and stored as unevaluated
  sums ``hi + lo`` of two doubles. ``λ² = (I₃ − I₂)(G² − 2E I₁)/(I₁ I₂ I₃)`` and ``G²`` are
  rational in the data; the complete integrals ``K = cel(k_c, 1, 1, 1)`` and
  ``Π(ν|m) = cel(k_c, 1 − ν, 1, 1)`` (``k_c = √p``) come from Bulirsch's quadratically
  convergent ``cel`` algorithm (Bulirsch 1969; Press et al., *Numerical Recipes*, §6.11);
* ``λt`` and ``j·2K`` are split exactly into two doubles (Dekker's product), and the terms
  of ``u₀ + λt − j·2K`` are added with error-free transformations (Ogita, Rump & Oishi 2005,
  Sum2): r is then as accurate as if computed in twice the working precision. ψ is reduced
  by ``2π`` (itself ``hi + lo``) the same way.

The remaining error is that of the in-period evaluation — a few ulps of quantities of size
``K`` and ``2π`` — and does not grow with t.
"""

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal, getcontext, localcontext

import numpy as np

__all__ = ["LongPhase", "cel", "long_phase", "reduce_sum", "two_prod"]

#: 2π to 60 digits
_TWO_PI = Decimal("6.28318530717958647692528676655900576839433879875021164194989")
_DIGITS = 50


def _dd(x: Decimal) -> tuple[float, float]:
    """``x`` as the unevaluated sum ``hi + lo`` of two doubles (~32 digits)."""
    hi = float(x)
    return hi, float(x - Decimal(hi))


def cel(kc: Decimal, p: Decimal, a: Decimal, b: Decimal) -> Decimal:
    """Bulirsch's general complete elliptic integral for ``p > 0``, ``k_c ≠ 0`` (current context)::

        cel(k_c, p, a, b) = ∫₀^{π/2} (a cos²θ + b sin²θ) dθ / ((cos²θ + p sin²θ) (cos²θ + k_c² sin²θ)^{1/2}),

    so that ``K(m) = cel(√(1 − m), 1, 1, 1)`` and ``Π(ν|m) = cel(√(1 − m), 1 − ν, 1, 1)``. A
    Gauss (AGM-type) transformation, converging quadratically (Bulirsch 1969).
    """
    tol = Decimal(10) ** (-(getcontext().prec // 2) - 2)
    qc, e, em = abs(kc), abs(kc), Decimal(1)
    p = p.sqrt()
    b = b / p
    while True:
        f = a
        a = a + b / p
        g = e / p
        b = 2 * (b + f * g)
        p = g + p
        g = em
        em = em + qc
        if abs(g - qc) <= g * tol:
            break
        qc = 2 * e.sqrt()
        e = qc * em
    return _TWO_PI / 4 * (b + a * em) / (em * (em + p))


def two_prod(a, b):
    """``a·b = p + e`` exactly, p the rounded product (Dekker's splitting; |a|, |b| < 1e290)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    p = a * b
    split = 134217729.0  # 2^27 + 1: halves of 26 bits, whose products are exact
    ca, cb = split * a, split * b
    ah = ca - (ca - a)
    bh = cb - (cb - b)
    al, bl = a - ah, b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def reduce_sum(terms) -> np.ndarray:
    """``Σ terms`` as if summed in twice the working precision, then rounded (Ogita, Rump &
    Oishi 2005, Sum2: each addition's rounding error, exact by Knuth's TwoSum, is carried)."""
    s = np.asarray(terms[0], dtype=float)
    c = np.zeros_like(s)
    for x in terms[1:]:
        t = s + x
        z = t - s
        c = c + ((s - (t - z)) + (x - z))
        s = t
    return s + c


@dataclass(frozen=True)
class LongPhase:
    """Constants of the long phases, each as ``(hi, lo)``: ``λ``, ``2K`` (None on the
    separatrix, ``p = 0``), ``ω = G/I₁`` and ``κ = 2 G (I₃ − I₁) Π(ν|m)/(I₁ I₃ λ)`` (None
    when the attitude has no third-kind term or the separatrix is hit)."""

    lam: tuple[float, float]
    two_k: tuple[float, float] | None
    omega: tuple[float, float]
    kappa: tuple[float, float] | None

    def reduce_u(self, u0: float, t: np.ndarray):
        """``(j, r)`` with ``u₀ + λt = 2jK + r``, ``|r| ≤ K`` (j = 0 on the separatrix)."""
        lam_t, lam_t_err = two_prod(self.lam[0], t)
        if self.two_k is None:
            j = np.zeros_like(t)
            return j, reduce_sum([u0 + 0.0 * t, lam_t, lam_t_err, self.lam[1] * t])
        j = np.round((u0 + self.lam[0] * t) / self.two_k[0])
        jk, jk_err = two_prod(j, self.two_k[0])  # j < 2^26 here: jK exact in two doubles
        return j, reduce_sum([u0 + 0.0 * t, lam_t, -jk, lam_t_err, -jk_err, self.lam[1] * t, -j * self.two_k[1]])

    def reduce_psi(self, t: np.ndarray, j: np.ndarray, rest: np.ndarray) -> np.ndarray:
        """``ωt − κj + rest`` reduced modulo 2π (``rest``: the in-period part, of size O(1))."""
        om_t, om_t_err = two_prod(self.omega[0], t)
        terms = [om_t, om_t_err, self.omega[1] * t, rest]
        if self.kappa is not None:
            kj, kj_err = two_prod(j, self.kappa[0])
            terms += [-kj, -kj_err, -j * self.kappa[1]]
        k = np.round(reduce_sum(terms) / _TWO_PI_DD[0])
        tk, tk_err = two_prod(k, _TWO_PI_DD[0])
        return reduce_sum([*terms, -tk, -tk_err, -k * _TWO_PI_DD[1]])


_TWO_PI_DD = _dd(_TWO_PI)


def long_phase(I, w, lam: float, attitude: bool) -> LongPhase:
    """The constants of :class:`LongPhase` from the relabelled data, in 50-digit arithmetic.

    Parameters
    ----------
    I : sequence of 3 floats
        Moments ``I₁, I₂, I₃`` in the order of the elliptic solution (``I₂`` in the middle).
    w : sequence of 3 floats
        The initial angular velocity in that order; the doubles are taken as exact.
    lam : float
        λ in double precision (its sign is the one of the solution).
    attitude : bool
        Whether κ is needed.
    """
    with localcontext() as ctx:
        ctx.prec = _DIGITS
        I1, I2, I3 = (Decimal(float(x)) for x in I)
        W2 = [Decimal(float(x)) ** 2 for x in w]
        Id = (I1, I2, I3)

        def gap(Ik):  # G² − 2E I_k = Σ I_i (I_i − I_k) w_i²
            return sum(Id[i] * (Id[i] - Ik) * W2[i] for i in range(3))

        d1, d2, d3 = gap(I1), gap(I2), -gap(I3)
        G = sum(Id[i] ** 2 * W2[i] for i in range(3)).sqrt()
        lam_x = ((I3 - I2) * d1 / (I1 * I2 * I3)).sqrt().copy_sign(Decimal(lam))
        p = Decimal(1) if I2 == I1 else (I3 - I1) * d2 / ((I3 - I2) * d1)
        two_k = kappa = None
        if p > 0:
            kc = p.sqrt()
            two_k = 2 * cel(kc, Decimal(1), Decimal(1), Decimal(1))
            if attitude and d3 != 0:
                nu = -I1 * d3 / (I3 * d1)
                kappa = 2 * G * (I3 - I1) * cel(kc, 1 - nu, Decimal(1), Decimal(1)) / (I1 * I3 * lam_x)
        return LongPhase(
            _dd(lam_x), None if two_k is None else _dd(two_k), _dd(G / I1), None if kappa is None else _dd(kappa)
        )
