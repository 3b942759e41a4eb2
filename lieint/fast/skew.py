"""Compiled building blocks on so(n) and se(n) shared by the kernels (numba, cached on disk).

* ``exp`` of a skew matrix (:func:`expm_skew`) and of an se(n) element (:func:`expm_se`) by
  scaling and squaring with a Taylor polynomial evaluated by Paterson–Stockmeyer: matrix
  products only, no linear solve;
* the exact dexp⁻¹ range test on so(n) (:func:`so_ad_radius_exceeds`);
* brackets of skew matrices in one product, and the Newton–Schulz projection onto SO(n).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._jit import NO_REFCOUNT, compiled_copies
from .products import copy_matrix_into, mm, mm_into, mm_small_into, mm_unrolled_into

__all__ = [
    "expm_se",
    "expm_skew",
    "expm_skew_into",
    "expm_skew_small_into",
    "expm_so4_into",
    "expm_so_se_into",
    "so_ad_radius_exceeds",
]

_TWO_PI = 2.0 * np.pi

#: ``1/k!`` for the Taylor polynomial of exp
_INV_FACTORIAL = np.array([1.0 / math.factorial(k) for k in range(17)])
#: Paterson–Stockmeyer shapes ``(p, q)`` of the Taylor degrees ``m = pq`` used, and for each
#: the largest norm θ_m with ``θ_m^{m+1}/(m+1)! ≤ 2⁻⁵³`` (the truncation error on a skew
#: matrix of spectral norm θ ≤ θ_m, whose eigenvalues are ``±iθ_k``, stays below the unit
#: round-off): m = 4, 6, 9, 12, 16 cost 2, 3, 4, 5, 6 products.
_SHAPES = np.array([[2, 2], [3, 2], [3, 3], [4, 3], [4, 4]], dtype=np.int64)
_THETAS = np.array([(math.factorial(p * q + 1) * 2.0**-53) ** (1.0 / (p * q + 1)) for p, q in _SHAPES])
#: the same for the translation of an se(n) element ``(W, v)``: its Taylor error is
#: ``|Σ_{k>m} W^{k−1}v/k!| ≤ |v| θ^m/(m+1)!``, below ``2⁻⁵³|v|`` for θ ≤ θ'_m
_THETAS_SE = np.array([(math.factorial(p * q + 1) * 2.0**-53) ** (1.0 / (p * q)) for p, q in _SHAPES])


@njit(cache=True)
def _onenorm(X):
    """``‖X‖₁``, the largest absolute column sum (for skew X it bounds ``‖X‖₂ = θ₁``)."""
    n = X.shape[0]
    best = 0.0
    for j in range(n):
        acc = 0.0
        for i in range(n):
            acc += abs(X[i, j])
        if acc > best:
            best = acc
    return best


@njit(cache=True)
def expm_skew(u):
    """``exp(u)`` of a finite skew matrix: Taylor polynomial with scaling and squaring.

    For skew u (a normal matrix with eigenvalues ``±iθ_k``) the error of the Taylor
    polynomial ``T_m`` is ``max_k |e^{iθ_k} − T_m(iθ_k)| ≤ θ₁^{m+1}/(m+1)!`` in the 2-norm, and
    ``θ₁ = ‖u‖₂ ≤ η = min(‖u‖₁, ‖u²‖₁^{1/2})`` (u² is needed anyway). The degree
    m ∈ {4, 6, 9, 12, 16} is the least with ``η ≤ θ_m`` (error below 2⁻⁵³); above
    ``θ₁₆ ≈ 0.83`` u is scaled by ``2⁻ˢ`` and the result squared s times (as in
    Higham's scaling and squaring, SIAM J. Matrix Anal. Appl. 26, 2005, with the Taylor
    approximant of Al-Mohy & Higham, 2009). ``T_m`` is evaluated by Paterson–Stockmeyer,
    ``T_m = Σ_j (u^p)^j B_j(u)``, ``B_j = Σ_{i<p} u^i/(jp + i)!``, in ``p + q − 2`` products
    (m = pq); no linear solve.
    """
    n = u.shape[0]
    out = np.empty((n, n))
    expm_skew_into(u, out, np.empty((5, n, n)))
    return out


@njit(cache=True)
def expm_skew_into(u, out, work):
    """:func:`expm_skew` written into ``out`` (n, n), with ``work`` (5, n, n) as scratch: no
    allocation."""
    u2 = work[0]
    mm_into(u, u, u2)
    # θ₁ = ‖u‖₂ ≤ min(‖u‖₁, ‖u²‖₁^{1/2}); the second is often several times tighter for large n
    _scaled_taylor_into(u, min(_onenorm(u), np.sqrt(_onenorm(u2))), _THETAS, out, work)


@njit(cache=True)
def expm_se(W, v):
    """``exp`` of the se(n) element ``(W, v)``: ``(exp W, φ₁(W) v)``, ``φ₁(W) = Σ_k W^k/(k+1)!``.

    The exponential of the homogeneous ``X = [[W, v], [0, 0]]`` by the same scaling and
    squaring as :func:`expm_skew`; the degree is chosen on W's bound θ (v enters linearly) with
    the thresholds θ'_m of the translation, whose relative Taylor error ``θ^m/(m+1)!`` is one
    power of θ larger than the rotation's. Returns ``(Q, t)``.
    """
    n = W.shape[0]
    if n == 3:
        return _exp_se3(W, v)
    X = np.zeros((n + 1, n + 1))
    for a in range(n):
        for c in range(n):
            X[a, c] = W[a, c]
        X[a, n] = v[a]
    X2 = mm(X, X)
    S = _scaled_taylor(X, X2, min(_onenorm(W), np.sqrt(_onenorm(X2[:n, :n]))), _THETAS_SE)
    return np.ascontiguousarray(S[:n, :n]), np.ascontiguousarray(S[:n, n])


@njit(cache=True)
def expm_so_se_into(W, v, Q, t):
    """:func:`expm_skew` of W into Q when v has length 0 (so(n)), :func:`expm_se` of ``(W, v)``
    into Q and t otherwise (se(n), n ≠ 3), through one compiled Taylor kernel whose products
    never reach BLAS: the same bits while X (below) is at most 8 × 8, round-off apart above.

    Both are :func:`_scaled_taylor_into` of a matrix X — W itself, or the homogeneous
    ``[[W, v], [0, 0]]`` with the translation's thresholds — so a caller that takes both
    (:func:`lieint.fast.se_algebra.exponential`, whose group is known only at run time)
    compiles the kernel once, not the two wrappers with their own allocations and copies. Its
    products are :func:`lieint.fast.products.mm_unrolled_into` (unrolled up to 8 × 8, where they
    beat both loops and BLAS; loops above), not :func:`mm_into`, whose BLAS fallback for larger
    matrices (numba's product with its checks, and the copies) cost a cold run a second to
    compile."""
    n = W.shape[0]
    m = v.shape[0]
    k = n + 1 if m > 0 else n
    X = np.zeros((k, k))
    for a in range(n):
        for c in range(n):
            X[a, c] = W[a, c]
    for a in range(m):
        X[a, n] = v[a]
    work = np.empty((5, k, k))
    mm_unrolled_into(X, X, work[0])
    # θ₁ ≤ min(‖W‖₁, ‖W²‖₁^{1/2}); W² is the top left block of X² (X's last row is zero)
    norm = min(_onenorm(W), np.sqrt(_onenorm_block(work[0], n)))
    S = np.empty((k, k))
    _scaled_taylor_no_blas_into(X, norm, _THETAS_SE if m > 0 else _THETAS, S, work)
    for a in range(n):
        for c in range(n):
            Q[a, c] = S[a, c]
    for a in range(m):
        t[a] = S[a, n]


@njit(cache=True)
def _onenorm_block(X, n):
    """:func:`_onenorm` of the top left n × n block of X (the same sums in the same order)."""
    best = 0.0
    for j in range(n):
        acc = 0.0
        for i in range(n):
            acc += abs(X[i, j])
        if acc > best:
            best = acc
    return best


@njit(cache=True)
def _exp_se3(W, v):
    """:func:`exp_se3_into` into new arrays ``(Q, t)``."""
    Q = np.empty((3, 3))
    t = np.empty(v.shape[0])
    exp_se3_into(W, v, Q, t)
    return Q, t


@njit(cache=True, **NO_REFCOUNT)
def exp_se3_into(W, v, Q, t):
    """Closed forms on se(3) into Q and t: ``exp W = I + (sin θ/θ) W + ((1 − cos θ)/θ²) W²``
    (Rodrigues) and ``t = φ₁(W) v``, ``φ₁(W) = I + ((1 − cos θ)/θ²) W + ((θ − sin θ)/θ³) W²``,
    with their Taylor series below θ = 1e-3 (next terms below 1e-22); v of length 0 gives the
    rotation alone."""
    t2 = W[2, 1] * W[2, 1] + W[0, 2] * W[0, 2] + W[1, 0] * W[1, 0]
    if t2 < 1e-6:
        a = 1.0 - t2 / 6.0 + t2 * t2 / 120.0
        b = 0.5 - t2 / 24.0 + t2 * t2 / 720.0
        c = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0
    else:
        theta = np.sqrt(t2)
        a = np.sin(theta) / theta
        b = (1.0 - np.cos(theta)) / t2
        c = (theta - np.sin(theta)) / (t2 * theta)
    for i in range(3):
        for j in range(3):
            w2 = W[i, 0] * W[0, j] + W[i, 1] * W[1, j] + W[i, 2] * W[2, j]
            Q[i, j] = (1.0 if i == j else 0.0) + a * W[i, j] + b * w2
    if v.shape[0] == 3:
        wv0 = W[0, 0] * v[0] + W[0, 1] * v[1] + W[0, 2] * v[2]
        wv1 = W[1, 0] * v[0] + W[1, 1] * v[1] + W[1, 2] * v[2]
        wv2 = W[2, 0] * v[0] + W[2, 1] * v[1] + W[2, 2] * v[2]
        t[0] = v[0] + b * wv0 + c * (W[0, 0] * wv0 + W[0, 1] * wv1 + W[0, 2] * wv2)
        t[1] = v[1] + b * wv1 + c * (W[1, 0] * wv0 + W[1, 1] * wv1 + W[1, 2] * wv2)
        t[2] = v[2] + b * wv2 + c * (W[2, 0] * wv0 + W[2, 1] * wv1 + W[2, 2] * wv2)


@njit(cache=True, **NO_REFCOUNT)
def _cayley_se3_into(W, x, Q, t):
    """The Cayley map of se(3) in closed form: with ``w = vee(W)`` and ``s = 1 + |w|²/4``,
    ``cay W = I + (ŵ + ŵ²/2)/s`` and ``M⁻¹x = (x + ŵx/2 + w⟨w, x⟩/4)/s`` — orthogonal to
    round-off at any step, where an elimination on ``I − W/2`` loses ``‖W‖ε``."""
    w0, w1, w2 = W[2, 1], W[0, 2], W[1, 0]
    s = 1.0 + 0.25 * (w0 * w0 + w1 * w1 + w2 * w2)
    for i in range(3):
        for j in range(3):
            w2ij = W[i, 0] * W[0, j] + W[i, 1] * W[1, j] + W[i, 2] * W[2, j]
            Q[i, j] = (1.0 if i == j else 0.0) + (W[i, j] + 0.5 * w2ij) / s
    if x.shape[0] == 3:
        wx = 0.25 * (w0 * x[0] + w1 * x[1] + w2 * x[2])
        t[0] = (x[0] + 0.5 * (W[0, 1] * x[1] + W[0, 2] * x[2]) + w0 * wx) / s
        t[1] = (x[1] + 0.5 * (W[1, 0] * x[0] + W[1, 2] * x[2]) + w1 * wx) / s
        t[2] = (x[2] + 0.5 * (W[2, 0] * x[0] + W[2, 1] * x[1]) + w2 * wx) / s


@njit(cache=True)
def cayley_se_into(W, x, Q, t):
    """:func:`cayley_se_elim_into` with its own work array (closed forms for n = 3)."""
    n = W.shape[0]
    if n == 3:
        _cayley_se3_into(W, x, Q, t)
        return
    cayley_se_elim_into(W, x, Q, t, np.empty((n, 2 * n + 1)))


@njit(cache=True, **NO_REFCOUNT)
def _column_dominant(u):
    """Whether ``I − u/2`` is strictly column diagonally dominant, ``Σ_r |u_rc| < 2`` for every
    column c (u skew: zero diagonal), which also says that u is finite (a NaN or an infinite sum
    fails the test). Elimination keeps the dominance, so partial pivoting would never swap."""
    n = u.shape[0]
    for c in range(n):
        total = 0.0
        for r in range(n):
            total += abs(u[r, c])
        if not total < 2.0:
            return False
    return True


#: a Cayley map further than this off the orthogonal matrices is not trusted: NaN (its stage's
#: u reached θ ~ 1e10, where the solve has lost all but six digits of the map)
OFF_GROUP = 1e-6


@njit(cache=True, **NO_REFCOUNT)
def orthogonal_polish(Q, G, g0, T, t0):
    """Q back onto the orthogonal matrices when the Cayley map's elimination left it off them,
    NaN when it is too far off to be the map at all.

    ``cay(u)`` of a skew u is a rotation, but elimination computes it only to about
    ``ε·cond(I − u/2) = ε(1 + θ₁²/4)^{1/2}``: the stages of a step far beyond its range (which
    the step check warns about) or of a trial step that a loose tolerance lets through reach
    θ ~ 1e17, where the computed map is off the group by O(1) — and the attitude ``R ← RQ`` with
    it. With ``δ = max |QᵀQ − I|``: nothing when ``δ ≤ 8nε``; Newton–Schulz ``Q ← Q(3I − QᵀQ)/2``
    toward the polar factor (quadratic convergence, two steps from δ ≤ :data:`OFF_GROUP`; the
    factor is within δ of the exact map, so a rotation) when ``δ ≤`` :data:`OFF_GROUP`; NaN
    beyond, which the caller reports (a fixed step) or rejects (an adaptive trial step) — a
    polar factor of garbage may even be a reflection. Scratch without allocation:
    ``G[i, g0 + j]`` and ``T[i, t0 + j]``, n × n blocks of the caller's work arrays."""
    n = Q.shape[0]
    tol = 8.0 * n * 2.220446049250313e-16
    for step in range(4):
        worst = 0.0
        for i in range(n):
            for j in range(n):
                s = 0.0
                for k in range(n):
                    s += Q[k, i] * Q[k, j]
                if i == j:
                    s -= 1.0
                G[i, g0 + j] = s
                if abs(s) > worst:
                    worst = abs(s)
        if not worst > tol:  # on the group (or NaN: left to the caller's finiteness check)
            return
        if worst > OFF_GROUP or step == 3:  # not the map any more (or not converging): reported
            for i in range(n):
                for j in range(n):
                    Q[i, j] = np.nan
            return
        for i in range(n):
            for j in range(n):
                s = 0.0
                for k in range(n):
                    s += Q[i, k] * G[k, g0 + j]
                T[i, t0 + j] = s
        for i in range(n):
            for j in range(n):
                Q[i, j] -= 0.5 * T[i, t0 + j]


@njit(cache=True, **NO_REFCOUNT)
def cayley_se_elim_into(W, x, Q, t, aug):
    """The Cayley map of se(n) into Q and t: for ``X = [[W, x], [0, 0]]``,
    ``cay X = (I − X/2)⁻¹(I + X/2) = [[M⁻¹(I + W/2), M⁻¹x], [0, 1]]`` with ``M = I − W/2`` (x of
    length 0: the rotation alone). M is invertible for skew W (its eigenvalues are ``1 ∓ iθ_k/2``)
    and well conditioned (singular values ≥ 1): Gaussian elimination with partial pivoting on
    ``aug``, an ``(n, 2n + 1)`` work array."""
    n = W.shape[0]
    m = x.shape[0]
    for i in range(n):
        for j in range(n):
            aug[i, j] = -0.5 * W[i, j]
            aug[i, n + 1 + j] = 0.5 * W[i, j]
        aug[i, i] += 1.0
        aug[i, n + 1 + i] += 1.0
        aug[i, n] = x[i] if m > 0 else 0.0
    cols = aug.shape[1]
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(aug[r, c]) > abs(aug[p, c]):
                p = r
        if aug[p, c] == 0.0:  # only for a step so large that the elimination cancels: reported
            Q[:, :] = np.nan
            t[:] = np.nan
            return
        if p != c:
            for j in range(cols):
                aug[c, j], aug[p, j] = aug[p, j], aug[c, j]
        for r in range(c + 1, n):
            f = aug[r, c] / aug[c, c]
            if f != 0.0:
                for j in range(c, cols):
                    aug[r, j] -= f * aug[c, j]
    for r in range(n - 1, -1, -1):
        for j in range(n, cols):
            acc = aug[r, j]
            for k in range(r + 1, n):
                acc -= aug[r, k] * aug[k, j]
            aug[r, j] = acc / aug[r, r]
    for i in range(n):
        for j in range(n):
            Q[i, j] = aug[i, n + 1 + j]
        if m > 0:
            t[i] = aug[i, n]
    # a huge W leaves the rotation off SO(n) by ε·cond(M): back onto it, or NaN when it is too far
    # off to be the map (aug's blocks as scratch); a column diagonally dominant M (θ₁ < 2,
    # cond(M) < √2) needs no look
    if not _column_dominant(W):
        orthogonal_polish(Q, aug, 0, aug, n + 1)


@njit(cache=True)
def _scaled_taylor(u, u2, norm, thetas):
    """:func:`_scaled_taylor_into` into a new array (u2 is not modified)."""
    n = u.shape[0]
    out = np.empty((n, n))
    work = np.empty((5, n, n))
    copy_matrix_into(u2, work[0])
    _scaled_taylor_into(u, norm, thetas, out, work)
    return out


@njit(cache=True)
def _scaled_taylor_into(u, norm, thetas, out, work):
    """``exp(u)`` into ``out`` from u, ``u²`` (in ``work[0]``, overwritten) and a bound
    ``norm`` of u's spectral norm: the least Taylor degree m with ``norm ≤ thetas[m]``, scaling
    by ``2⁻ˢ`` above the last, Paterson–Stockmeyer (see :func:`expm_skew`). ``work`` is scratch
    of shape ``(5, n, n)``: no allocation (a stage of a kernel calls this several times)."""
    n = u.shape[0]
    last = _SHAPES.shape[0] - 1
    pick = last
    for i in range(last + 1):
        if norm <= thetas[i]:
            pick = i
            break
    s = 0
    if norm > thetas[last]:
        s = int(np.ceil(np.log2(norm / thetas[last])))
    p, q = _SHAPES[pick, 0], _SHAPES[pick, 1]
    scale = 2.0 ** (-s)  # exact: a power of two
    x2, x, x3, x4, T = work[0], work[1], work[2], work[3], work[4]
    scale2 = scale * scale
    for a in range(n):
        for b in range(n):
            x[a, b] = u[a, b] * scale
            x2[a, b] *= scale2
    if p >= 3:
        mm_into(x2, x, x3)
    if p == 4:
        mm_into(x2, x2, x4)
    top = x2 if p == 2 else (x3 if p == 3 else x4)
    c = _INV_FACTORIAL
    # Horner in x^p: S = c_m x^p + B_{q−1}, then S ← S x^p + B_j for j = q − 2 … 0
    S = out
    cm = c[p * q]
    for a in range(n):
        for b in range(n):
            S[a, b] = cm * top[a, b]
    for j in range(q - 1, -1, -1):
        if j < q - 1:
            mm_into(S, top, T)
            copy_matrix_into(T, S)
        c0, c1, c2 = c[j * p], c[j * p + 1], c[j * p + 2] if p >= 3 else 0.0
        c3 = c[j * p + 3] if p == 4 else 0.0
        for a in range(n):
            S[a, a] += c0
            for b in range(n):
                S[a, b] += c1 * x[a, b]
                if p >= 3:
                    S[a, b] += c2 * x2[a, b]
                if p == 4:
                    S[a, b] += c3 * x3[a, b]
    for _ in range(s):
        mm_into(S, S, T)
        copy_matrix_into(T, S)


@njit(cache=True, **NO_REFCOUNT)
def expm_so4_into(u, Q):
    """``Q = exp(u)`` for a 4 × 4 skew matrix in closed form, by so(4) = su(2) ⊕ su(2).

    The Hodge star splits u into commuting self-dual and anti-self-dual parts ``u± = (u ± ⋆u)/2``
    (``⋆u₀₁ = u₂₃``, ``⋆u₀₂ = u₃₁``, ``⋆u₀₃ = u₁₂``), with ``u±² = −θ±² I``, ``θ±`` the norms of
    their three components: ``exp(u) = (cos θ₊ I + sinc θ₊ u₊)(cos θ₋ I + sinc θ₋ u₋)``, the
    rotation angles of u being ``θ₊ ± θ₋``. Ten times cheaper than the Taylor polynomial of
    :func:`expm_skew_into` at n = 4, to round-off as that one (u finite).
    """
    a1, a2, a3 = 0.5 * (u[0, 1] + u[2, 3]), 0.5 * (u[0, 2] + u[3, 1]), 0.5 * (u[0, 3] + u[1, 2])
    b1, b2, b3 = 0.5 * (u[0, 1] - u[2, 3]), 0.5 * (u[0, 2] - u[3, 1]), 0.5 * (u[0, 3] - u[1, 2])
    ta = math.sqrt(a1 * a1 + a2 * a2 + a3 * a3)
    tb = math.sqrt(b1 * b1 + b2 * b2 + b3 * b3)
    ca, cb = math.cos(ta), math.cos(tb)
    sa = math.sin(ta) / ta if ta > 0.0 else 1.0
    sb = math.sin(tb) / tb if tb > 0.0 else 1.0
    # the factors' off-diagonal parts: S = sinc θ₊ u₊, T = sinc θ₋ u₋ (skew)
    p1, p2, p3 = sa * a1, sa * a2, sa * a3
    q1, q2, q3 = sb * b1, sb * b2, sb * b3
    S = ((0.0, p1, p2, p3), (-p1, 0.0, p3, -p2), (-p2, -p3, 0.0, p1), (-p3, p2, -p1, 0.0))
    T = ((0.0, q1, q2, q3), (-q1, 0.0, -q3, q2), (-q2, q3, 0.0, -q1), (-q3, -q2, q1, 0.0))
    for i in range(4):
        for j in range(4):
            st = S[i][0] * T[0][j] + S[i][1] * T[1][j] + S[i][2] * T[2][j] + S[i][3] * T[3][j]
            Q[i, j] = cb * S[i][j] + ca * T[i][j] + st
        Q[i, i] += ca * cb


@njit(cache=True)
def so_ad_radius_exceeds(u):
    """1 when ``θ₁ + θ₂ ≥ 2π`` for the skew matrix u (the dexp⁻¹ series diverges), 0 when
    not, 2 when u is not finite (not a "too large step": the non-finite state is reported).

    Two sufficient bounds settle the usual cases without a decomposition:
    ``θ₁ + θ₂ ≤ ‖u‖_F`` (``‖u‖_F² = 2 Σ_k θ_k²``) and, one product dearer,
    ``θ₁ + θ₂ ≤ (8(θ₁⁴ + θ₂⁴))^{1/4} ≤ (2‖u²‖_F)^{1/2}`` (``‖u²‖_F² = 2 Σ_k θ_k⁴``; tighter when
    many planes rotate alike, as in a large random u). Only when both fail are the angles
    computed: the eigenvalues of the symmetric ``(u/m)ᵀ(u/m)`` (m = max |u_ij|, against
    overflow) are ``θ_k²/m²``, each twice, so in ascending order ``θ₁ = m √λ_{n−1}`` and
    ``θ₂ = m √λ_{n−3}`` — the generic path's ``s₀ + s₂`` from the singular values.
    """
    n = u.shape[0]
    ss = 0.0
    big = 0.0
    for i in range(n):
        for j in range(n):
            x = u[i, j]
            if not np.isfinite(x):
                return 2
            ss += x * x
            if abs(x) > big:
                big = abs(x)
    if np.sqrt(ss) < _TWO_PI:
        return 0
    # the products by loops, not by ``@``: a test of a bound needs no BLAS, and each ``@``
    # compiled its own dispatch to it (half a second of a cold run's compilation)
    scale = 1.0 / big
    v = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            v[i, j] = u[i, j] * scale
    ss = 0.0
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += v[i, k] * v[k, j]
            ss += acc * acc
    if big * np.sqrt(2.0 * np.sqrt(ss)) < _TWO_PI:
        return 0
    G = np.empty((n, n))  # vᵀv
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += v[k, i] * v[k, j]
            G[i, j] = acc
    lam = np.linalg.eigvalsh(G)
    theta = big * np.sqrt(max(lam[n - 1], 0.0))
    if n >= 3:  # so(2) turns one plane: θ₂ = 0
        theta += big * np.sqrt(max(lam[n - 3], 0.0))
    return 1 if theta >= _TWO_PI else 0


@njit(cache=True)
def _bracket(X, Y):
    """``[X, Y] = XY − YX = W − Wᵀ`` with ``W = XY``, for skew X, Y: one product, exactly skew
    (``W_ac − W_ca = −(W_ca − W_ac)`` in floating point)."""
    W = mm(X, Y)
    n = W.shape[0]
    out = np.empty((n, n))
    for a in range(n):  # rows written in order; the transposed read is the strided one
        for c in range(n):
            out[a, c] = W[a, c] - W[c, a]
    return out


@njit(cache=True, **NO_REFCOUNT)
def _finite(X):
    """Whether every entry of X is finite (``.flat``: ``ravel`` copies a strided array)."""
    for x in X.flat:
        if not np.isfinite(x):
            return False
    return True


@njit(cache=True)
def _exp_or_nan(u):
    """``exp(u)``, or a matrix of NaN when u is not finite (the driver reports the state)."""
    if _finite(u):
        return expm_skew(u)
    out = np.empty_like(u)
    out[:] = np.nan
    return out


@njit(cache=True)
def _project(R):
    """Newton–Schulz toward the polar factor: ``R ← R(3I − RᵀR)/2 = R − R E/2`` with
    ``E = RᵀR − I``, once, then again while ``max |E|`` exceeds 1e-8 (quadratic convergence:
    the last step leaves ~1e-16).

    The iteration maps each singular value σ to σ(3 − σ²)/2 and converges for σ in (0, √3).
    ``max |E_ij| < 2/n`` bounds the spectral radius of E below 2, i.e. σ² < 3; beyond it (a
    coarse classical step) R is first divided by ``‖RᵀR‖₁^{1/2} ≥ σ_max`` — the polar factor of
    cR is that of R — and the iteration runs until it has converged (at most 128 steps: a
    singular value of 1e-18 grows ×1.5 a step).
    """
    n = R.shape[0]
    E, worst = _gram_defect(R)
    if not np.isfinite(worst):
        return R
    if worst >= 2.0 / n:
        G = mm(R.T, R)
        norm1 = 0.0
        for c in range(n):
            col = 0.0
            for r in range(n):
                col += abs(G[r, c])
            norm1 = max(norm1, col)
        if norm1 > 0.0:
            R = R / np.sqrt(norm1)
            E, worst = _gram_defect(R)
    for _ in range(128):
        R = R - 0.5 * mm(R, E)
        if worst <= 1e-8:
            break
        E, worst = _gram_defect(R)
        if not np.isfinite(worst):
            break
    return R


@njit(cache=True)
def _gram_defect(R):
    """``E = RᵀR − I`` and ``max |E_ij|``."""
    n = R.shape[0]
    E = mm(R.T, R)
    for i in range(n):
        E[i, i] -= 1.0
    worst = 0.0
    for x in E.ravel():
        if abs(x) > worst or x != x:
            worst = abs(x)
    return E, worst


#: :func:`_scaled_taylor_into` with the products that never reach BLAS (:func:`mm_unrolled_into`):
#: :func:`expm_so_se_into`'s
_scaled_taylor_no_blas_into = compiled_copies([_scaled_taylor_into], {"mm_into": mm_unrolled_into}, "_no_blas")[
    "_scaled_taylor_into"
]

#: :func:`expm_skew_into` with the unrolled products (:func:`mm_small_into`): the n-dimensional
#: top's kernels take them, every other kernel keeps the loops (which do not dominate those
#: kernels' steps, and compile faster)
expm_skew_small_into = compiled_copies([expm_skew_into, _scaled_taylor_into], {"mm_into": mm_small_into}, "_unrolled")[
    "expm_skew_into"
]
