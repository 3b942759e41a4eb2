"""The Moser–Veselov map of the n-dimensional top (n ≥ 4) as a form of the one compiled loop.

``moser_veselov`` and its compositions ``moser_veselov_composed4/6`` on the n-D top: each
substep solves ``h Ã = B Kᵀ − K B`` for ``K = cay(X) − I = (I − X/2)⁻¹ X`` by Newton's method
on the Cayley parameter ``X ∈ so(n)`` with the exact Jacobian in bivector coordinates (a
``d × d`` system, ``d = n(n − 1)/2``), from ``X₀ = hΩ̃`` — the numpy path's iteration
(:func:`lieint.methods.moser_veselov.solve_generator`) with the same stopping rule and the same
check of the residual — and applies the step from K without forming ω:
``Ã₁ = Ã + skew(P − Pᵀ + KᵀP)``, ``P = ÃK``, ``R̃₁ = R̃ + R̃K``. In the principal frame B is
``diag(b)``, so the Jacobian's column of ``e_i ∧ e_j`` is read off two rank-one terms
``½(W e_i (2I + K)_j − W e_j (2I + K)_i)``, ``W = (I − X/2)⁻¹``.

A step's increment is the Cayley coordinates of its ω (``X`` of a single map,
``2(ω − I)(ω + I)⁻¹`` of a composition's product), converted when dense output asks.
Everything else is the n-D top's (:mod:`lieint.fast.topn`).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .products import copy_matrix_into
from .topn import (
    _dims,
    _parts,
    form_embedded,
    form_error_sum,
    form_prepare,
    form_project,
    form_radius2,
    form_user_field,
)

__all__ = ["NAMESPACES", "MoserVeselovNumbersN", "numbers"]

#: the substeps' fractions of h, the principal eigenvalues b of the mass tensor, and ``cayley``
#: (the increments are Cayley coordinates: dense output converts them)
MoserVeselovNumbersN = namedtuple("MoserVeselovNumbersN", "substeps b cayley")

#: Newton updates before a step is declared unsolvable (the numpy path's limit)
MAX_NEWTON = 40
_EPS = np.finfo(float).eps
_TINY = np.finfo(float).tiny


def numbers(form, layout) -> MoserVeselovNumbersN:
    """The numbers of a Moser–Veselov :class:`~lieint.fast.forms.MapForm` for the n-D top of
    ``layout`` (the eigenvalues of its mass tensor, the principal frame's diagonal B)."""
    if form.degree:
        raise ValueError("the modified Moser–Veselov moments are defined for the 3D top only")
    return MoserVeselovNumbersN(np.array(form.substeps, dtype=float), np.array(layout.b, dtype=float), True)


@njit(cache=True)
def form_scratch(fx, meth, par, d):
    """The product of a composition's substeps ``ω − I`` and a product's temporary (n, n)."""
    n, _ = _dims(par)
    return np.zeros((n, n)), np.zeros((n, n))


@njit(cache=True)
def _solve(A, b, h):
    """``K = cay(X) − I`` solving ``h A = B Kᵀ − K B`` (B = diag(b)), the Cayley parameter X and
    the Newton iterations spent, or 0 of them when Newton's method does not reach round-off (the
    numpy path's rule)."""
    n = A.shape[0]
    d = n * (n - 1) // 2
    eye = np.eye(n)
    # X₀ = hΩ, Ω_ij = −A_ij/(b_i + b_j)
    X = np.empty((n, n))
    scale = _TINY
    bmax = 0.0
    for i in range(n):
        bmax = max(bmax, abs(b[i]))
        for j in range(n):
            X[i, j] = -h * A[i, j] / (b[i] + b[j]) if i != j else 0.0
            scale = max(scale, abs(h * A[i, j]))
    F = np.empty(d)
    J = np.empty((d, d))
    last = np.inf
    spent = 0
    for _ in range(MAX_NEWTON):
        spent += 1
        try:
            W = np.linalg.inv(eye - 0.5 * X)
        except Exception:  # I − X/2 singular to round-off: X diverged (a too long step)
            return X, X, 0
        K = W @ X
        G = 2.0 * eye + K
        p = 0
        for r in range(n):
            for c in range(r + 1, n):
                F[p] = b[r] * K[c, r] - K[r, c] * b[c] - h * A[r, c]
                p += 1
        k = 0
        for i in range(n):
            for j in range(i + 1, n):
                # dω = ½ (W[:, i] G[j, :] − W[:, j] G[i, :]); dF = B dωᵀ − dω B
                p = 0
                for r in range(n):
                    for c in range(r + 1, n):
                        w_cr = 0.5 * (W[c, i] * G[j, r] - W[c, j] * G[i, r])
                        w_rc = 0.5 * (W[r, i] * G[j, c] - W[r, j] * G[i, c])
                        J[p, k] = b[r] * w_cr - w_rc * b[c]
                        p += 1
                k += 1
        try:
            delta = np.linalg.solve(J, -F)
        except Exception:  # a singular Jacobian (Newton diverging at a too long step)
            return X, X, 0
        size = 0.0
        k = 0
        for i in range(n):
            for j in range(i + 1, n):
                X[i, j] += delta[k]
                X[j, i] -= delta[k]
                size = max(size, abs(delta[k]))
                k += 1
        if not np.isfinite(size):
            return X, X, 0
        xsize = max(np.max(np.abs(X)), _TINY)
        # converged: the update is round-off, or it stopped shrinking near round-off
        if size <= 4.0 * _EPS * xsize or (size >= last and size <= 1e-10 * xsize):
            break
        last = size
    try:
        K = np.linalg.inv(eye - 0.5 * X) @ X
    except Exception:
        return X, X, 0
    residual = 0.0
    for r in range(n):
        for c in range(n):
            residual = max(residual, abs(b[r] * K[c, r] - K[r, c] * b[c] - h * A[r, c]))
    return K, X, spent if residual <= 1e3 * _EPS * max(scale, bmax) else 0


@njit(cache=True)
def form_mv_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One step (every substep a Moser–Veselov solve and its action) of one body in the
    principal frame; ``inc`` = the Cayley coordinates of the step's ω, ``aux[0] = −1`` (the loop
    evaluates the bound). Returns the Newton iterations spent (what the numpy path counts as its
    evaluations), or −1 when a solve did not reach round-off."""
    n, r = _dims(par)
    for i in range(y.shape[0]):
        y1[i] = y[i]
    A, R = _parts(y1, n, r)
    total, tmp = scr[0], scr[1]
    total[:, :] = 0.0
    X = np.zeros((n, n))
    subs = meth.substeps.shape[0]
    spent = 0
    for sub in range(subs):
        K, X, iterations = _solve(A, meth.b, h * meth.substeps[sub])
        if iterations == 0:
            return -1
        spent += iterations
        # Ã₁ = Ã + skew(P − Pᵀ + KᵀP), P = ÃK; R̃₁ = R̃ + R̃K
        P = A @ K
        C = P - P.T + K.T @ P
        for a in range(n):
            for c in range(n):
                tmp[a, c] = 0.5 * (C[a, c] - C[c, a])
        for a in range(n):
            for c in range(n):
                A[a, c] += tmp[a, c]
        if r > 0:
            copy_matrix_into(R + R @ K, R)
        if subs > 1:  # (I + T)(I + K) = I + (T + K + TK)
            copy_matrix_into(total @ K, tmp)
            for a in range(n):
                for c in range(n):
                    total[a, c] += K[a, c] + tmp[a, c]
    if subs > 1:  # X = 2 T (2I + T)⁻¹: the Cayley coordinates of I + T
        X = 2.0 * total @ np.linalg.inv(2.0 * np.eye(n) + total)
    j = 0
    for a in range(n):
        for c in range(n):
            inc[j] = X[a, c]
            j += 1
    return spent


#: the names of :mod:`lieint.fast.loop` this form binds (fixed steps only)
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
