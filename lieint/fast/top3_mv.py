"""The Moser–Veselov maps of the 3D top as a form of the one compiled loop (numba, cached on disk).

A step of ``moser_veselov`` (and of its compositions ``moser_veselov_composed4/6`` and its
modified-moment forms ``moser_veselov4/6/8/10``) is one solve of the Moser–Veselov equation
``h A = B ωᵀ − ω B`` per substep and the group action ``(Π, R) ↦ (ωᵀΠ, Rω)``
(:mod:`lieint.methods.moser_veselov`, :mod:`lieint.methods.modified_mv`). In the principal
frame, where B is diagonal, the equation has three unknowns: with ω the rotation of the
quaternion ``(1, c)/√(1 + |c|²)`` (``ω = cay(2ĉ)``), ``B ωᵀ − ω B = 2 q₀² hat(−I c + c × Bc)``
and the equation is

    F(c) = c − (1 + |c|²) a − f ⊙ (c₂c₃, c₃c₁, c₁c₂) = 0,   a = hΠ/(2I),
    f = ((I₂ − I₃)/I₁, (I₃ − I₁)/I₂, (I₁ − I₂)/I₃),

Hairer & Vilmart's form of it (their DMV codes iterate it by fixed points). It is solved here
by Newton's method from ``c = a + f ⊙ (a₂a₃, a₃a₁, a₁a₂)`` (the numpy path starts from
``c = a``, its ``X₀ = hΩ``, ``c = X/2``: the same solution to round-off, one update earlier) with
the 3 × 3 Jacobian ``J = I − 2 a cᵀ − ∂(f ⊙ …)`` solved by its adjugate: the update is
quadratic, so once it is below 1e-9 of |c| the next one would be below round-off and the
iteration stops (two updates for ``h|Ω| ≈ 0.05``); it fails — the run stops with the numpy
path's message — when 40 updates do not get there.

The step is applied from ``K = ω − I = g (ĉ + ĉ²)``, ``g = 2/(1 + |c|²)``, never forming ω:
``Π₁ = Π + KᵀΠ``, ``R₁ = R + RK``, as :meth:`lieint.EulerTop.act_near_identity` does on the numpy
path (K's diagonal ``g(c_i² − |c|²)`` keeps its relative precision; see
:mod:`lieint.methods.moser_veselov` for why this keeps the energy error a random walk).

The modified moments ``1/Ĩ = S/I + D`` of ``moser_veselov2q+2`` are the series of
:func:`lieint.methods.modified_mv.modified_moments` in ``x = h²|Π|²/2``, ``y = h² Σ Π_k²/(2I_k)``
at the step's Π, with their coefficients computed once per run in Python
(:func:`lieint.methods.modified_mv.modified_coefficients`, passed in the map's numbers).

A step's increment (what dense output interpolates) is written as the Cayley coordinates
``2c`` of ω (the run's numbers say ``cayley``), converted to exponential coordinates only when
an interpolant asks for one. Everything else — the error norm, the projection, ``radius2``, the
vector field — is the 3D top's (:mod:`lieint.fast.top3`).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .top3 import _newton_schulz, form_embedded, form_error_sum, form_prepare, form_radius2, form_user_field

__all__ = ["NAMESPACES", "MoserVeselovNumbers", "numbers"]

#: the map's numbers as the compiled step reads them: the substeps' fractions of h, the degree
#: of the modified moments' series (0: the body's moments) and the coefficients of S and D by
#: degree (row q − 1, column j multiplies x^{q−j} y^j), and ``cayley`` (the increments are
#: Cayley coordinates: dense output converts them)
MoserVeselovNumbers = namedtuple("MoserVeselovNumbers", "substeps degree s d cayley")

#: Newton updates before a step is declared unsolvable (the numpy path's limit)
MAX_NEWTON = 40
#: an update below this fraction of |c| leaves the next one below round-off (quadratic convergence)
_QUADRATIC = 1e-9
_EPS = np.finfo(float).eps


def numbers(form, layout) -> MoserVeselovNumbers:
    """The numbers of a :class:`~lieint.fast.forms.MapForm` of the Moser–Veselov family for the
    3D top of ``layout`` (its principal moments give the modified moments' coefficients)."""
    degree = int(form.degree)
    s = np.zeros((max(degree, 1), 5))
    d = np.zeros((max(degree, 1), 5))
    if degree:
        s_coeffs, d_coeffs = form.coefficients(tuple(float(m) for m in layout.moments))
        for q in range(degree):
            s[q, : q + 2] = s_coeffs[q]
            d[q, : q + 2] = d_coeffs[q]
    return MoserVeselovNumbers(np.array(form.substeps, dtype=float), degree, s, d, True)


@njit(cache=True, inline="always")
def _series(c, degree, x, y):
    """``Σ_{q < degree} Σ_j c[q, j] x^{q+1−j} y^j`` (degree ≤ 4), the powers by products."""
    total = c[0, 0] * x + c[0, 1] * y
    if degree > 1:
        x2, xy, y2 = x * x, x * y, y * y
        total += c[1, 0] * x2 + c[1, 1] * xy + c[1, 2] * y2
        if degree > 2:
            total += c[2, 0] * x2 * x + c[2, 1] * x2 * y + c[2, 2] * x * y2 + c[2, 3] * y2 * y
            if degree > 3:
                total += c[3, 0] * x2 * x2 + c[3, 1] * x2 * xy + c[3, 2] * x2 * y2
                total += c[3, 3] * xy * y2 + c[3, 4] * y2 * y2
    return total


@njit(cache=True)
def _solve(a0, a1, a2, f0, f1, f2):
    """Newton's method for ``F(c) = 0`` (module docstring): ``(c, updates)``, updates −1 when
    it did not converge. The first guess is ``c = a`` moved by one fixed-point pass
    ``c = a + f ⊙ (a₂a₃, …)`` (as the DMV codes start), which is ``O(h³)`` from the solution
    where ``a`` is ``O(h²)``: one Newton update fewer for the same result."""
    c0 = a0 + f0 * a1 * a2
    c1 = a1 + f1 * a2 * a0
    c2 = a2 + f2 * a0 * a1
    for it in range(1, MAX_NEWTON + 1):
        n2 = c0 * c0 + c1 * c1 + c2 * c2
        g = 1.0 + n2
        r0 = c0 - g * a0 - f0 * c1 * c2
        r1 = c1 - g * a1 - f1 * c2 * c0
        r2 = c2 - g * a2 - f2 * c0 * c1
        # J = I − 2 a cᵀ − [[0, f0 c2, f0 c1], [f1 c2, 0, f1 c0], [f2 c1, f2 c0, 0]]
        j00 = 1.0 - 2.0 * a0 * c0
        j01 = -2.0 * a0 * c1 - f0 * c2
        j02 = -2.0 * a0 * c2 - f0 * c1
        j10 = -2.0 * a1 * c0 - f1 * c2
        j11 = 1.0 - 2.0 * a1 * c1
        j12 = -2.0 * a1 * c2 - f1 * c0
        j20 = -2.0 * a2 * c0 - f2 * c1
        j21 = -2.0 * a2 * c1 - f2 * c0
        j22 = 1.0 - 2.0 * a2 * c2
        # δ = −J⁻¹ r by the adjugate
        m00 = j11 * j22 - j12 * j21
        m01 = j02 * j21 - j01 * j22
        m02 = j01 * j12 - j02 * j11
        m10 = j12 * j20 - j10 * j22
        m11 = j00 * j22 - j02 * j20
        m12 = j02 * j10 - j00 * j12
        m20 = j10 * j21 - j11 * j20
        m21 = j01 * j20 - j00 * j21
        m22 = j00 * j11 - j01 * j10
        det = j00 * m00 + j01 * m10 + j02 * m20
        if not (det != 0.0 and np.isfinite(det)):
            return c0, c1, c2, -1
        k = -1.0 / det
        d0 = k * (m00 * r0 + m01 * r1 + m02 * r2)
        d1 = k * (m10 * r0 + m11 * r1 + m12 * r2)
        d2 = k * (m20 * r0 + m21 * r1 + m22 * r2)
        c0 += d0
        c1 += d1
        c2 += d2
        size = abs(d0) + abs(d1) + abs(d2)
        scale = abs(c0) + abs(c1) + abs(c2)
        if not np.isfinite(size):
            return c0, c1, c2, -1
        if size <= _QUADRATIC * scale:
            return c0, c1, c2, it
    return c0, c1, c2, -1


@njit(cache=True)
def form_scratch(fx, meth, par, d):
    """The projection's 3 × 3 work matrix (the step needs no arrays)."""
    return np.zeros((3, 3))


@njit(cache=True)
def form_mv_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One step (every substep a Moser–Veselov solve and its action) of one body, in the
    principal frame; ``inc`` = the Cayley coordinates of the step's ω (``2c`` of a single
    map; of the product of the substeps' ω for a composition), ``aux[0] = |I⁻¹Π|²``.
    Returns the Newton iterations spent (what the numpy path counts as its evaluations), or −1
    when Newton did not converge."""
    Iinv = par[0:3]
    for i in range(12):
        y1[i] = y[i]
    p0, p1, p2 = y1[0], y1[1], y1[2]
    w0, w1, w2 = Iinv[0] * p0, Iinv[1] * p1, Iinv[2] * p2
    aux[0] = w0 * w0 + w1 * w1 + w2 * w2
    # the moments of the map: modified by the series at this step's Π (the same at every step:
    # |Π| and H are kept), or the body's
    degree = meth.degree
    if degree:
        x = 0.5 * h * h * (p0 * p0 + p1 * p1 + p2 * p2)
        e = 0.5 * h * h * (p0 * w0 + p1 * w1 + p2 * w2)
        S = 1.0 + _series(meth.s, degree, x, e)
        D = _series(meth.d, degree, x, e)
        Jinv0, Jinv1, Jinv2 = S * Iinv[0] + D, S * Iinv[1] + D, S * Iinv[2] + D
    else:
        Jinv0, Jinv1, Jinv2 = Iinv[0], Iinv[1], Iinv[2]
    J0, J1, J2 = 1.0 / Jinv0, 1.0 / Jinv1, 1.0 / Jinv2
    f0, f1, f2 = (J1 - J2) * Jinv0, (J2 - J0) * Jinv1, (J0 - J1) * Jinv2
    spent = 0
    R = y1[3:12]
    # the step's ω as a quaternion (q0, q) = Π_i (1, c_i) (Hamilton products in the order the
    # substeps act, R ↦ R ω₁ ω₂ …): its Cayley coordinates 2q/q0 are the step's increment
    q0, q1, q2, q3 = 1.0, 0.0, 0.0, 0.0
    for sub in range(meth.substeps.shape[0]):
        hh = 0.5 * h * meth.substeps[sub]
        p0, p1, p2 = y1[0], y1[1], y1[2]
        c0, c1, c2, it = _solve(hh * p0 * Jinv0, hh * p1 * Jinv1, hh * p2 * Jinv2, f0, f1, f2)
        if it < 0:
            return -1
        spent += it  # Newton iterations, as the numpy path counts its evaluations
        n2 = c0 * c0 + c1 * c1 + c2 * c2
        g = 2.0 / (1.0 + n2)
        # K = g (ĉ + c cᵀ − |c|² I)
        k00 = g * (c0 * c0 - n2)
        k11 = g * (c1 * c1 - n2)
        k22 = g * (c2 * c2 - n2)
        k01 = g * (c0 * c1 - c2)
        k10 = g * (c1 * c0 + c2)
        k02 = g * (c0 * c2 + c1)
        k20 = g * (c2 * c0 - c1)
        k12 = g * (c1 * c2 - c0)
        k21 = g * (c2 * c1 + c0)
        # Π₁ = Π + KᵀΠ
        y1[0] = p0 + (k00 * p0 + k10 * p1 + k20 * p2)
        y1[1] = p1 + (k01 * p0 + k11 * p1 + k21 * p2)
        y1[2] = p2 + (k02 * p0 + k12 * p1 + k22 * p2)
        # R₁ = R + RK (row by row)
        for r in range(3):
            r0, r1, r2 = R[3 * r], R[3 * r + 1], R[3 * r + 2]
            R[3 * r] = r0 + (r0 * k00 + r1 * k10 + r2 * k20)
            R[3 * r + 1] = r1 + (r0 * k01 + r1 * k11 + r2 * k21)
            R[3 * r + 2] = r2 + (r0 * k02 + r1 * k12 + r2 * k22)
        q0, q1, q2, q3 = (
            q0 - (q1 * c0 + q2 * c1 + q3 * c2),
            q1 + q0 * c0 + (q2 * c2 - q3 * c1),
            q2 + q0 * c1 + (q3 * c0 - q1 * c2),
            q3 + q0 * c2 + (q1 * c1 - q2 * c0),
        )
    inc[0], inc[1], inc[2] = 2.0 * q1 / q0, 2.0 * q2 / q0, 2.0 * q3 / q0
    return spent


@njit(cache=True)
def form_project(fx, y, par, out, scr):
    """R onto SO(3) (the 3D top's Newton–Schulz); Π as it is."""
    for i in range(12):
        out[i] = y[i]
    _newton_schulz(out[3:12].reshape((3, 3)), scr)


#: the names of :mod:`lieint.fast.loop` this form binds (fixed steps only: the maps have no
#: embedded pair; ``embedded`` and ``error_sum`` are bound for completeness of the template)
NAMESPACES = {
    "moser_veselov": {
        "prepare": form_prepare,
        "scratch": form_scratch,
        "step": form_mv_step,
        "embedded": form_embedded,
        "error_sum": form_error_sum,
        "project": form_project,
        "radius2": form_radius2,
        "user_field": form_user_field,
    }
}
