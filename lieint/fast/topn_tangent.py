"""The tangent maps of the n-dimensional Euler top's RKMK methods (n ≥ 4) as forms of the one
compiled loop (forward mode, numba, cached on disk).

A body's row is its state in the principal frame, ``(Ã, R̃) = (PᵀAP, RP)`` (2n² numbers; R̃ = I
for a top without attitude), followed by k tangent vectors ``(δÃ, δR̃)`` of the same layout:
``d = 2n² (1 + k)``. The step is RKMK in exponential coordinates with dexp⁻¹ truncated at the
method's degree (docs/theory.md §3): ``ξ = Ω̃ = M ∘ Ã`` (``M_ij = −1/(b_i + b_j)``), the right action
``Ã ← QᵀÃQ``, ``R̃ ← R̃Q``, ``Q = exp U``, and the series' terms ``T_d = [−U, T_{d−1}]``. Each
tangent vector moves by the derivative of that step:

* ``exp(U)`` moves by ``Qᵀ δQ = Ŵ = Σ_{j ≥ 0} (−1)^j/(j + 1)! ad_U^j δU`` (dexp of the right
  trivialisation), summed until a term no longer changes the sum — at n = 4 in closed form, the
  right Jacobian of so(3) on each half of so(4) = so(3) ⊕ so(3);
* ``δ(QᵀÃQ) = QᵀδÃQ + [QᵀÃQ, Ŵ]``, ``δR̃₁ = δR̃ Q + R̃₁ Ŵ``; ``δξ = M ∘ δÃ_i`` (ξ is linear);
* ``δT_d = [−δU, T_{d−1}] + [−U, δT_{d−1}]``.

This is the derivative of the map the method computes: the tangent map the complex step of
:mod:`lieint.tangent.flow` computes on the generic path, to round-off (not to the bit: the plain
step's code is :mod:`lieint.fast.topn_step`'s). MEGNO's and Benettin's sums take the chart's
coordinates of a vector (:mod:`lieint.tangent.coordinates`): the upper triangle of δÃ and of the
skew part of ``R̃ᵀδR̃`` — the principal frame is a rotation of the user's, so their norms and
inner products are the chart's.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .se3_tangent import coefficients
from .se_algebra import out_of_range
from .small_skew import bracket_skew_into, congruence_skew_into
from .tangent_sums import MEGNO_SLOTS, keep_row, megno_advance, prepare_nothing
from .top3 import _cross
from .topn_step import _exp_into

__all__ = ["MEGNO_SLOTS", "NAMESPACES"]

# parameters: n, whether the top carries R, M (n²), then (Lyapunov) every, total
_ORIENT, _M = 1, 2


@njit(cache=True, inline="always")
def _mat(y, o, n):
    """The n × n matrix stored row-major at ``y[o :]`` (a view)."""
    return y[o : o + n * n].reshape((n, n))


@njit(cache=True)
def _bracket_into(X, Y, out):
    """``out = [X, Y] = XY − YX`` of skew X and Y, exactly skew: unrolled for 4 ≤ n ≤ 6
    (:func:`lieint.fast.small_skew.bracket_skew_into`), else its upper triangle by loops and the
    rest mirrored."""
    if bracket_skew_into(X, Y, out):
        return
    n = X.shape[0]
    for i in range(n):
        out[i, i] = 0.0
        for j in range(i + 1, n):
            acc = 0.0
            for k in range(n):
                acc += X[i, k] * Y[k, j] - Y[i, k] * X[k, j]
            out[i, j] = acc
            out[j, i] = -acc


@njit(cache=True)
def _conjugate_into(Q, X, M, tmp, out):
    """``out = QᵀXQ`` of a skew X, exactly skew (and ``tmp = M ∘ out`` for 4 ≤ n ≤ 6, where the
    unrolled :func:`lieint.fast.small_skew.congruence_skew_into` computes both; else ``tmp`` is
    scratch and the upper triangle is computed by loops, the rest mirrored)."""
    if congruence_skew_into(Q, X, M, out, tmp):
        return
    n = Q.shape[0]
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += X[i, k] * Q[k, j]
            tmp[i, j] = acc
    for i in range(n):
        out[i, i] = 0.0
        for j in range(i + 1, n):
            acc = 0.0
            for k in range(n):
                acc += Q[k, i] * tmp[k, j]
            out[i, j] = acc
            out[j, i] = -acc


@njit(cache=True, inline="always")
def _jacobian3(u0, u1, u2, v0, v1, v2):
    """``v − β u × v + γ u × (u × v)``: the right Jacobian of so(3) at u applied to v."""
    beta, gamma, _, _ = coefficients(u0 * u0 + u1 * u1 + u2 * u2)
    c0, c1, c2 = _cross(u0, u1, u2, v0, v1, v2)
    e0, e1, e2 = _cross(u0, u1, u2, c0, c1, c2)
    return v0 - beta * c0 + gamma * e0, v1 - beta * c1 + gamma * e1, v2 - beta * c2 + gamma * e2


@njit(cache=True)
def _dexp4_into(U, V, out):
    """:func:`_dexp_into` on so(4) in closed form: so(4) = so(3) ⊕ so(3), ``X = Σ a_i E⁺_i + Σ b_i E⁻_i``
    (``E⁺ = e₁₂ + e₃₄, e₁₃ − e₂₄, e₁₄ + e₂₃``, ``E⁻ = e₁₂ − e₃₄, e₁₃ + e₂₄, e₁₄ − e₂₃``), where
    ``[X, Y]`` has the parts ``−2 a × a′`` and ``2 b × b′``: ad_U is the cross product by ``−2a`` on the
    first part and by ``2b`` on the second, and the series sums to the right Jacobian of so(3) on
    each (β and γ of its angle)."""
    a0, a1, a2 = 0.5 * (U[0, 1] + U[2, 3]), 0.5 * (U[0, 2] - U[1, 3]), 0.5 * (U[0, 3] + U[1, 2])
    b0, b1, b2 = 0.5 * (U[0, 1] - U[2, 3]), 0.5 * (U[0, 2] + U[1, 3]), 0.5 * (U[0, 3] - U[1, 2])
    p0, p1, p2 = 0.5 * (V[0, 1] + V[2, 3]), 0.5 * (V[0, 2] - V[1, 3]), 0.5 * (V[0, 3] + V[1, 2])
    q0, q1, q2 = 0.5 * (V[0, 1] - V[2, 3]), 0.5 * (V[0, 2] + V[1, 3]), 0.5 * (V[0, 3] - V[1, 2])
    p0, p1, p2 = _jacobian3(-2.0 * a0, -2.0 * a1, -2.0 * a2, p0, p1, p2)
    q0, q1, q2 = _jacobian3(2.0 * b0, 2.0 * b1, 2.0 * b2, q0, q1, q2)
    w01, w23, w02, w13, w03, w12 = p0 + q0, p0 - q0, p1 + q1, q1 - p1, p2 + q2, p2 - q2
    out[0, 0], out[0, 1], out[0, 2], out[0, 3] = 0.0, w01, w02, w03
    out[1, 0], out[1, 1], out[1, 2], out[1, 3] = -w01, 0.0, w12, w13
    out[2, 0], out[2, 1], out[2, 2], out[2, 3] = -w02, -w12, 0.0, w23
    out[3, 0], out[3, 1], out[3, 2], out[3, 3] = -w03, -w13, -w23, 0.0


@njit(cache=True)
def _dexp_into(U, V, term, nxt, out):
    """``out = Σ_{j ≥ 0} (−1)^j/(j + 1)! ad_U^j V``: in closed form at n = 4 (:func:`_dexp4_into`),
    else summed until a term adds nothing to the sum (at most 60 terms; the series converges for
    every U, fast for a step's ``‖U‖``)."""
    n = U.shape[0]
    if n == 4:
        _dexp4_into(U, V, out)
        return
    for i in range(n):
        for j in range(n):
            term[i, j] = V[i, j]
            out[i, j] = V[i, j]
    for p in range(1, 60):
        _bracket_into(U, term, nxt)
        scale = -1.0 / (p + 1)
        changed = False
        for i in range(n):
            for j in range(n):
                t = scale * nxt[i, j]
                term[i, j] = t
                before = out[i, j]
                out[i, j] = before + t
                if out[i, j] != before:
                    changed = True
        if not changed:
            break


@njit(cache=True)
def _series_into(U, X, coeffs, T, tmp, out):
    """``out = Σ_d c_d T_d``, ``T_0 = X``, ``T_d = [−U, T_{d−1}] = [T_{d−1}, U]``."""
    n = U.shape[0]
    for i in range(n):
        for j in range(n):
            T[i, j] = X[i, j]
            out[i, j] = X[i, j]
    for dd in range(1, coeffs.shape[0]):
        _bracket_into(T, U, tmp)
        cd = coeffs[dd]
        for i in range(n):
            for j in range(n):
                T[i, j] = tmp[i, j]
                if cd != 0.0:
                    out[i, j] += cd * tmp[i, j]


@njit(cache=True)
def _series_tangent_into(U, dU, X, dX, coeffs, T, dT, tmp, tmp2, out):
    """How :func:`_series_into` moves: ``Σ_d c_d δT_d``, ``δT_d = [δT_{d−1}, U] + [T_{d−1}, δU]``."""
    n = U.shape[0]
    for i in range(n):
        for j in range(n):
            T[i, j] = X[i, j]
            dT[i, j] = dX[i, j]
            out[i, j] = dX[i, j]
    for dd in range(1, coeffs.shape[0]):
        _bracket_into(dT, U, tmp)
        _bracket_into(T, dU, tmp2)
        cd = coeffs[dd]
        for i in range(n):
            for j in range(n):
                dT[i, j] = tmp[i, j] + tmp2[i, j]
                if cd != 0.0:
                    out[i, j] += cd * dT[i, j]
        _bracket_into(T, U, tmp)
        for i in range(n):
            for j in range(n):
                T[i, j] = tmp[i, j]


@njit(cache=True)
def form_scratch(fx, meth, par, d):
    """The stage slopes ``K`` (s, n, n) and the tangent vectors' ``δK`` (k, s, n, n), ``U`` and
    ``δU`` (k, n, n), eight n × n temporaries (the stage's Ã, Ŵ, series terms, products), the
    exponential's work (5, n, n) and Q (:func:`lieint.fast.topn_step._exp_into`: the plain step's
    exponential, in closed form at n = 4)."""
    n = int(par[0])
    s = meth.b.shape[0]
    k = max(d // (2 * n * n) - 1, 1)
    return (np.zeros((s, n, n)), np.zeros((k, s, n, n)), np.zeros((n, n)), np.zeros((k, n, n)),
            np.zeros((8, n, n)), np.zeros((5, n, n)), np.zeros((n, n)))  # fmt: skip


@njit(cache=True)
def form_radius2(fx, y, par, scr):
    """``‖Ω̃‖_F²``, an upper bound of the squared ad spectral radius of ξ (the plain loop's)."""
    n = int(par[0])
    total = 0.0
    for i in range(n):
        for j in range(n):
            w = par[_M + i * n + j] * y[i * n + j]
            total += w * w
    return total


@njit(cache=True)
def _xi_into(par, X, out):
    """``out = M ∘ X`` (ξ = Ω̃ of a momentum, δξ of its perturbation: ξ is linear)."""
    n = X.shape[0]
    for i in range(n):
        for j in range(n):
            out[i, j] = par[_M + i * n + j] * X[i, j]


@njit(cache=True)
def form_rkmk_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One RKMK step (exponential coordinates, dexp⁻¹ truncated at ``meth.coeffs``) of a top's
    state and of its tangent vectors in forward mode (module docstring); ``inc`` = the step's
    increment U (n², flattened), ``aux[0]`` = ``‖ξ(y)‖_F²``. Returns the stages, or −1 when a
    stage reaches the dexp⁻¹ radius (as the plain step)."""
    K, dK, U, dU, tmp, work, Q = scr[0], scr[1], scr[2], scr[3], scr[4], scr[5], scr[6]
    Ai, W, T, dT, P1, P2, X, dX = tmp[0], tmp[1], tmp[2], tmp[3], tmp[4], tmp[5], tmp[6], tmp[7]
    n = int(par[0])
    nn = n * n
    block = 2 * nn
    d = y.shape[0]
    k = d // block - 1
    for i in range(d):
        y1[i] = y[i]
    orient = par[_ORIENT] != 0.0
    A, b, coeffs = meth.A, meth.b, meth.coeffs
    s = b.shape[0]
    A0, R0 = _mat(y1, 0, n), _mat(y1, nn, n)
    Mm = par[_M : _M + nn].reshape((n, n))
    for i in range(s + 1):  # the stages, then (i = s) the step's end
        U[:, :] = 0.0
        dU[:, :, :] = 0.0
        for j in range(i if i < s else s):
            weight = A[i, j] if i < s else b[j]
            if weight != 0.0:
                hw = h * weight
                for a in range(n):
                    for c in range(n):
                        U[a, c] += hw * K[j, a, c]
                for m in range(k):
                    for a in range(n):
                        for c in range(n):
                            dU[m, a, c] += hw * dK[m, j, a, c]
        if i == 0:  # U = 0 and δU = 0: K₀ = ξ(y), δK₀ = M ∘ δÃ
            _xi_into(par, A0, K[0])
            for m in range(k):
                _xi_into(par, _mat(y1, block * (m + 1), n), dK[m, 0])
            continue
        if i < s and out_of_range(U, 0):
            return -1
        _exp_into(U, Q, work)
        _conjugate_into(Q, A0, Mm, P1, Ai)
        if i == s:  # the step's end: the tangent vectors first, they read the state before it moves
            for m in range(k):
                o = block * (m + 1)
                _dexp_into(U, dU[m], P1, P2, W)
                dA, dR = _mat(y1, o, n), _mat(y1, o + nn, n)
                _conjugate_into(Q, dA, Mm, P1, X)
                _bracket_into(Ai, W, P2)
                for a in range(n):
                    for c in range(n):
                        dA[a, c] = X[a, c] + P2[a, c]  # skew: both terms are, entry by entry
                if orient:  # δR̃₁ = δR̃ Q + R̃₁ Ŵ, R̃₁ = R̃ Q
                    for a in range(n):
                        for c in range(n):
                            acc = 0.0
                            acc2 = 0.0
                            for e in range(n):
                                acc += dR[a, e] * Q[e, c]
                                acc2 += R0[a, e] * Q[e, c]
                            P1[a, c] = acc
                            X[a, c] = acc2  # R̃₁
                    for a in range(n):
                        for c in range(n):
                            acc = 0.0
                            for e in range(n):
                                acc += X[a, e] * W[e, c]
                            dR[a, c] = P1[a, c] + acc
            for a in range(n):
                for c in range(n):
                    A0[a, c] = Ai[a, c]
            if orient:
                for a in range(n):
                    for c in range(n):
                        acc = 0.0
                        for e in range(n):
                            acc += R0[a, e] * Q[e, c]
                        P1[a, c] = acc
                for a in range(n):
                    for c in range(n):
                        R0[a, c] = P1[a, c]
            for a in range(n):
                for c in range(n):
                    if a * n + c < inc.shape[0]:
                        inc[a * n + c] = U[a, c]
            total = 0.0
            for a in range(n):
                for c in range(n):
                    total += K[0, a, c] * K[0, a, c]
            aux[0] = total
            return s
        # a stage: ξ at the moved state and its truncated dexp⁻¹ series
        _xi_into(par, Ai, X)
        for m in range(k):
            o = block * (m + 1)
            _dexp_into(U, dU[m], P1, P2, W)
            _conjugate_into(Q, _mat(y1, o, n), Mm, P1, dT)
            _bracket_into(Ai, W, P2)
            for a in range(n):
                for c in range(n):
                    dT[a, c] += P2[a, c]
            _xi_into(par, dT, dX)
            _series_tangent_into(U, dU[m], X, dX, coeffs, T, dT, P1, P2, dK[m, i])
        _series_into(U, X, coeffs, T, P1, K[i])
    return s  # not reached: the loop returns at i = s


@njit(cache=True, inline="always")
def _chart_into(y1, o, n, orient, u):
    """The chart's coordinates of the tangent vector at ``y1[o :]``: the upper triangle of δÃ, then
    (with an attitude) that of the skew part of ``R̃ᵀδR̃`` (R̃ at ``y1[n² :]``)."""
    nn = n * n
    c = 0
    for i in range(n):
        for j in range(i + 1, n):
            u[c] = y1[o + i * n + j]
            c += 1
    if not orient:
        return c
    for i in range(n):
        for j in range(i + 1, n):
            mij = 0.0
            mji = 0.0
            for e in range(n):
                mij += y1[nn + e * n + i] * y1[o + nn + e * n + j]
                mji += y1[nn + e * n + j] * y1[o + nn + e * n + i]
            u[c] = 0.5 * (mij - mji)
            c += 1
    return c


@njit(cache=True)
def form_rkmk_megno_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_rkmk_tangent_step` of the state and one tangent vector, then MEGNO's sums
    (:func:`lieint.fast.tangent_sums.megno_advance`) on the vector's chart norm; −1 when a stage
    reached the dexp⁻¹ radius."""
    spent = form_rkmk_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    if spent >= 0:
        n = int(par[0])
        block = 2 * n * n
        u = np.empty(n * (n - 1))
        c = _chart_into(y1, block, n, par[_ORIENT] != 0.0, u)
        n2 = 0.0
        for a in range(c):
            n2 += u[a] * u[a]
        megno_advance(y1, 2 * block, h, np.sqrt(n2), block, 2 * block)
    return spent


@njit(cache=True)
def form_rkmk_lyapunov_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """:func:`form_rkmk_tangent_step`, then every ``every`` steps and after the last the k tangent
    vectors orthonormalised by modified Gram–Schmidt in the chart's norm (the coordinates are
    linear in the vectors: the combinations are applied to both) and ``log`` of each norm added to
    its sum; −1 when a stage reached the dexp⁻¹ radius."""
    spent = form_rkmk_tangent_step(fx, y, par, meth, h, y1, inc, aux, scr)
    if spent < 0:
        return spent
    n = int(par[0])
    block = 2 * n * n
    k = y.shape[0] // block - 1
    at = block * (1 + k)
    y1[at] += 1.0
    every, total = par[_M + n * n], par[_M + n * n + 1]
    if y1[at] % every != 0.0 and y1[at] != total:
        return spent
    orient = par[_ORIENT] != 0.0
    C = np.empty((k, n * (n - 1)))
    c = 0
    for j in range(k):
        c = _chart_into(y1, block * (j + 1), n, orient, C[j])
    for j in range(k):
        oj = block * (j + 1)
        for i in range(j):  # v_j ← v_j − ⟨q_i, v_j⟩ q_i, q_i already normalised
            oi = block * (i + 1)
            dot = 0.0
            for a in range(c):
                dot += C[i, a] * C[j, a]
            for a in range(c):
                C[j, a] -= dot * C[i, a]
            for a in range(block):
                y1[oj + a] -= dot * y1[oi + a]
        n2 = 0.0
        for a in range(c):
            n2 += C[j, a] * C[j, a]
        norm = np.sqrt(n2)
        y1[at + 1 + j] += np.log(norm)  # −inf or NaN when the vectors degenerate: the caller refuses
        for a in range(c):
            C[j, a] /= norm
        for a in range(block):
            y1[oj + a] /= norm
    return spent


_COMMON = {"prepare": prepare_nothing, "scratch": form_scratch, "project": keep_row, "radius2": form_radius2}

#: the names of :mod:`lieint.fast.loop` this form binds (fixed steps only, no projection: the
#: projection's derivative is not carried; the adaptive loop's names are left unbound)
NAMESPACES = {
    "rkmk": {**_COMMON, "step": form_rkmk_tangent_step},
    "rkmk_megno": {**_COMMON, "step": form_rkmk_megno_step},
    "rkmk_lyapunov": {**_COMMON, "step": form_rkmk_lyapunov_step},
}
