"""The algebra of se(3) that the compiled tangent steps of RKMK share (:mod:`lieint.fast.heavy3_tangent`,
:mod:`lieint.fast.chaplygin3_tangent`; numba, inlined): the coefficients of ``exp`` and ``φ₁``
and their derivatives, the right Jacobian of so(3), the translation ``t = φ₁(u_w) u_v`` of
``exp(u)`` with its derivative, the bracket ``ad_{−u}`` and the truncated dexp⁻¹ series with its
derivative (the formulas: docs/theory.md, "The tangent flow"). An element of se(3) is six numbers,
``(u_w, u_v)``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .top3 import _cross, _rodrigues, rotation_into

__all__ = [
    "ad_minus",
    "attitude_turned_into",
    "coefficients",
    "combine_stage",
    "dexpinv_series",
    "dexpinv_series_tangent",
    "exponential",
    "phi1",
    "product_exponent",
    "right_jacobian",
    "rotate_back",
    "tangent_attitude_turned",
    "translation",
    "weighted_sum",
]


@njit(cache=True, inline="always")
def coefficients(t2):
    """``β = (1 − cos θ)/θ²``, ``γ = (θ − sin θ)/θ³`` and their derivatives in ``t2 = θ²``; below
    θ = 0.1 their even series (the first omitted terms below 1e-20 relative)."""
    if t2 < 1e-2:
        beta = 0.5 + t2 * (-1.0 / 24 + t2 * (1.0 / 720 + t2 * (-1.0 / 40320 + t2 * (1.0 / 3628800))))
        gamma = 1.0 / 6 + t2 * (-1.0 / 120 + t2 * (1.0 / 5040 + t2 * (-1.0 / 362880 + t2 * (1.0 / 39916800))))
        dbeta = -1.0 / 24 + t2 * (2.0 / 720 + t2 * (-3.0 / 40320 + t2 * (4.0 / 3628800 + t2 * (-5.0 / 479001600))))
        dgamma = -1.0 / 120 + t2 * (2.0 / 5040 + t2 * (-3.0 / 362880 + t2 * (4.0 / 39916800 - t2 * 5.0 / 6227020800)))
        return beta, gamma, dbeta, dgamma
    th = np.sqrt(t2)
    return _large_angle(t2, th, np.sin(th), np.cos(th))


@njit(cache=True, inline="always")
def _large_angle(t2, th, s, c):
    """:func:`coefficients` from ``θ² = t2``, θ, ``sin θ`` and ``cos θ`` (θ ≥ 0.1)."""
    beta = (1.0 - c) / t2
    gamma = (th - s) / (t2 * th)
    return beta, gamma, (0.5 * s / th - beta) / t2, (beta - 3.0 * gamma) / (2.0 * t2)


@njit(cache=True, inline="always")
def phi1(a0, a1, a2, b0, b1, b2, beta, gamma):
    """``φ₁(â) b = b + β a × b + γ a × (a × b)``."""
    c0, c1, c2 = _cross(a0, a1, a2, b0, b1, b2)
    e0, e1, e2 = _cross(a0, a1, a2, c0, c1, c2)
    return b0 + beta * c0 + gamma * e0, b1 + beta * c1 + gamma * e1, b2 + beta * c2 + gamma * e2


@njit(cache=True, inline="always")
def rotate_back(Q, x0, x1, x2):
    """``Qᵀx``."""
    return (
        Q[0, 0] * x0 + Q[1, 0] * x1 + Q[2, 0] * x2,
        Q[0, 1] * x0 + Q[1, 1] * x1 + Q[2, 1] * x2,
        Q[0, 2] * x0 + Q[1, 2] * x1 + Q[2, 2] * x2,
    )


@njit(cache=True, inline="always")
def right_jacobian(u, du, beta, gamma):
    """``w = J_r(u_w) δu_w = δu_w − β u_w × δu_w + γ u_w × (u_w × δu_w)``: ``exp(u_w)`` moves by
    ``Qᵀ δQ = ŵ``."""
    a0, a1, a2 = u[0], u[1], u[2]
    d0, d1, d2 = du[0], du[1], du[2]
    c0, c1, c2 = _cross(a0, a1, a2, d0, d1, d2)
    e0, e1, e2 = _cross(a0, a1, a2, c0, c1, c2)
    return d0 - beta * c0 + gamma * e0, d1 - beta * c1 + gamma * e1, d2 - beta * c2 + gamma * e2


@njit(cache=True, inline="always")
def translation(u, du, beta, gamma, dbeta, dgamma):
    """The translation of ``exp(u)``, ``t = φ₁(u_w) u_v``, and how it moves with δu (module
    docstring): ``t`` and ``δt``, six numbers."""
    a0, a1, a2 = u[0], u[1], u[2]
    d0, d1, d2 = du[0], du[1], du[2]
    b0, b1, b2 = u[3], u[4], u[5]
    t0, t1, t2 = phi1(a0, a1, a2, b0, b1, b2, beta, gamma)
    f0, f1, f2 = phi1(a0, a1, a2, du[3], du[4], du[5], beta, gamma)  # φ₁(a) δb
    ab0, ab1, ab2 = _cross(a0, a1, a2, b0, b1, b2)  # a × b
    aab0, aab1, aab2 = _cross(a0, a1, a2, ab0, ab1, ab2)  # a × (a × b)
    db0, db1, db2 = _cross(d0, d1, d2, b0, b1, b2)  # δa × b
    q0, q1, q2 = _cross(d0, d1, d2, ab0, ab1, ab2)  # δa × (a × b)
    r0, r1, r2 = _cross(a0, a1, a2, db0, db1, db2)  # a × (δa × b)
    two_dot = 2.0 * (a0 * d0 + a1 * d1 + a2 * d2)
    dbe, dga = dbeta * two_dot, dgamma * two_dot
    dt0 = f0 + dbe * ab0 + beta * db0 + dga * aab0 + gamma * (q0 + r0)
    dt1 = f1 + dbe * ab1 + beta * db1 + dga * aab1 + gamma * (q1 + r1)
    dt2 = f2 + dbe * ab2 + beta * db2 + dga * aab2 + gamma * (q2 + r2)
    return t0, t1, t2, dt0, dt1, dt2


@njit(cache=True, inline="always")
def ad_minus(u, x0, x1, x2, y0, y1, y2):
    """``ad_{−u}(x, y) = (x × u_w, y × u_w + x × u_v)`` on se(3)."""
    a0, a1, a2 = _cross(x0, x1, x2, u[0], u[1], u[2])
    b0, b1, b2 = _cross(y0, y1, y2, u[0], u[1], u[2])
    c0, c1, c2 = _cross(x0, x1, x2, u[3], u[4], u[5])
    return a0, a1, a2, b0 + c0, b1 + c1, b2 + c2


@njit(cache=True, inline="always")
def dexpinv_series(u, coeffs, x0, x1, x2, x3, x4, x5):
    """``K = Σ_d c_d T_d``, ``T_0 = ξ``, ``T_d = ad_{−u} T_{d−1}``: the truncated dexp⁻¹ series of
    se(3) at ``ξ = (x0 … x5)`` (its coefficients ``coeffs``)."""
    k0, k1, k2, k3, k4, k5 = x0, x1, x2, x3, x4, x5
    for dd in range(1, coeffs.shape[0]):
        x0, x1, x2, x3, x4, x5 = ad_minus(u, x0, x1, x2, x3, x4, x5)
        cd = coeffs[dd]
        if cd != 0.0:
            k0 += cd * x0
            k1 += cd * x1
            k2 += cd * x2
            k3 += cd * x3
            k4 += cd * x4
            k5 += cd * x5
    return k0, k1, k2, k3, k4, k5


@njit(cache=True, inline="always")
def dexpinv_series_tangent(u, du, coeffs, x0, x1, x2, x3, x4, x5, d0, d1, d2, d3, d4, d5):
    """How :func:`dexpinv_series` moves when u moves by δu and ξ by ``δξ = (d0 … d5)``:
    ``δK = Σ_d c_d δT_d``, ``δT_d = ad_{−δu} T_{d−1} + ad_{−u} δT_{d−1}``."""
    k0, k1, k2, k3, k4, k5 = d0, d1, d2, d3, d4, d5
    for dd in range(1, coeffs.shape[0]):
        a0, a1, a2, a3, a4, a5 = ad_minus(du, x0, x1, x2, x3, x4, x5)
        c0, c1, c2, c3, c4, c5 = ad_minus(u, d0, d1, d2, d3, d4, d5)
        d0, d1, d2, d3, d4, d5 = a0 + c0, a1 + c1, a2 + c2, a3 + c3, a4 + c4, a5 + c5
        x0, x1, x2, x3, x4, x5 = ad_minus(u, x0, x1, x2, x3, x4, x5)
        cd = coeffs[dd]
        if cd != 0.0:
            k0 += cd * d0
            k1 += cd * d1
            k2 += cd * d2
            k3 += cd * d3
            k4 += cd * d4
            k5 += cd * d5
    return k0, k1, k2, k3, k4, k5


@njit(cache=True, inline="always")
def combine_stage(i, A, b, h, K, dK, u, du, k):
    """``u = h Σ_j a_ij K_j`` and ``δu_m = h Σ_j a_ij δK_mj`` for stage i of the tableau (A, b), or
    with the weights b for the step's end (``i = s``): K (s, w), δK (k, s, w) — w = 6 on se(3),
    9 with the rolling ball's abelian so(3) factor after it. Written out, not through
    :func:`weighted_sum` of the row ``A[i]``: the row's view cost the 3D heavy top's plain step
    about 10 %."""
    s = b.shape[0]
    width = K.shape[1]
    for c in range(width):
        u[c] = 0.0
    for m in range(k):
        for c in range(width):
            du[m, c] = 0.0
    for j in range(i if i < s else s):
        weight = A[i, j] if i < s else b[j]
        if weight != 0.0:
            hw = h * weight
            for c in range(width):
                u[c] += hw * K[j, c]
            for m in range(k):
                for c in range(width):
                    du[m, c] += hw * dK[m, j, c]


@njit(cache=True, inline="always")
def attitude_turned_into(y1, at, Q, out):
    """``out = R Q`` for the attitude R stored row-major at ``y1[at : at + 9]``."""
    for r in range(3):
        for c in range(3):
            out[r, c] = y1[at + 3 * r] * Q[0, c] + y1[at + 1 + 3 * r] * Q[1, c] + y1[at + 2 + 3 * r] * Q[2, c]


@njit(cache=True, inline="always")
def tangent_attitude_turned(y1, at, Q, turned, w0, w1, w2):
    """``δR₁ = δR Q + R₁ ŵ`` in place for the δR stored at ``y1[at : at + 9]``, with ``R₁ = turned``
    (:func:`attitude_turned_into`) and ``ŵ = [[0, −w2, w1], [w2, 0, −w0], [−w1, w0, 0]]``."""
    for r in range(3):
        e = at + 3 * r
        s0, s1, s2 = y1[e], y1[e + 1], y1[e + 2]
        n0, n1, n2 = turned[r, 0], turned[r, 1], turned[r, 2]
        y1[e] = (s0 * Q[0, 0] + s1 * Q[1, 0] + s2 * Q[2, 0]) + (n1 * w2 - n2 * w1)
        y1[e + 1] = (s0 * Q[0, 1] + s1 * Q[1, 1] + s2 * Q[2, 1]) + (n2 * w0 - n0 * w2)
        y1[e + 2] = (s0 * Q[0, 2] + s1 * Q[1, 2] + s2 * Q[2, 2]) + (n0 * w1 - n1 * w0)


@njit(cache=True, inline="always")
def weighted_sum(u, du, K, dK, weights, upto, h, k):
    """``u = h Σ_{j < upto} w_j K_j`` and ``δu_m = h Σ_j w_j δK_mj`` over the nonzero weights ``w``
    in the order of j (K (s, w), δK (k, s, w)); returns whether any weight was nonzero."""
    width = K.shape[1]
    for c in range(width):
        u[c] = 0.0
    for m in range(k):
        for c in range(width):
            du[m, c] = 0.0
    any_weight = False
    for j in range(upto):
        if weights[j] != 0.0:
            any_weight = True
            hw = h * weights[j]
            for c in range(width):
                u[c] += hw * K[j, c]
            for m in range(k):
                for c in range(width):
                    du[m, c] += hw * dK[m, j, c]
    return any_weight


@njit(cache=True, inline="always")
def product_exponent(u, du, K, dK, weights, row, upto, h, k):
    """An exponent of a product of exponentials and its tangent vectors' moves: :func:`weighted_sum`
    of the weights ``weights[row]``; returns whether any weight was nonzero."""
    return weighted_sum(u, du, K, dK, weights[row], upto, h, k)


@njit(cache=True, inline="always")
def exponential(u, Q):
    """``Q = exp(û_w)`` (written into Q, Rodrigues) and the coefficients of u (:func:`coefficients`):
    what turning a block by ``exp(u)`` needs. Above θ = 0.1 one sine and one cosine serve both
    (Rodrigues' ``(1 − cos θ)/θ²`` is β); the numbers are :func:`lieint.fast.top3._rodrigues`' and
    :func:`coefficients`' bit for bit."""
    t2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2]
    if t2 < 1e-2:
        _rodrigues(u, Q)
        return coefficients(t2)
    th = np.sqrt(t2)
    s = np.sin(th)
    beta, gamma, dbeta, dgamma = _large_angle(t2, th, s, np.cos(th))
    rotation_into(u, s / th, beta, Q)
    return beta, gamma, dbeta, dgamma
