"""Compiled kernels for the 3D Euler top (numba, cached on disk).

The generic path moves dicts of batched matrices through Python for every stage; for the
3D top (the common case) this module runs the whole fixed-step loop in machine code:

* the state is ``(Π, R)`` in the principal frame of B (``A = −Π̂``, ``w = I⁻¹Π``), where the
  Euler top's SO(3) action is ``Π ↦ QᵀΠ``, ``R ↦ RQ`` and the bracket is the cross product;
* RKMK from any explicit tableau with exponential coordinates (Rodrigues) and dexp⁻¹
  truncated at the method's degree, or classical RK on the embedded equations;
* the projection is Newton–Schulz ``R ← R(3I − RᵀR)/2`` toward the polar factor (one step from
  a method's step, to convergence from farther),
  which for ``‖RᵀR − I‖ ~ 1e-16`` is the polar factor to round-off;
* bodies of an ensemble run in parallel threads (``prange``); a single body, or fewer bodies
  than threads, runs serially in the calling thread.

``lieint.integrate`` dispatches here automatically (``backend="auto"``) and the generic numpy
path remains the reference: ``tests/fast/test_top3.py`` checks that they agree to round-off.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["NAMESPACES", "minus_hat", "minus_vee"]

# (2π)²: the dexp⁻¹ series of so(3) converges for |u| < 2π (the spectral radius of ad_u is |u|)
_RADIUS2 = (2.0 * np.pi) ** 2


@njit(cache=True, inline="always")
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True, inline="always")
def rodrigues_coefficients(t2):
    """``sin θ/θ`` and ``(1 − cos θ)/θ²`` from ``t2 = θ²`` as even polynomials of degree 10
    (Horner, multiplications only), exact to round-off for ``θ < 0.1``: the first omitted terms,
    ``θ¹²/13!`` and ``θ¹²/14!``, are below 2e-22 there."""
    a = 1.0 + t2 * (-1.0 / 6 + t2 * (1.0 / 120 + t2 * (-1.0 / 5040 + t2 * (1.0 / 362880 + t2 * (-1.0 / 39916800)))))
    b = 0.5 + t2 * (-1.0 / 24 + t2 * (1.0 / 720 + t2 * (-1.0 / 40320 + t2 * (1.0 / 3628800 + t2 * (-1.0 / 479001600)))))
    return a, b


@njit(cache=True)
def _rodrigues(u, Q):
    """Q = exp(û), written into Q (3×3); below θ = 0.1 (every stage of a resolved step) the
    coefficients are polynomials: no sqrt, sin, cos or division."""
    t2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2]
    if t2 < 1e-2:
        a, b = rodrigues_coefficients(t2)
    else:
        th = np.sqrt(t2)
        a = np.sin(th) / th
        b = (1.0 - np.cos(th)) / t2
    rotation_into(u, a, b, Q)


@njit(cache=True, inline="always")
def rotation_into(u, a, b, Q):
    """``Q = I + a û + b û²`` written into Q: Rodrigues' formula for ``exp(û)`` with its coefficients
    ``a = sin θ/θ`` and ``b = (1 − cos θ)/θ²`` given (:func:`_rodrigues` computes them)."""
    x, y, z = u[0], u[1], u[2]
    Q[0, 0] = 1.0 - b * (y * y + z * z)
    Q[1, 1] = 1.0 - b * (x * x + z * z)
    Q[2, 2] = 1.0 - b * (x * x + y * y)
    Q[0, 1] = -a * z + b * x * y
    Q[1, 0] = a * z + b * x * y
    Q[0, 2] = a * y + b * x * z
    Q[2, 0] = -a * y + b * x * z
    Q[1, 2] = -a * x + b * y * z
    Q[2, 1] = a * x + b * y * z


@njit(cache=True, inline="always")
def _without_spin(p0, p1, p2, x0, x1, x2, reduce):
    """``ξ − μΠ`` with ``μ = ⟨ξ, Π⟩/⟨Π, Π⟩`` when ``reduce`` (the generator without its part along
    the momentum, :meth:`lieint.EulerTop.commuting_generator`), else ξ."""
    if not reduce:
        return x0, x1, x2
    n2 = p0 * p0 + p1 * p1 + p2 * p2
    if n2 == 0.0:
        return x0, x1, x2
    mu = (x0 * p0 + x1 * p1 + x2 * p2) / n2
    return x0 - mu * p0, x1 - mu * p1, x2 - mu * p2


@njit(cache=True)
def _lie_step(pi, R, Iinv, A, b, h, coeffs, K, u, Q, tmp_pi, tmp_R, reduce=False):
    """One RKMK step (right action, exp coordinates) in place on pi (3,) and R (3, 3); with
    ``reduce`` of the generator without its part along the momentum (:func:`_without_spin`).

    Returns False, leaving pi and R as they were, when a stage increment ``u`` reaches the
    radius of the dexp⁻¹ series (``|u| ≥ 2π`` on so(3)): the same exact test as the generic path."""
    s = b.shape[0]
    degree = coeffs.shape[0] - 1
    for i in range(s):
        u[0] = 0.0
        u[1] = 0.0
        u[2] = 0.0
        for j in range(i):
            if A[i, j] != 0.0:
                w = h * A[i, j]
                u[0] += w * K[j, 0]
                u[1] += w * K[j, 1]
                u[2] += w * K[j, 2]
        if i == 0 or (u[0] == 0.0 and u[1] == 0.0 and u[2] == 0.0):
            K[i, 0], K[i, 1], K[i, 2] = _without_spin(
                pi[0], pi[1], pi[2], Iinv[0] * pi[0], Iinv[1] * pi[1], Iinv[2] * pi[2], reduce
            )
            continue
        if u[0] * u[0] + u[1] * u[1] + u[2] * u[2] >= _RADIUS2:
            return False
        _rodrigues(u, Q)
        # Π_i = Qᵀ Π, ξ = I⁻¹ Π_i
        p0 = Q[0, 0] * pi[0] + Q[1, 0] * pi[1] + Q[2, 0] * pi[2]
        p1 = Q[0, 1] * pi[0] + Q[1, 1] * pi[1] + Q[2, 1] * pi[2]
        p2 = Q[0, 2] * pi[0] + Q[1, 2] * pi[1] + Q[2, 2] * pi[2]
        x0, x1, x2 = _without_spin(p0, p1, p2, Iinv[0] * p0, Iinv[1] * p1, Iinv[2] * p2, reduce)
        # k = dexp⁻¹_{−u}(ξ) = Σ_d c_d ad_{−u}^d ξ, ad_{−u} v = (−u) × v
        k0, k1, k2 = x0, x1, x2
        t0, t1, t2 = x0, x1, x2
        for d in range(1, degree + 1):
            t0, t1, t2 = _cross(-u[0], -u[1], -u[2], t0, t1, t2)
            c = coeffs[d]
            if c != 0.0:
                k0 += c * t0
                k1 += c * t1
                k2 += c * t2
        K[i, 0] = k0
        K[i, 1] = k1
        K[i, 2] = k2
    u[0] = 0.0
    u[1] = 0.0
    u[2] = 0.0
    for j in range(s):
        w = h * b[j]
        u[0] += w * K[j, 0]
        u[1] += w * K[j, 1]
        u[2] += w * K[j, 2]
    _rodrigues(u, Q)
    for r in range(3):
        tmp_pi[r] = Q[0, r] * pi[0] + Q[1, r] * pi[1] + Q[2, r] * pi[2]
    for r in range(3):
        for c2 in range(3):
            tmp_R[r, c2] = R[r, 0] * Q[0, c2] + R[r, 1] * Q[1, c2] + R[r, 2] * Q[2, c2]
    for r in range(3):
        pi[r] = tmp_pi[r]
        for c2 in range(3):
            R[r, c2] = tmp_R[r, c2]
    return True


@njit(cache=True)
def _classical_rhs(pi, R, Iinv, dpi, dR):
    """Π̇ = Π × w, Ṙ = R ŵ with w = I⁻¹Π."""
    w0, w1, w2 = Iinv[0] * pi[0], Iinv[1] * pi[1], Iinv[2] * pi[2]
    d0, d1, d2 = _cross(pi[0], pi[1], pi[2], w0, w1, w2)
    dpi[0], dpi[1], dpi[2] = d0, d1, d2
    for r in range(3):
        # (R ŵ)[r, :] = R[r, :] · ŵ, ŵ = [[0, −w2, w1], [w2, 0, −w0], [−w1, w0, 0]]
        dR[r, 0] = R[r, 1] * w2 - R[r, 2] * w1
        dR[r, 1] = -R[r, 0] * w2 + R[r, 2] * w0
        dR[r, 2] = R[r, 0] * w1 - R[r, 1] * w0


@njit(cache=True)
def _classical_step(pi, R, Iinv, A, b, h, Kpi, KR, ypi, yR):
    s = b.shape[0]
    for i in range(s):
        for r in range(3):
            ypi[r] = pi[r]
            for c2 in range(3):
                yR[r, c2] = R[r, c2]
        for j in range(i):
            w = h * A[i, j]
            if w != 0.0:
                for r in range(3):
                    ypi[r] += w * Kpi[j, r]
                    for c2 in range(3):
                        yR[r, c2] += w * KR[j, r, c2]
        _classical_rhs(ypi, yR, Iinv, Kpi[i], KR[i])
    for j in range(s):
        w = h * b[j]
        for r in range(3):
            pi[r] += w * Kpi[j, r]
            for c2 in range(3):
                R[r, c2] += w * KR[j, r, c2]


@njit(cache=True)
def _newton_schulz(R, tmp):
    """R ← R (3I − RᵀR)/2 toward the polar factor (quadratic convergence), in place.

    One step when ``max |RᵀR − I| ≤ 1e-8`` (a step of a method leaves R that close: the step
    then leaves ~1e-16), more until that holds otherwise. The map σ ↦ σ(3 − σ²)/2 of the
    singular values converges for σ in (0, √3); beyond ``max |RᵀR − I| ≥ 2/3`` (which could
    reach σ² ≥ 3) R is first divided by ``‖RᵀR‖₁^{1/2} ≥ σ_max`` (same polar factor), and at
    most 64 steps are taken.
    """
    worst = _gram3(R, tmp)
    if not np.isfinite(worst):
        return
    if worst >= 2.0 / 3.0:
        norm1 = 0.0
        for c2 in range(3):
            col = 0.0
            for r in range(3):
                col += abs((1.0 if r == c2 else 0.0) - tmp[r, c2])  # tmp = I − RᵀR: |RᵀR| entries
            norm1 = max(norm1, col)
        if norm1 > 0.0:
            scale = 1.0 / np.sqrt(norm1)
            for r in range(3):
                for c2 in range(3):
                    R[r, c2] *= scale
            worst = _gram3(R, tmp)
    out = np.empty((3, 3))
    for _ in range(128):
        for r in range(3):
            for c2 in range(3):
                out[r, c2] = 0.5 * (
                    R[r, 0] * (tmp[0, c2] + 2.0 * (0 == c2))
                    + R[r, 1] * (tmp[1, c2] + 2.0 * (1 == c2))
                    + R[r, 2] * (tmp[2, c2] + 2.0 * (2 == c2))
                )
        for r in range(3):
            for c2 in range(3):
                R[r, c2] = out[r, c2]
        if worst <= 1e-8:
            break
        worst = _gram3(R, tmp)
        if not np.isfinite(worst):
            break


@njit(cache=True)
def _gram3(R, tmp):
    """``tmp = I − RᵀR``; returns ``max |RᵀR − I|`` (NaN when R is not finite)."""
    worst = 0.0
    for r in range(3):
        for c2 in range(3):
            acc = 0.0
            for k in range(3):
                acc += R[k, r] * R[k, c2]
            d = (1.0 if r == c2 else 0.0) - acc
            tmp[r, c2] = d
            if abs(d) > worst or d != d:
                worst = abs(d)
    return worst


@njit(cache=True)
def _embedded(pi0, R0, K, w, h, u, Q, out_pi, out_R):
    """``ρ(exp(h Σ_j w_j k_j), (Π₀, R₀))`` into out_pi (3,), out_R (3, 3)."""
    u[0] = 0.0
    u[1] = 0.0
    u[2] = 0.0
    for j in range(w.shape[0]):
        c = h * w[j]
        if c != 0.0:
            u[0] += c * K[j, 0]
            u[1] += c * K[j, 1]
            u[2] += c * K[j, 2]
    _rodrigues(u, Q)
    for r in range(3):
        out_pi[r] = Q[0, r] * pi0[0] + Q[1, r] * pi0[1] + Q[2, r] * pi0[2]
        for c2 in range(3):
            out_R[r, c2] = R0[r, 0] * Q[0, c2] + R0[r, 1] * Q[1, c2] + R0[r, 2] * Q[2, c2]


@njit(cache=True)
def _scaled(pi0, R0, pi1, R1, pih, Rh, P, orientation, rtol, atol, U0, U1, Uh):
    """``Σ_i r_i²`` over the user-frame entries of A (and R) of one body (see the module text)."""
    total = 0.0
    for r in range(3):
        a0 = P[r, 0] * pi0[0] + P[r, 1] * pi0[1] + P[r, 2] * pi0[2]
        a1 = P[r, 0] * pi1[0] + P[r, 1] * pi1[1] + P[r, 2] * pi1[2]
        ah = P[r, 0] * pih[0] + P[r, 1] * pih[1] + P[r, 2] * pih[2]
        x = (a1 - ah) / (atol + rtol * max(abs(a0), abs(a1)))
        total += 2.0 * x * x  # A = −(PΠ)^ holds each component twice, with both signs
    if orientation:
        for r in range(3):
            for c2 in range(3):  # R_user = R Pᵀ
                U0[r, c2] = R0[r, 0] * P[c2, 0] + R0[r, 1] * P[c2, 1] + R0[r, 2] * P[c2, 2]
                U1[r, c2] = R1[r, 0] * P[c2, 0] + R1[r, 1] * P[c2, 1] + R1[r, 2] * P[c2, 2]
                Uh[r, c2] = Rh[r, 0] * P[c2, 0] + Rh[r, 1] * P[c2, 1] + Rh[r, 2] * P[c2, 2]
        for r in range(3):
            for c2 in range(3):
                x = (U1[r, c2] - Uh[r, c2]) / (atol + rtol * max(abs(U0[r, c2]), abs(U1[r, c2])))
                total += x * x
    return total


# -- the 3D top as a form of the one compiled loop (lieint.fast.loop) -----------------------------
# State of one body: y = (Π, R P) in the principal frame, 12 floats (R = I when the top carries no
# attitude); parameters par = (I⁻¹ (3), P (9), orientation, identity frame).


@njit(cache=True, inline="always")
def _pi(y):
    return y[0:3]


@njit(cache=True, inline="always")
def _att(y):
    return y[3:12].reshape((3, 3))


@njit(cache=True)
def form_prepare(ctx):
    """Nothing to prepare: the 3D top's stage code is in this module."""
    return ctx


@njit(cache=True)
def form_scratch(fx, meth, par, d):
    """``K`` (s, 3), ``u``, ``Q``, ``Π`` and R temporaries, ``KR`` (s, 3, 3) of classical RK, the
    user-frame matrices of the error norm."""
    s = meth.b.shape[0]
    return (
        np.zeros((s, 3)), np.zeros(3), np.zeros((3, 3)), np.zeros(3), np.zeros((3, 3)), np.zeros((s, 3, 3)),
        np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3)),
    )  # fmt: skip


@njit(cache=True)
def form_lie_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One RKMK step (exponential coordinates) of one body; ``inc`` = the step's increment
    ``h Σ b_j k_j`` (the so(3) vector), ``aux[0] = |w|²`` of the first stage."""
    K, u, Q, tpi, tR = scr[0], scr[1], scr[2], scr[3], scr[4]
    for i in range(12):
        y1[i] = y[i]
    if not _lie_step(_pi(y1), _att(y1), par[0:3], meth.A, meth.b, h, meth.coeffs, K, u, Q, tpi, tR):
        return -1
    inc[0], inc[1], inc[2] = u[0], u[1], u[2]
    aux[0] = K[0, 0] * K[0, 0] + K[0, 1] * K[0, 1] + K[0, 2] * K[0, 2]
    return meth.b.shape[0]


@njit(cache=True)
def form_rk_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One classical RK step on ``Π̇ = Π × w``, ``Ṙ = R ŵ``."""
    K, tpi, tR, KR = scr[0], scr[3], scr[4], scr[5]
    for i in range(12):
        y1[i] = y[i]
    _classical_step(_pi(y1), _att(y1), par[0:3], meth.A, meth.b, h, K, KR, tpi, tR)
    return meth.b.shape[0]


@njit(cache=True)
def form_embedded(fx, y, par, meth, weights, h, yh, scr):
    """``ρ(exp(h Σ_j w_j k_j), y)`` from the stages of the last step."""
    K, u, Q = scr[0], scr[1], scr[2]
    pih, Rh = yh[0:3], yh[3:12].reshape((3, 3))
    _embedded(_pi(y), _att(y), K, weights, h, u, Q, pih, Rh)


@njit(cache=True)
def form_error_sum(fx, y0, y1, yh, par, rtol, atol, scr):
    """``Σ r_i²`` over the user's A (and R) of one body (:func:`_scaled`)."""
    P = par[3:12].reshape((3, 3))
    return _scaled(
        _pi(y0), _att(y0), _pi(y1), _att(y1), yh[0:3], yh[3:12].reshape((3, 3)), P, par[12] != 0.0, rtol, atol,
        scr[6], scr[7], scr[8],
    )  # fmt: skip


@njit(cache=True)
def form_project(fx, y, par, out, scr):
    """R onto SO(3) by Newton–Schulz (:func:`_newton_schulz`); Π (and the energy pairs' level,
    entry 12) as it is."""
    for i in range(y.shape[0]):
        out[i] = y[i]
    _newton_schulz(_att(out), scr[2])


@njit(cache=True)
def form_radius2(fx, y, par, scr):
    """``|w|²``, ``w = I⁻¹Π``: the squared ad spectral radius of ``ξ = ŵ`` on so(3) (exact)."""
    w0, w1, w2 = par[0] * y[0], par[1] * y[1], par[2] * y[2]
    return w0 * w0 + w1 * w1 + w2 * w2


@njit(cache=True)
def form_user_field(fx, yu, par, fu, scr):
    """The vector field at a state in the user's flat layout ``(A (9), R (9))`` (R only when the
    top carries it), in that layout: ``Ȧ = [A, Ω] = −(Π × ω)^``, ``Ṙ = R ω̂`` with ``Π = −vee A``,
    ``ω = P I⁻¹ Pᵀ Π``."""
    P = par[3:12].reshape((3, 3))
    p0 = -0.5 * (yu[7] - yu[5])
    p1 = -0.5 * (yu[2] - yu[6])
    p2 = -0.5 * (yu[3] - yu[1])
    w = np.empty(3)
    for c in range(3):  # principal frame: I⁻¹ Pᵀ Π
        w[c] = par[c] * (P[0, c] * p0 + P[1, c] * p1 + P[2, c] * p2)
    o0 = P[0, 0] * w[0] + P[0, 1] * w[1] + P[0, 2] * w[2]
    o1 = P[1, 0] * w[0] + P[1, 1] * w[1] + P[1, 2] * w[2]
    o2 = P[2, 0] * w[0] + P[2, 1] * w[1] + P[2, 2] * w[2]
    d0, d1, d2 = _cross(p0, p1, p2, o0, o1, o2)
    # −hat(d)
    fu[0], fu[1], fu[2] = 0.0, d2, -d1
    fu[3], fu[4], fu[5] = -d2, 0.0, d0
    fu[6], fu[7], fu[8] = d1, -d0, 0.0
    if par[12] != 0.0:
        for r in range(3):
            R0, R1, R2 = yu[9 + 3 * r], yu[10 + 3 * r], yu[11 + 3 * r]
            fu[9 + 3 * r] = R1 * o2 - R2 * o1
            fu[10 + 3 * r] = -R0 * o2 + R2 * o0
            fu[11 + 3 * r] = R0 * o1 - R1 * o0


# -- the energy-keeping pairs (lieint.methods.energy_projection) on the 3D top ---------------------
# State of one body: (Π, R P, H₀), 13 floats — the level every accepted step ends on travels with
# the state, so a run split into calls keeps the level of its start. A step: the exact flow of the
# generator's part along Π (``R ← R exp(hμΠ)``, Π stays), the pair's step of ``w − μΠ`` from there,
# then the move along the orbit onto H₀; the error estimate is the pair's (before the move), as on
# the generic path.

#: :data:`lieint.methods.energy_projection.LEVEL_ULPS` · ε (the generic path's level band)
_LEVEL = 64 * 2.220446049250313e-16
#: the largest orbit move accepted and the secant iterations (the generic path's)
_MAX_MOVE = 1e-3
_ITERATIONS = 4


@njit(cache=True, inline="always")
def _energy(Iinv, p0, p1, p2):
    """``H = ½ Σ Π_i²/I_i``."""
    return 0.5 * (Iinv[0] * p0 * p0 + Iinv[1] * p1 * p1 + Iinv[2] * p2 * p2)


@njit(cache=True)
def _turned_energy(Iinv, pi, g, s, Q):
    """H of ``exp(s ĝ)ᵀ Π`` (Q receives the rotation)."""
    u = np.empty(3)
    u[0], u[1], u[2] = s * g[0], s * g[1], s * g[2]
    _rodrigues(u, Q)
    p0 = Q[0, 0] * pi[0] + Q[1, 0] * pi[1] + Q[2, 0] * pi[2]
    p1 = Q[0, 1] * pi[0] + Q[1, 1] * pi[1] + Q[2, 1] * pi[2]
    p2 = Q[0, 2] * pi[0] + Q[1, 2] * pi[1] + Q[2, 2] * pi[2]
    return _energy(Iinv, p0, p1, p2)


@njit(cache=True)
def _onto_level(pi, R, Iinv, level0, g, Q, tmp_pi, tmp_R):
    """Move ``(Π, R)`` along the orbit, ``(exp(sĝ)ᵀΠ, R exp(sĝ))``, onto ``H = level0`` in place:
    ĝ the steepest ascent of H within the orbit, ``g = w × Π`` (``dH/ds = g·(w × Π)`` at s = 0:
    the exact gradient the generic path takes by central differences), s by one Newton step and
    secant steps — the generic path's rule (:meth:`EnergyProjected.onto_level`), band, limits and
    all, for one body."""
    w0, w1, w2 = Iinv[0] * pi[0], Iinv[1] * pi[1], Iinv[2] * pi[2]
    f0 = _energy(Iinv, pi[0], pi[1], pi[2]) - level0
    band = _LEVEL * abs(level0)
    if not (np.isfinite(f0) and abs(f0) > band):
        return
    g[0], g[1], g[2] = _cross(w0, w1, w2, pi[0], pi[1], pi[2])
    slope0 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2]
    if not slope0 > 0.0:
        return
    s_prev, f_prev = 0.0, f0
    s = -f0 / slope0
    f = _turned_energy(Iinv, pi, g, s, Q) - level0
    for _ in range(_ITERATIONS - 1):
        if not (abs(f) > band and f != f_prev):
            break
        step = f * (s - s_prev) / (f - f_prev)
        s_prev, f_prev, s = s, f, s - step
        f = _turned_energy(Iinv, pi, g, s, Q) - level0
    size = abs(s) * np.sqrt(slope0)
    if not (np.isfinite(s) and np.isfinite(f) and size <= _MAX_MOVE):
        return
    if not (abs(f) <= band or abs(f) <= 1e-2 * abs(f0)):
        return
    _turned_energy(Iinv, pi, g, s, Q)
    for r in range(3):
        tmp_pi[r] = Q[0, r] * pi[0] + Q[1, r] * pi[1] + Q[2, r] * pi[2]
    for r in range(3):
        for c2 in range(3):
            tmp_R[r, c2] = R[r, 0] * Q[0, c2] + R[r, 1] * Q[1, c2] + R[r, 2] * Q[2, c2]
    for r in range(3):
        pi[r] = tmp_pi[r]
        for c2 in range(3):
            R[r, c2] = tmp_R[r, c2]


@njit(cache=True)
def form_energy_scratch(fx, meth, par, d):
    """:func:`form_scratch`'s arrays, the state after the spin's flow (12: where the embedded
    solutions start), the move onto the level (12: added to them) and the orbit direction (3)."""
    return form_scratch(fx, meth, par, d) + (np.zeros(12), np.zeros(12), np.zeros(3))


@njit(cache=True)
def form_energy_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One step of an energy-keeping pair (see above); ``inc`` = the pair's increment (unused by
    dense output: these pairs' interpolants step again, :meth:`lieint.fast.engine.Engine.restep`)."""
    K, u, Q, tpi, tR = scr[0], scr[1], scr[2], scr[3], scr[4]
    turned, moved, g = scr[9], scr[10], scr[11]
    Iinv = par[0:3]
    p0, p1, p2 = y[0], y[1], y[2]
    n2 = p0 * p0 + p1 * p1 + p2 * p2
    mu = (Iinv[0] * p0 * p0 + Iinv[1] * p1 * p1 + Iinv[2] * p2 * p2) / n2 if n2 > 0.0 else 0.0
    u[0], u[1], u[2] = h * mu * p0, h * mu * p1, h * mu * p2
    _rodrigues(u, Q)
    for i in range(3):
        turned[i] = y[i]
    R0 = _att(y)
    for r in range(3):
        for c2 in range(3):
            turned[3 + 3 * r + c2] = R0[r, 0] * Q[0, c2] + R0[r, 1] * Q[1, c2] + R0[r, 2] * Q[2, c2]
    for i in range(12):
        y1[i] = turned[i]
    y1[12] = y[12]
    if not _lie_step(_pi(y1), _att(y1), Iinv, meth.A, meth.b, h, meth.coeffs, K, u, Q, tpi, tR, True):
        return -1
    inc[0], inc[1], inc[2] = u[0], u[1], u[2]
    for i in range(12):
        moved[i] = y1[i]
    _onto_level(_pi(y1), _att(y1), Iinv, y[12], g, Q, tpi, tR)
    for i in range(12):
        moved[i] = y1[i] - moved[i]
    aux[0] = -1.0
    return meth.b.shape[0]


@njit(cache=True)
def form_energy_embedded(fx, y, par, meth, weights, h, yh, scr):
    """The pair's embedded solution from the state after the spin's flow, plus the move onto the
    level: ``y₁ − ŷ`` is then the pair's own difference, as the generic path's estimate."""
    K, u, Q, turned, moved = scr[0], scr[1], scr[2], scr[9], scr[10]
    pih, Rh = yh[0:3], yh[3:12].reshape((3, 3))
    _embedded(turned[0:3], turned[3:12].reshape((3, 3)), K, weights, h, u, Q, pih, Rh)
    for i in range(12):
        yh[i] += moved[i]
    yh[12] = y[12]


# -- products of exponentials (commutator-free, Crouch–Grossman: lieint.fast.forms.ExpProductForm) --


@njit(cache=True, inline="always")
def _exponent(u, K, weights, row, upto, h):
    """``u = Σ_{j < upto} (h w_j) K[j]``, ``w = weights[row]``, over the nonzero weights in the order
    of j (the numpy path's combination); returns whether any weight was nonzero."""
    u[0] = 0.0
    u[1] = 0.0
    u[2] = 0.0
    any_weight = False
    for j in range(upto):
        if weights[row, j] != 0.0:
            any_weight = True
            w = h * weights[row, j]
            u[0] += w * K[j, 0]
            u[1] += w * K[j, 1]
            u[2] += w * K[j, 2]
    return any_weight


@njit(cache=True)
def _products_step(pi, R, Iinv, weights, bounds, h, K, u, Q, tR, inc):
    """One step of a product of exponentials in place on pi (3,) and R (3, 3): stage i turns Π by
    its exponentials one after the other (its ξ depends on Π alone), the step turns Π and R by
    its own; ``inc`` receives the step's exponents, three entries each."""
    s = bounds.shape[0] - 2
    for i in range(s):
        p0, p1, p2 = pi[0], pi[1], pi[2]
        for e in range(bounds[i], bounds[i + 1]):
            if not _exponent(u, K, weights, e, i, h):
                continue
            _rodrigues(u, Q)
            # Π ← QᵀΠ
            q0 = Q[0, 0] * p0 + Q[1, 0] * p1 + Q[2, 0] * p2
            q1 = Q[0, 1] * p0 + Q[1, 1] * p1 + Q[2, 1] * p2
            q2 = Q[0, 2] * p0 + Q[1, 2] * p1 + Q[2, 2] * p2
            p0, p1, p2 = q0, q1, q2
        K[i, 0], K[i, 1], K[i, 2] = Iinv[0] * p0, Iinv[1] * p1, Iinv[2] * p2
    first = bounds[s]
    for e in range(first, bounds[s + 1]):
        o = 3 * (e - first)
        if not _exponent(u, K, weights, e, s, h):
            inc[o], inc[o + 1], inc[o + 2] = 0.0, 0.0, 0.0
            continue
        inc[o], inc[o + 1], inc[o + 2] = u[0], u[1], u[2]
        _rodrigues(u, Q)
        p0, p1, p2 = pi[0], pi[1], pi[2]
        for r in range(3):
            pi[r] = Q[0, r] * p0 + Q[1, r] * p1 + Q[2, r] * p2
        for r in range(3):
            for c2 in range(3):
                tR[r, c2] = R[r, 0] * Q[0, c2] + R[r, 1] * Q[1, c2] + R[r, 2] * Q[2, c2]
        for r in range(3):
            for c2 in range(3):
                R[r, c2] = tR[r, c2]


@njit(cache=True)
def form_products_scratch(fx, meth, par, d):
    """:func:`form_scratch`'s arrays for s = the method's stages (the error norm's are unused)."""
    s = meth.c.shape[0]
    return (np.zeros((s, 3)), np.zeros(3), np.zeros((3, 3)), np.zeros(3), np.zeros((3, 3)))


@njit(cache=True)
def form_products_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One step of a product of exponentials (:func:`_products_step`) of one body; ``aux[0] = |w|²``
    of the first stage. Never out of range: there is no dexp⁻¹."""
    K, u, Q, tR = scr[0], scr[1], scr[2], scr[4]
    for i in range(12):
        y1[i] = y[i]
    _products_step(_pi(y1), _att(y1), par[0:3], meth.weights, meth.bounds, h, K, u, Q, tR, inc)
    aux[0] = K[0, 0] * K[0, 0] + K[0, 1] * K[0, 1] + K[0, 2] * K[0, 2]
    return meth.c.shape[0]


#: the names of :mod:`lieint.fast.loop` this form binds, per method family
NAMESPACES = {
    family: {
        "prepare": form_prepare,
        "scratch": form_scratch,
        "step": stepper,
        "embedded": form_embedded,
        "error_sum": form_error_sum,
        "project": form_project,
        "radius2": form_radius2,
        "user_field": form_user_field,
    }
    for family, stepper in (("rkmk", form_lie_step), ("rk", form_rk_step))
}
#: products of exponentials (no pairs: the controller loop, the embedded solution and the error
#: norm are never compiled for them)
NAMESPACES["cf"] = {**NAMESPACES["rkmk"], "scratch": form_products_scratch, "step": form_products_step}
NAMESPACES["rkmk_energy"] = {
    **NAMESPACES["rkmk"],
    "scratch": form_energy_scratch,
    "step": form_energy_step,
    "embedded": form_energy_embedded,
}


@njit(cache=True)
def _minus_hat_rows(w, out):
    for r in range(w.shape[0]):
        x, y, z = w[r, 0], w[r, 1], w[r, 2]
        out[r, 0, 0] = 0.0
        out[r, 0, 1] = z
        out[r, 0, 2] = -y
        out[r, 1, 0] = -z
        out[r, 1, 1] = 0.0
        out[r, 1, 2] = x
        out[r, 2, 0] = y
        out[r, 2, 1] = -x
        out[r, 2, 2] = 0.0


@njit(cache=True)
def _minus_vee_rows(X, out):
    for r in range(X.shape[0]):
        out[r, 0] = -0.5 * (X[r, 2, 1] - X[r, 1, 2])
        out[r, 1] = -0.5 * (X[r, 0, 2] - X[r, 2, 0])
        out[r, 2] = -0.5 * (X[r, 1, 0] - X[r, 0, 1])


def minus_vee(X: np.ndarray) -> np.ndarray:
    """``−vee(X)`` of ``(..., 3, 3)`` matrices as ``(..., 3)`` vectors in one compiled pass, the
    values of ``-vee(X)`` (signed zeros included): ``−0.5 (X₂₁ − X₁₂, X₀₂ − X₂₀, X₁₀ − X₀₁)``."""
    out = np.empty(X.shape[:-2] + (3,))
    _minus_vee_rows(np.ascontiguousarray(X, dtype=np.float64).reshape(-1, 3, 3), out.reshape(-1, 3))
    return out


def minus_hat(w: np.ndarray) -> np.ndarray:
    """``−ŵ`` of vectors ``(..., 3)`` as ``(..., 3, 3)`` matrices, in one compiled pass: the values
    of ``-hat(w)`` (negation is exact) with ``+0.0`` on the diagonal."""
    lead = w.shape[:-1]
    out = np.empty(lead + (3, 3))
    _minus_hat_rows(np.ascontiguousarray(w, dtype=np.float64).reshape(-1, 3), out.reshape(-1, 3, 3))
    return out
