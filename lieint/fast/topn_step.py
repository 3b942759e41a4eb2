"""One step of the n-dimensional top in its principal frame, compiled (numba, cached on disk):
the stage code of the fixed-step kernel (:mod:`lieint.fast.topn`) and of the adaptive one
(:mod:`lieint.fast.topn_adaptive`).

* :func:`_lie_step`: RKMK from an explicit tableau on ``(Ã, R̃)`` under the right action
  ``Q · (Ã, R̃) = (QᵀÃQ, R̃Q)``, in exponential coordinates (dexp⁻¹ truncated, its range checked)
  or in Cayley coordinates (exact dcay⁻¹, :mod:`lieint.fast.cayley`), allocating nothing;
* :func:`_classical_step`: classical RK on the embedded equations ``Ã' = [Ã, Ω̃]``, ``R̃' = R̃Ω̃``;
* the pieces: the action with the inertia operator ``Ω̃ = M ∘ Ã`` (:func:`_act_into`), a bracket
  of skew matrices in one product, the stages' linear combinations; for 4 ≤ n ≤ 6 the action,
  dcay⁻¹ and the bracket are the unrolled operations of :mod:`lieint.fast.small_skew`, which
  compute only the upper triangle of a skew result and skip the zero diagonal (about half the
  multiply-adds: a 6D RKMK6 step in Cayley coordinates 3.0 → 2.4 µs, 4D 1.7 → 1.2 µs, RKMK4
  in exponential coordinates 4.0 → 3.7 and 2.9 → 2.5 µs, ``benchmarks/kernel_steps.py --only
  "Euler top" --against <the previous checkout>``).

The equations, the frame and the choices behind them are :mod:`lieint.fast.topn`'s docstring.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._jit import NO_REFCOUNT, compiled_copies
from .cayley import cayley_into, dcayinv_into
from .products import copy_matrix_into, mm_small_into, mm_unrolled_into
from .skew import _bracket, _finite, expm_skew_small_into, expm_so4_into, so_ad_radius_exceeds
from .small_skew import bracket_skew_into, congruence_skew_into, dcayinv_skew_into


# inlined into its callers, not called: a product here may fall back on BLAS (which copies),
# so it cannot drop reference counts, and a call would pay them (lieint.fast._jit)
@njit(cache=True, inline="always")
def _act_into(Q, QT, A, M, A1, Om, C, tmp):
    """``(Ã', Ω̃') = (skew(QᵀAQ), Ã' ∘ M)`` into ``A1`` and ``Om``: the action on the momentum,
    made exactly skew as the generic action does (``skew_part``), and the inertia operator
    ``Ω̃_ij = M_ij Ã'_ij`` (M symmetric, so Ω̃' is exactly skew too). ``QT`` is the view
    ``Q.T``, made once by the caller (each view counts a reference: an atomic operation); ``C``
    and ``tmp`` are scratch; A1 may be A (A is read before A1 is written)."""
    mm_small_into(A, Q, tmp)
    mm_small_into(QT, tmp, C)
    n = C.shape[0]
    for a in range(n):
        for c in range(n):
            d = 0.5 * (C[a, c] - C[c, a])
            A1[a, c] = d
            Om[a, c] = d * M[a, c]


# inlined into its callers, not called: a product here may fall back on BLAS (which copies),
# so it cannot drop reference counts, and a call would pay them (lieint.fast._jit)
@njit(cache=True, inline="always")
def _bracket_into(X, Y, out, tmp):
    """``out = [X, Y] = W − Wᵀ`` with ``W = XY`` (tmp), for skew X, Y: one product, exactly
    skew."""
    mm_small_into(X, Y, tmp)
    n = out.shape[0]
    for a in range(n):
        for c in range(n):
            out[a, c] = tmp[a, c] - tmp[c, a]


# inlined into its callers, not called: a product here may fall back on BLAS (which copies),
# so it cannot drop reference counts, and a call would pay them (lieint.fast._jit)
@njit(cache=True, inline="always")
def _exp_into(u, Q, work):
    """``Q = exp(u)``, or NaN when u is not finite (the driver reports the state); in closed form
    at n = 4 (:func:`lieint.fast.skew.expm_so4_into`)."""
    if _finite(u):
        if u.shape[0] == 4:
            expm_so4_into(u, Q)
        else:
            expm_skew_small_into(u, Q, work)
    else:
        Q[:, :] = np.nan


@njit(cache=True, **NO_REFCOUNT)
def _accumulate(out, K, weights, upto, h):
    """``out += Σ_{j < upto} (h w_j) K[j]`` over the nonzero weights, in the order of j (the
    generic path's linear combinations); returns whether any weight was nonzero."""
    n, r = out.shape[0], out.shape[1]
    any_weight = False
    for j in range(upto):
        if weights[j] != 0.0:
            any_weight = True
            w = h * weights[j]
            for a in range(n):
                for c in range(r):
                    out[a, c] += w * K[j, a, c]
    return any_weight


@njit(cache=True, **NO_REFCOUNT)
def _combine(out, K, weights, row, upto, h):
    """``out = Σ_{j < upto} (h w_j) K[j]``, ``w_j = weights[row, j]``, over the nonzero weights,
    in the order of j (the generic path's linear combinations; the first term written, not
    added to zero); returns whether any weight was nonzero (out is left as it was if none). The
    row by index, not as a view: a view counts a reference (an atomic operation) per stage."""
    n, r = out.shape[0], out.shape[1]
    first = True
    for j in range(upto):
        if weights[row, j] != 0.0:
            w = h * weights[row, j]
            if first:
                for a in range(n):
                    for c in range(r):
                        out[a, c] = w * K[j, a, c]
                first = False
            else:
                for a in range(n):
                    for c in range(r):
                        out[a, c] += w * K[j, a, c]
    return not first


@njit(cache=True, **NO_REFCOUNT)
def _store(K, i, X):
    """``K[i] = X``."""
    for a in range(X.shape[0]):
        for c in range(X.shape[1]):
            K[i, a, c] = X[a, c]


# For n ≤ 8, copies of the stage functions whose product never reaches BLAS, compiled without
# reference counts (lieint.fast._jit): with BLAS behind their products the originals may
# allocate, so they count a reference on every array they are given — about 120 atomic
# increments and as many decrements a 6D RKMK6 step, a third of its time on a virtual machine
# (perf: 31 % of the samples in NRT_incref/NRT_decref).
_SMALL = compiled_copies(
    [_act_into, _bracket_into, dcayinv_into], {"mm_small_into": mm_unrolled_into}, "_small", **NO_REFCOUNT
)
_act_small, _bracket_small, _dcayinv_small = _SMALL["_act_into"], _SMALL["_bracket_into"], _SMALL["dcayinv_into"]


@njit(cache=True, **NO_REFCOUNT)
def _without_spin(xi, A):
    """``ξ ← ξ − μA`` with ``μ = ⟨ξ, A⟩/⟨A, A⟩``: the generator without its part along the
    momentum (:meth:`lieint.EulerTop.commuting_generator`; nothing where A is zero)."""
    n2, dot = 0.0, 0.0
    for a in range(A.shape[0]):
        for c in range(A.shape[1]):
            n2 += A[a, c] * A[a, c]
            dot += xi[a, c] * A[a, c]
    if n2 == 0.0:
        return
    mu = dot / n2
    for a in range(A.shape[0]):
        for c in range(A.shape[1]):
            xi[a, c] -= mu * A[a, c]


@njit(cache=True)
def _lie_step(A, R, orient, M, tab, b, h, coeffs, cayley, K, W, E, reduce=False):
    """One RKMK step (right action) of ``(A, R)`` in place, in exponential coordinates (dexp⁻¹
    truncated at ``coeffs``) or in Cayley coordinates (``cayley``: exact dcay⁻¹, no range);
    returns False, leaving A and R as they were, when a stage increment reaches the dexp⁻¹
    radius. With ``reduce``, of the generator without its part along the momentum at each
    stage (:func:`_without_spin`: the energy-keeping pairs, :mod:`lieint.fast.topn_energy`).

    ``K`` (stages, n, n) holds the stage slopes, ``W`` (8, n, n) and ``E`` (5, n, n) are
    scratch (the coordinate map's): a step allocates nothing."""
    s = b.shape[0]
    n = A.shape[0]
    degree = coeffs.shape[0] - 1
    # the views once per step: each counts a reference on W or E (an atomic operation)
    u, Q, C, tmp, acc, term, other, minus_u = W[0], W[1], W[2], W[3], W[4], W[5], W[6], W[7]
    QT, E0, E1 = Q.T, E[0], E[1]
    small = n <= 8  # no BLAS behind the products: the copies without reference counts
    unrolled = 4 <= n <= 6  # the skew operations unrolled (lieint.fast.small_skew's sizes)
    for i in range(s):
        if not _combine(u, K, tab, i, i, h):
            for a in range(n):  # u = 0: ξ = Ω̃(Ã)
                for c in range(n):
                    K[i, a, c] = A[a, c] * M[a, c]
            if reduce:
                _without_spin(K[i], A)
            continue
        if cayley:
            cayley_into(u, Q, E0, E1)
            if unrolled:
                congruence_skew_into(Q, A, M, other, acc)  # acc = Ω̃(QᵀÃQ) = ξ
            elif small:
                _act_small(Q, QT, A, M, other, acc, C, tmp)  # acc = Ω̃(QᵀÃQ) = ξ
            else:
                _act_into(Q, QT, A, M, other, acc, C, tmp)
            if reduce:
                _without_spin(acc, other)  # other = QᵀÃQ, the stage's momentum
            if unrolled:
                dcayinv_skew_into(u, acc, K[i])
            elif small:
                _dcayinv_small(u, acc, K[i], C, tmp)
            else:
                dcayinv_into(u, acc, K[i], C, tmp)
            continue
        if so_ad_radius_exceeds(u) == 1:
            return False
        _exp_into(u, Q, E)
        if unrolled:
            congruence_skew_into(Q, A, M, other, acc)  # acc = Ω̃(QᵀÃQ) = ξ
        elif small:
            _act_small(Q, QT, A, M, other, acc, C, tmp)  # acc = Ω̃(QᵀÃQ) = ξ
        else:
            _act_into(Q, QT, A, M, other, acc, C, tmp)
        if reduce:
            _without_spin(acc, other)  # other = QᵀÃQ, the stage's momentum
        # k = Σ_d (B_d/d!) ad_{−u}^d ξ, the terms by repeated brackets
        for a in range(n):
            for c in range(n):
                term[a, c] = acc[a, c]
                minus_u[a, c] = -u[a, c]
        for d in range(1, degree + 1):
            if unrolled:
                bracket_skew_into(minus_u, term, other)
            elif small:
                _bracket_small(minus_u, term, other, tmp)
            else:
                _bracket_into(minus_u, term, other, tmp)
            term, other = other, term
            if coeffs[d] != 0.0:
                w = coeffs[d]
                for a in range(n):
                    for c in range(n):
                        acc[a, c] += w * term[a, c]
        _store(K, i, acc)
    if not _combine(u, K, b.reshape((1, s)), 0, s, h):
        u[:, :] = 0.0
    if cayley:
        cayley_into(u, Q, E0, E1)
    else:
        _exp_into(u, Q, E)
    if unrolled:
        congruence_skew_into(Q, A, M, A, acc)
    elif small:
        _act_small(Q, QT, A, M, A, acc, C, tmp)
    else:
        _act_into(Q, QT, A, M, A, acc, C, tmp)
    if orient:
        mm_small_into(R, Q, C)
        copy_matrix_into(C, R)
    return True


@njit(cache=True)
def _products_step(A, R, orient, M, weights, bounds, h, K, W, E, inc):
    """One step of a product of exponentials (:class:`lieint.fast.forms.ExpProductForm`) of
    ``(A, R)`` in place: stage i moves Ã by its exponentials one after the other (ξ = M ∘ Ã depends
    on Ã alone), the step moves Ã and R̃ by its own; ``inc`` receives the step's exponents (n²
    entries each). ``K`` (stages, n, n) holds the stage generators, ``W`` (8, n, n) and ``E``
    (5, n, n) are scratch: a step allocates nothing. No dexp⁻¹: never out of range."""
    s = bounds.shape[0] - 2
    n = A.shape[0]
    u, Q, C, tmp, Om, Y = W[0], W[1], W[2], W[3], W[4], W[5]
    QT = Q.T
    small = n <= 8  # no BLAS behind the products: the copies without reference counts
    unrolled = 4 <= n <= 6  # the skew operations unrolled (lieint.fast.small_skew's sizes)
    for i in range(s):
        for a in range(n):
            for c in range(n):
                Y[a, c] = A[a, c]
        for e in range(bounds[i], bounds[i + 1]):
            if not _combine(u, K, weights, e, i, h):
                continue
            _exp_into(u, Q, E)
            if unrolled:
                congruence_skew_into(Q, Y, M, Y, Om)
            elif small:
                _act_small(Q, QT, Y, M, Y, Om, C, tmp)
            else:
                _act_into(Q, QT, Y, M, Y, Om, C, tmp)
        for a in range(n):  # ξ_i = Ω̃(Y_i)
            for c in range(n):
                K[i, a, c] = Y[a, c] * M[a, c]
    first = bounds[s]
    for e in range(first, bounds[s + 1]):
        o = n * n * (e - first)
        if not _combine(u, K, weights, e, s, h):
            for j in range(n * n):
                inc[o + j] = 0.0
            continue
        j = o
        for a in range(n):
            for c in range(n):
                inc[j] = u[a, c]
                j += 1
        _exp_into(u, Q, E)
        if unrolled:
            congruence_skew_into(Q, A, M, A, Om)
        elif small:
            _act_small(Q, QT, A, M, A, Om, C, tmp)
        else:
            _act_into(Q, QT, A, M, A, Om, C, tmp)
        if orient:
            mm_small_into(R, Q, C)
            copy_matrix_into(C, R)


@njit(cache=True)
def _field(A, R, M, orient):
    """The vector field in the principal frame, ``(Ã', R̃') = ([Ã, Ω̃], R̃Ω̃)`` with
    ``Ω̃ = M ∘ Ã`` (the bracket exactly skew); R̃' is R itself without orientation."""
    Om = A * M
    return _bracket(A, Om), (R @ Om if orient else R)


@njit(cache=True)
def _classical_step(A, R, orient, M, tab, b, h, KA, KR):
    """One classical RK step on ``Ã' = [Ã, Ω̃]``, ``R̃' = R̃ Ω̃`` (Ã stays exactly skew)."""
    s = b.shape[0]
    for i in range(s):
        Ai = A.copy()
        _accumulate(Ai, KA, tab[i], i, h)
        Ri = R.copy()
        if orient:
            _accumulate(Ri, KR, tab[i], i, h)
        dA, dR = _field(Ai, Ri, M, orient)
        _store(KA, i, dA)
        if orient:
            _store(KR, i, dR)
    A1 = A.copy()
    _accumulate(A1, KA, b, s, h)
    R1 = R.copy()
    if orient:
        _accumulate(R1, KR, b, s, h)
    return A1, R1
