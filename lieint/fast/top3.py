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
path remains the reference: ``tests/test_fast.py`` checks that they agree to round-off.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["integrate_top3", "largest_rate", "minus_hat", "minus_vee"]

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


@njit(cache=True)
def _lie_step(pi, R, Iinv, A, b, h, coeffs, K, u, Q, tmp_pi, tmp_R):
    """One RKMK step (right action, exp coordinates) in place on pi (3,) and R (3, 3).

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
            K[i, 0] = Iinv[0] * pi[0]
            K[i, 1] = Iinv[1] * pi[1]
            K[i, 2] = Iinv[2] * pi[2]
            continue
        if u[0] * u[0] + u[1] * u[1] + u[2] * u[2] >= _RADIUS2:
            return False
        _rodrigues(u, Q)
        # Π_i = Qᵀ Π, ξ = I⁻¹ Π_i
        x0 = Iinv[0] * (Q[0, 0] * pi[0] + Q[1, 0] * pi[1] + Q[2, 0] * pi[2])
        x1 = Iinv[1] * (Q[0, 1] * pi[0] + Q[1, 1] * pi[1] + Q[2, 1] * pi[2])
        x2 = Iinv[2] * (Q[0, 2] * pi[0] + Q[1, 2] * pi[1] + Q[2, 2] * pi[2])
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
def _run_body(
    n,
    pi0,
    R0,
    Iinv,
    A,
    b,
    coeffs,
    lie,
    h,
    h_last,
    k_from,
    k_to,
    nsteps,
    save_steps,
    project,
    out_pi,
    out_R,
    fin_pi,
    fin_R,
):
    """Steps k_from < k ≤ k_to of body n on the global grid (the last global step has size
    h_last); states after the steps listed in save_steps go to out_*, the state after k_to to
    fin_*. Returns -1, or the step k at which a stage left the dexp⁻¹ radius (the run stops)."""
    s = b.shape[0]
    pi = pi0[n].copy()
    R = R0[n].copy()
    K = np.zeros((s, 3))
    KR = np.zeros((s, 3, 3))
    u = np.zeros(3)
    Q = np.zeros((3, 3))
    tpi = np.zeros(3)
    tR = np.zeros((3, 3))
    slot = 0
    status = -1
    for k in range(k_from, k_to):
        hk = h if k < nsteps - 1 else h_last
        if lie:
            if not _lie_step(pi, R, Iinv, A, b, hk, coeffs, K, u, Q, tpi, tR):
                status = k
                break
        else:
            _classical_step(pi, R, Iinv, A, b, hk, K, KR, tpi, tR)
        if project:
            _newton_schulz(R, Q)
        if slot < save_steps.shape[0] and save_steps[slot] == k + 1:
            out_pi[slot, n] = pi
            out_R[slot, n] = R
            slot += 1
    fin_pi[n] = pi
    fin_R[n] = R
    return status


@njit(cache=True, parallel=True)
def _run_parallel(
    pi0, R0, Iinv, A, b, coeffs, lie, h, h_last, k_from, k_to, nsteps, save_steps, project, out_pi, out_R, fin_pi, fin_R
):
    """Bodies in parallel threads (``prange``); per-body status as :func:`_run_body`."""
    nb = pi0.shape[0]
    status = np.empty(nb, dtype=np.int64)
    for n in prange(nb):
        status[n] = _run_body(
            n, pi0, R0, Iinv, A, b, coeffs, lie, h, h_last, k_from, k_to, nsteps, save_steps, project,
            out_pi, out_R, fin_pi, fin_R,
        )  # fmt: skip
    return status


@njit(cache=True)
def _run_serial(
    pi0, R0, Iinv, A, b, coeffs, lie, h, h_last, k_from, k_to, nsteps, save_steps, project, out_pi, out_R, fin_pi, fin_R
):
    """Bodies one after the other in the calling thread: a single trajectory (or fewer bodies
    than threads) pays no thread start-up or scheduling, which on a busy machine costs
    milliseconds per call."""
    nb = pi0.shape[0]
    status = np.empty(nb, dtype=np.int64)
    for n in range(nb):
        status[n] = _run_body(
            n, pi0, R0, Iinv, A, b, coeffs, lie, h, h_last, k_from, k_to, nsteps, save_steps, project,
            out_pi, out_R, fin_pi, fin_R,
        )  # fmt: skip
    return status


def integrate_top3(
    pi0,
    R0,
    inverse_moments,
    tableau_A,
    tableau_b,
    coeffs,
    lie: bool,
    h,
    h_last,
    k_from,
    k_to,
    nsteps,
    save_steps,
    project: bool,
    parallel: bool = False,
    start_row: bool = False,
):
    """Run the compiled loop over steps ``k_from < k ≤ k_to`` (bodies in threads if ``parallel``):
    ``Π`` (N, 3) and ``R`` (N, 3, 3) in the principal frame, the inverse principal moments, the
    tableau's A and b as C-contiguous float64 arrays.

    Returns ``(Π, R)`` at the global save steps in that range, shapes ``(m, N, 3)`` and
    ``(m, N, 3, 3)`` (with ``start_row`` the starting state first: ``m + 1`` rows, written
    where the loop writes, so that a whole run's rows need no concatenation), the final
    ``(Π, R)``, all in the principal frame, and the first step at which a stage left the dexp⁻¹
    radius (-1: none).
    """
    save_steps = np.asarray(save_steps, dtype=np.int64)
    m, N, s = save_steps.size, pi0.shape[0], int(bool(start_row))
    pi0, R0 = np.ascontiguousarray(pi0), np.ascontiguousarray(R0)
    out_pi, out_R = np.empty((m + s, N, 3)), np.empty((m + s, N, 3, 3))
    if s:
        out_pi[0], out_R[0] = pi0, R0
    fin_pi, fin_R = np.empty((N, 3)), np.empty((N, 3, 3))
    run = _run_parallel if parallel else _run_serial
    status = run(
        pi0,
        R0,
        inverse_moments,
        tableau_A,
        tableau_b,
        coeffs,
        bool(lie),
        float(h),
        float(h_last),
        int(k_from),
        int(k_to),
        int(nsteps),
        save_steps,
        bool(project),
        out_pi[s:],  # C-contiguous views: the compiled signature's layout
        out_R[s:],
        fin_pi,
        fin_R,
    )
    if np.maximum.reduce(status, initial=-1) < 0:
        return out_pi, out_R, fin_pi, fin_R, -1
    return out_pi, out_R, fin_pi, fin_R, int(status[status >= 0].min())


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


@njit(cache=True)
def _largest_rate(A, P, Iinv):
    """``max |ω|`` over the rows of A (``(m, 3, 3)``, the user's frame), ``ω = I⁻¹ Pᵀ(−vee A)``
    (the principal-frame Π of a proper P is ``Pᵀ(−vee A)``); NaN when a row is not finite."""
    best = 0.0
    for r in range(A.shape[0]):
        v0 = -0.5 * (A[r, 2, 1] - A[r, 1, 2])
        v1 = -0.5 * (A[r, 0, 2] - A[r, 2, 0])
        v2 = -0.5 * (A[r, 1, 0] - A[r, 0, 1])
        acc = 0.0
        for c in range(3):
            w = Iinv[c] * (P[0, c] * v0 + P[1, c] * v1 + P[2, c] * v2)
            acc += w * w
        if not np.isfinite(acc):
            return np.nan
        if acc > best:
            best = acc
    return np.sqrt(best)


def largest_rate(A: np.ndarray, P: np.ndarray, moments: np.ndarray) -> float:
    """The largest angular speed ``|ω|`` over the momenta ``A`` (``(..., 3, 3)``) of a top with
    principal moments ``moments`` in the proper frame P — the ad spectral radius of ``ξ = ŵ``
    on so(3) — in one compiled pass; NaN when a row is not finite."""
    rows = np.ascontiguousarray(A, dtype=np.float64).reshape(-1, 3, 3)
    return float(_largest_rate(rows, np.ascontiguousarray(P, dtype=np.float64), 1.0 / moments))


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
