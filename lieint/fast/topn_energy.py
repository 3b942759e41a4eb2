"""The energy-keeping pairs (:mod:`lieint.methods.energy_projection`) on the Euler top in n ≥ 4
dimensions, compiled (numba, cached on disk): a family of the n-D top's form
(:mod:`lieint.fast.topn`), in exponential and Cayley coordinates — and the 3D top's Cayley
coordinates (its own form, :mod:`lieint.fast.top3`, has exponential coordinates only; the stage
code holds for n = 3).

State of one body: ``(Ã, R̃)`` in the principal frame (the plain form's layout), then the level
H₀ every accepted step ends on — it travels with the state, so a run split into calls keeps the
level of its start. A step, as on the generic path:

* the exact flow of the generator's commuting part ``λÃ``, ``λ = ⟨Ω̃, Ã⟩/⟨Ã, Ã⟩``
  (:meth:`lieint.EulerTop.commuting_generator`): ``R̃ ← R̃ exp(hλÃ)``, Ã stays (the flow
  commutes with A; the generic path's conjugation leaves it to round-off);
* the pair's step of ``Ω̃ − λÃ`` from there (:func:`lieint.fast.topn_step._lie_step` with
  ``reduce``: λ of each stage's momentum);
* the move along the orbit onto H₀, ``(Ã, R̃) ← (exp(sη)ᵀ Ã exp(sη), R̃ exp(sη))``, with the
  steepest ascent of ``H = −¼ Σ M_ij Ã_ij²`` within the orbit, ``η = [Ã, Ω̃]`` (the generic
  path's central differences over the basis ``E_kj − E_jk`` give ``∂H = [Ω̃, Ã]_jk``, whose
  combination is ``[Ã, Ω̃]``, and ``dH/ds = ½‖[Ω̃, Ã]‖_F²``; conjugation by the principal frame
  keeps both), s by one Newton step and secant steps — the generic path's band, limits and
  acceptance (:meth:`lieint.methods.energy_projection.EnergyProjected.onto_level`).

The error estimate is the pair's own: its embedded solution from the state after the spin's
flow, moved by the same amount as the step.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .products import copy_matrix_into, mm_small_into
from .topn import _M, _dims, _embedded, _parts, form_scratch
from .topn import NAMESPACES as PLAIN
from .topn_step import _exp_into, _lie_step

__all__ = ["NAMESPACES"]

#: :data:`lieint.methods.energy_projection.LEVEL_ULPS` · ε (the generic path's level band)
_LEVEL = 64 * 2.220446049250313e-16
#: the largest orbit move accepted and the secant iterations (the generic path's)
_MAX_MOVE = 1e-3
_ITERATIONS = 4


@njit(cache=True)
def form_energy_scratch(fx, meth, par, d):
    """The plain form's arrays, then the state after the spin's flow and the move onto the level
    (``d − 1`` each: the fields), and five n × n matrices for η, the move's exponential and the
    conjugation."""
    n = _dims(par)[0]
    f = d - 1
    return form_scratch(fx, meth, par, d) + (np.zeros(f), np.zeros(f), np.zeros((5, n, n)))


@njit(cache=True)
def _energy(A, M):
    """``H = ¼ tr(Ω̃Ã) = −¼ Σ M_ij Ã_ij²``."""
    total = 0.0
    for a in range(A.shape[0]):
        for c in range(A.shape[1]):
            total += M[a, c] * A[a, c] * A[a, c]
    return -0.25 * total


@njit(cache=True)
def _conjugate(A, Q, out, tmp):
    """``out = skew(QᵀAQ)`` (the generic action's, made exactly skew)."""
    mm_small_into(A, Q, tmp)
    mm_small_into(Q.T, tmp, out)
    n = out.shape[0]
    for a in range(n):
        for c in range(a, n):
            x = 0.5 * (out[a, c] - out[c, a])
            out[a, c] = x
            out[c, a] = -x


@njit(cache=True)
def _turned_energy(A, M, eta, s, V, E):
    """H of ``exp(sη)ᵀ Ã exp(sη)``; ``V[1]`` receives ``exp(sη)``, ``V[2]`` the momentum."""
    u, Q, B, tmp = V[4], V[1], V[2], V[3]
    n = A.shape[0]
    for a in range(n):
        for c in range(n):
            u[a, c] = s * eta[a, c]
    _exp_into(u, Q, E)
    _conjugate(A, Q, B, tmp)
    return _energy(B, M)


@njit(cache=True)
def _onto_level(A, R, orient, M, level0, V, E):
    """Move ``(Ã, R̃)`` along the orbit onto ``H = level0`` in place (see the module docstring);
    ``V`` (5, n, n) and ``E`` (the exponential's) are scratch."""
    f0 = _energy(A, M) - level0
    band = _LEVEL * abs(level0)
    if not (np.isfinite(f0) and abs(f0) > band):
        return
    n = A.shape[0]
    eta, Om, tmp = V[0], V[1], V[3]
    for a in range(n):
        for c in range(n):
            Om[a, c] = M[a, c] * A[a, c]
    mm_small_into(A, Om, tmp)  # η = [Ã, Ω̃] = ÃΩ̃ − (ÃΩ̃)ᵀ
    slope0 = 0.0
    for a in range(n):
        for c in range(n):
            eta[a, c] = tmp[a, c] - tmp[c, a]
    for a in range(n):
        for c in range(a + 1, n):
            slope0 += eta[a, c] * eta[a, c]
    if not slope0 > 0.0:
        return
    s_prev, f_prev = 0.0, f0
    s = -f0 / slope0
    f = _turned_energy(A, M, eta, s, V, E) - level0
    for _ in range(_ITERATIONS - 1):
        if not (abs(f) > band and f != f_prev):
            break
        step = f * (s - s_prev) / (f - f_prev)
        s_prev, f_prev, s = s, f, s - step
        f = _turned_energy(A, M, eta, s, V, E) - level0
    size = abs(s) * np.sqrt(slope0)
    if not (np.isfinite(s) and np.isfinite(f) and size <= _MAX_MOVE):
        return
    if not (abs(f) <= band or abs(f) <= 1e-2 * abs(f0)):
        return
    _turned_energy(A, M, eta, s, V, E)
    Q, B = V[1], V[2]
    copy_matrix_into(B, A)
    if orient:
        mm_small_into(R, Q, tmp)
        copy_matrix_into(tmp, R)


@njit(cache=True)
def form_energy_step(fx, y, par, meth, h, y1, inc, aux, scr):
    """One step of an energy-keeping pair (the module docstring); ``inc`` = the pair's
    increment, ``aux[0] = −1`` (the first stage evaluates the reduced generator)."""
    n, r = _dims(par)
    K, W, E = scr[0], scr[2], scr[3]
    turned, moved, V = scr[5], scr[6], scr[7]
    f = y.shape[0] - 1
    M = _M(par, n)
    for i in range(f):
        turned[i] = y[i]
    A, R = _parts(turned, n, r)
    if r > 0:  # the spin's exact flow: R̃ ← R̃ exp(hλÃ), λ = ⟨Ω̃, Ã⟩/⟨Ã, Ã⟩
        n2, dot = 0.0, 0.0
        for a in range(n):
            for c in range(n):
                n2 += A[a, c] * A[a, c]
                dot += M[a, c] * A[a, c] * A[a, c]
        lam = dot / n2 if n2 > 0.0 else 0.0
        u, Q, tmp = V[4], V[1], V[3]
        for a in range(n):
            for c in range(n):
                u[a, c] = h * lam * A[a, c]
        _exp_into(u, Q, E)
        mm_small_into(R, Q, tmp)
        copy_matrix_into(tmp, R)
    for i in range(f):
        y1[i] = turned[i]
    y1[f] = y[f]
    A1, R1 = _parts(y1, n, r)
    if not _lie_step(A1, R1, r > 0, M, meth.A, meth.b, h, meth.coeffs, meth.cayley, K, W, E, True):
        return -1
    u = W[0]
    j = 0
    for a in range(n):
        for c in range(n):
            inc[j] = u[a, c]
            j += 1
    for i in range(f):
        moved[i] = y1[i]
    _onto_level(A1, R1, r > 0, M, y[f], V, E)
    for i in range(f):
        moved[i] = y1[i] - moved[i]
    aux[0] = -1.0
    return meth.b.shape[0]


@njit(cache=True)
def form_energy_embedded(fx, y, par, meth, weights, h, yh, scr):
    """The pair's embedded solution from the state after the spin's flow, plus the move onto the
    level: ``y₁ − ŷ`` is then the pair's own difference, as the generic path's estimate."""
    n, r = _dims(par)
    turned, moved = scr[5], scr[6]
    f = y.shape[0] - 1
    A0, R0 = _parts(turned, n, r)
    Ah, Rh = _parts(yh, n, r)
    _embedded(A0, R0, r > 0, _M(par, n), scr[0], weights, h, meth.cayley, scr[2], scr[3], Ah, Rh)
    for i in range(f):
        yh[i] += moved[i]
    yh[f] = y[f]


#: the names of :mod:`lieint.fast.loop` this family binds (the rest is the plain form's)
NAMESPACES = {
    "rkmk_energy": {
        **PLAIN["rkmk"],
        "scratch": form_energy_scratch,
        "step": form_energy_step,
        "embedded": form_energy_embedded,
    }
}
