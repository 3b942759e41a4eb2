"""The compiled kernel for the Euler top of any dimension n ≥ 4 (numba, cached on disk).

The generic path moves dicts of batched matrices through Python for every stage, and for the
n-dimensional top (MATH.md §2) each stage is a handful of n×n products: for small n the step
is Python overhead, not arithmetic. This module runs the whole fixed-step loop in machine code
(the 3D top keeps its own kernel, :mod:`lieint.fast.top3`); one step, shared with the adaptive
kernel, is :mod:`lieint.fast.topn_step`:

* the state is ``(Ã, R̃) = (PᵀAP, RP)`` in the principal frame of ``B = P diag(b) Pᵀ`` (P a
  proper eigenbasis), where the inertia operator is the entrywise product
  ``Ω̃_ij = −Ã_ij / (b_i + b_j)`` and the equations keep their form, ``Ã' = [Ã, Ω̃]``,
  ``R̃' = R̃ Ω̃`` (conjugation by P is an automorphism of so(n));
* RKMK from any explicit tableau of the right action ``Q · (Ã, R̃) = (QᵀÃQ, R̃Q)``, with
  exponential coordinates and dexp⁻¹ truncated at the method's degree::

      u_i = h Σ_j a_ij k_j,   k_i = Σ_{d ≤ degree} (B_d / d!) ad_{−u_i}^d Ω̃(exp(u_i)ᵀ Ã exp(u_i)),
      (Ã, R̃) ← (QᵀÃQ, R̃Q),  Q = exp(h Σ_j b_j k_j),

  or with Cayley coordinates, ``k_i = dcay⁻¹_{−u_i}(ξ_i) = ξ_i + ½[u_i, ξ_i] − ¼ u_i ξ_i u_i``
  (exact: two products, no range limit) and ``cay(u) = (I − u/2)⁻¹(I + u/2)`` by elimination,
  or classical RK on the embedded equations ``Ã' = [Ã, Ω̃]``, ``R̃' = R̃Ω̃``;
* ``exp`` of a skew matrix (:mod:`lieint.fast.skew`) by scaling and squaring with a Taylor
  polynomial of degree 4, 6, 9, 12 or 16 chosen so that the truncation error is below the unit
  round-off (:data:`lieint.fast.skew.expm_skew_small_into`): only matrix products, no linear solve —
  numba's ``np.linalg.solve`` alone would add about 5 s to the one-time compilation;
* the stage slopes and the scratch of the exponential, the action and the brackets are held
  per body for the whole run, and the products are written into them, unrolled up to n = 8
  (:func:`lieint.fast.products.mm_small_into`; BLAS above, where the arithmetic outweighs a call);
* brackets of skew matrices cost one product, ``[X, Y] = XY − (XY)ᵀ``; for 4 ≤ n ≤ 6 the
  stage's skew operations are unrolled and compute only upper triangles
  (:mod:`lieint.fast.small_skew`);
* the dexp⁻¹ series converges only while the spectral radius of ``ad_u`` on so(n),
  ``θ₁ + θ₂`` (the two largest rotation angles of u), is below 2π; the Frobenius norm settles
  the usual case (``‖u‖_F² = 2 Σ θ_k² ≥ (θ₁ + θ₂)²``), then ``(2‖u²‖_F)^{1/2}``, and only when
  both fail are the angles computed, from the eigenvalues ``θ_k²`` (each twice) of the
  symmetric ``−u² = uᵀu`` (:func:`so_ad_radius_exceeds`). Those give θ₂ to about
  ``√ε·θ₁`` when θ₂ is near 0 (the generic path's singular values give it to ``ε·θ₁``), so
  the two paths may decide differently on a step within about 1e-8 (relative) of the limit;
  every other step is accepted or refused alike;
* the projection (``project=True``) is Newton–Schulz ``R̃ ← R̃(3I − R̃ᵀR̃)/2`` toward the polar
  factor, repeated while ``‖R̃ᵀR̃ − I‖_max`` exceeds 1e-8; from farther than the region where
  it converges (a coarse classical step) R̃ is first scaled by ``‖R̃ᵀR̃‖₁^{-1/2}`` (same polar
  factor, at most 128 steps); Ã stays exactly skew;
* bodies of an ensemble run in parallel Python threads, each over a contiguous range of
  bodies (the compiled loop releases the GIL: no ``prange`` region to compile a second time);
  a single body, or fewer bodies than threads, runs serially in the calling thread
  (:func:`lieint.fast.use_threads`).

The compiled entry point :func:`_run_bodies` has one type signature (float64 arrays, int64,
bool) whatever the method, n, orientation and options, so numba compiles it once per
installation (cached on disk).
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache

import numpy as np
from numba import njit

from . import _dexpinv_coefficients, _proper_frame, range_error, use_threads
from ._jit import NO_REFCOUNT
from .principal import to_principal, to_user
from .skew import _project, expm_skew, so_ad_radius_exceeds
from .topn_step import _classical_step, _lie_step, _store

__all__ = ["TopNKernel", "expm_skew", "inertia_factors", "integrate_topn", "so_ad_radius_exceeds"]


@njit(cache=True, **NO_REFCOUNT)
def _load(X, stack, m):
    """``X = stack[m]``."""
    for a in range(X.shape[0]):
        for c in range(X.shape[1]):
            X[a, c] = stack[m, a, c]


@njit(cache=True, **NO_REFCOUNT)
def _save(out, slot, m, X):
    """``out[slot, m] = X``."""
    for a in range(X.shape[0]):
        for c in range(X.shape[1]):
            out[slot, m, a, c] = X[a, c]


@njit(cache=True, **NO_REFCOUNT)
def _generator_norm2(A, M):
    """``‖Ω̃‖_F²`` of ``Ω̃ = M ∘ Ã`` (an upper bound of ``(θ₁ + θ₂)²``, the squared ad spectral
    radius of Ω̃, which the step check compares with π/h)."""
    total = 0.0
    for a in range(A.shape[0]):
        for c in range(A.shape[1]):
            x = A[a, c] * M[a, c]
            total += x * x
    return total


@njit(cache=True, nogil=True)
def _run_bodies(
    lo, hi, A0, R0, orient, M, tab, b, coeffs, lie, cayley, h, h_last, k_from, k_to, nsteps, save_steps, project,
    out_A, out_R, fin_A, fin_R, status, norm2,
):  # fmt: skip
    """Steps ``k_from < k ≤ k_to`` of the bodies ``lo ≤ m < hi`` on the global grid (the last
    global step has size ``h_last``); states after the steps in ``save_steps`` go to
    ``out_*``, the states after ``k_to`` to ``fin_*``; ``status[m]`` is -1, or the step at which
    a stage of body m left the dexp⁻¹ radius (that body stops there); ``norm2[m]`` the largest
    ``‖Ω̃‖_F²`` of body m over its starting state and its saved rows (the step check's bound).
    Releases the GIL, so that threads can run disjoint ranges of bodies."""
    s = b.shape[0]
    n = A0.shape[1]
    r = R0.shape[1]
    K = np.zeros((s, n, n))
    KR = np.zeros((s, r, r))
    W = np.zeros((8, n, n))
    E = np.zeros((5, n, n))
    for m in range(lo, hi):
        A = np.empty((n, n))
        R = np.empty((r, r))
        _load(A, A0, m)
        _load(R, R0, m)
        slot = 0
        status[m] = -1
        norm2[m] = _generator_norm2(A, M)
        for k in range(k_from, k_to):
            hk = h if k < nsteps - 1 else h_last
            if lie:
                if not _lie_step(A, R, orient, M, tab, b, hk, coeffs, cayley, K, W, E):
                    status[m] = k
                    break
            else:
                A, R = _classical_step(A, R, orient, M, tab, b, hk, K, KR)
            if project and orient:
                R = _project(R)
            if slot < save_steps.shape[0] and save_steps[slot] == k + 1:
                _save(out_A, slot, m, A)
                _save(out_R, slot, m, R)
                norm2[m] = max(norm2[m], _generator_norm2(A, M))
                slot += 1
        _store(fin_A, m, A)
        _store(fin_R, m, R)


def inertia_factors(b_principal) -> np.ndarray:
    """``M_ij = −1/(b_i + b_j)``: the inertia operator in the principal frame is the entrywise
    product ``Ω̃ = M ∘ Ã`` (the diagonal, zero in a bivector, is set to −1)."""
    b = np.asarray(b_principal, dtype=float)
    pair = b[:, None] + b[None, :]
    np.fill_diagonal(pair, 1.0)  # the diagonal of a bivector is zero anyway
    return -1.0 / pair


@lru_cache(maxsize=32)
def _inertia_factors_of(data: bytes) -> np.ndarray:
    """:func:`inertia_factors` of the eigenvalues in ``data``, worked out once per top (a
    single call's set-up is tens of microseconds); writable, as the compiled loops take it,
    and never written."""
    return inertia_factors(np.frombuffer(data))


def integrate_topn(
    A0,
    R0,
    b_principal,
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
    threads: int = 1,
    cayley: bool = False,
    inertia: np.ndarray | None = None,
    start_row: bool = False,
    norm2: np.ndarray | None = None,
):
    """Run the compiled loop over steps ``k_from < k ≤ k_to`` (bodies in ``threads`` threads).

    Parameters
    ----------
    A0 : ndarray, shape (N, n, n)
        Body momenta ``Ã = PᵀAP`` in the principal frame (exactly skew).
    R0 : ndarray, shape (N, n, n) or (N, 0, 0)
        Orientations ``R̃ = RP``; empty trailing shape: the top carries no orientation.
    b_principal : ndarray, shape (n,)
        Eigenvalues b of the mass tensor (``Ω̃_ij = −Ã_ij / (b_i + b_j)``).
    tableau_A, tableau_b : ndarray
        The explicit Butcher tableau.
    coeffs : sequence of float
        ``B_d / d!`` for ``d ≤`` the dexp⁻¹ degree (RKMK); ignored for classical RK.
    lie : bool
        RKMK (True) or classical RK on the embedded equations (False).
    h, h_last : float
        The grid step and the size of the grid's last step.
    k_from, k_to, nsteps : int
        The steps to take, on a grid of ``nsteps`` steps.
    save_steps : array_like of int
        Global step numbers after which the state is saved (ascending, in ``(k_from, k_to]``).
    project : bool
        Newton–Schulz projection of R̃ after each step.
    threads : int
        Python threads, each running the compiled loop (which releases the GIL) over a
        contiguous range of bodies; 1 runs them all in the calling thread.
    cayley : bool
        RKMK in Cayley coordinates (exact dcay⁻¹; ``coeffs`` unused).
    inertia : ndarray, optional
        ``inertia_factors(b_principal)`` when the caller holds it already.
    start_row : bool
        Save the starting state as a first row (``m + 1`` rows), where the loop saves: a whole
        run's rows then need no concatenation.
    norm2 : ndarray, shape (N,), optional
        Filled with each body's largest ``‖M ∘ Ã‖_F²`` over its starting state and saved rows
        (the step check's bound, :meth:`TopNKernel.generator_radius`).

    Returns
    -------
    out_A, out_R : ndarray
        The saved states, shapes ``(m, N, n, n)`` (``out_R``: ``(m, N, 0, 0)`` without
        orientation).
    fin_A, fin_R : ndarray
        The states after ``k_to``.
    bad : int
        The first step at which a stage left the dexp⁻¹ radius (-1: none); the run stops there.
    """
    save_steps = np.asarray(save_steps, dtype=np.int64)
    A0 = np.ascontiguousarray(A0, dtype=float)
    R0 = np.ascontiguousarray(R0, dtype=float)
    N, n = A0.shape[0], A0.shape[1]
    r = R0.shape[1]
    m, s = save_steps.size, int(bool(start_row))
    out_A, out_R = np.empty((m + s, N, n, n)), np.empty((m + s, N, r, r))
    if s:
        out_A[0], out_R[0] = A0, R0
    fin_A, fin_R = np.empty((N, n, n)), np.empty((N, r, r))
    M = inertia_factors(b_principal) if inertia is None else inertia
    status = np.empty(N, dtype=np.int64)
    norm2 = np.empty(N) if norm2 is None else norm2
    args = (
        A0,
        R0,
        r > 0,
        M,
        np.ascontiguousarray(tableau_A, dtype=float),
        np.ascontiguousarray(tableau_b, dtype=float),
        np.asarray(coeffs, dtype=float),
        bool(lie),
        bool(cayley),
        float(h),
        float(h_last),
        int(k_from),
        int(k_to),
        int(nsteps),
        save_steps,
        bool(project),
        out_A[s:],  # C-contiguous views
        out_R[s:],
        fin_A,
        fin_R,
        status,
        norm2,
    )
    threads = min(int(threads), N)
    if threads > 1:
        # contiguous ranges of bodies, one per thread; the kernel releases the GIL
        cuts = np.linspace(0, N, threads + 1).astype(np.int64)
        with ThreadPoolExecutor(threads) as pool:
            for job in [pool.submit(_run_bodies, cuts[i], cuts[i + 1], *args) for i in range(threads)]:
                job.result()
    else:
        _run_bodies(0, N, *args)
    bad = status[status >= 0]
    return out_A, out_R, fin_A, fin_R, int(bad.min()) if bad.size else -1


class TopNKernel:
    """The compiled n-dimensional top kernel (n ≥ 4) with its own state representation
    ``(Ã, R̃) = (PᵀAP, RP)`` in the principal frame (P a proper eigenbasis of B), so that a run
    split into segments gives the same bits as one that is not: the conversion to ``(A, R)``
    happens only on output.

    Parameters
    ----------
    sys_decl : dict
        ``{"kind": "topn", "b": eigenvalues of B, "P": eigenbasis, "orientation": bool}``.
    meth_decl : dict
        ``{"kind": "rkmk" | "rk", "A", "b", "c"[, "dexpinv_degree"]}``.
    y : dict
        The initial state (unused: the layout does not depend on it).
    batch : tuple of int
        The batch shape of the run.
    """

    def __init__(self, sys_decl: dict, meth_decl: dict, y, batch: tuple[int, ...]):
        self.b = np.asarray(sys_decl["b"], dtype=float)
        self.n = self.b.size
        self.orientation = bool(sys_decl["orientation"])
        # a proper frame keeps R̃ = RP a rotation; a diagonal B needs no change of frame (P = I):
        # the conversions are skipped, not rounded (both worked out once per frame)
        P, self.identity_frame = _proper_frame(sys_decl["P"])
        self.P = np.array(P)  # writable: the compiled loops' signatures take mutable arrays
        self.method = meth_decl
        self.lie = meth_decl["kind"] == "rkmk"
        self.cayley = self.lie and meth_decl.get("coordinates") == "cayley"
        self.stages = int(np.asarray(meth_decl["b"]).size)
        # writable, as the compiled signature has it
        degree = meth_decl["dexpinv_degree"] if self.lie and not self.cayley else 0
        self.coeffs = np.array(_dexpinv_coefficients(degree))
        self.M = _inertia_factors_of(self.b.tobytes())  # Ω̃ = M ∘ Ã: the kernel's and the step check's
        self.batch = batch
        bodies = int(np.prod(batch)) if batch else 1
        self.parallel, self.threads = use_threads(bodies)
        # the largest ‖Ω̃‖_F over the states of this run (from start, kept by advance); none yet
        self._radius_bound = math.inf

    def describe(self) -> str:
        """Which kernel runs."""
        threads = f"{self.threads} threads" if self.parallel else "serial"
        kind = ("RKMK (Cayley)" if self.cayley else "RKMK") if self.lie else "classical RK"
        return f"compiled {self.n}D-top kernel, {kind}, per body, {threads}"

    def start(self, y: dict) -> dict:
        n = self.n
        A = y["A"].reshape(-1, n, n)
        R = y["R"].reshape(-1, n, n) if self.orientation else None
        if self.identity_frame:
            A = 0.5 * (A - np.swapaxes(A, -1, -2))  # exactly skew (the identity on a skew A)
        else:
            A, R = to_principal(A, R, self.P)  # skew(PᵀAP), RP (compiled: microseconds saved)
        self._radius_bound = 0.0
        internal = {"A": np.ascontiguousarray(A, dtype=float)}
        if self.orientation:
            internal["R"] = np.ascontiguousarray(R, dtype=float)
        return internal

    def advance(self, internal: dict, k_from: int, k_to: int, plan, save_steps, project: bool, with_start=False):
        tab = self.method
        A = internal["A"]
        # without orientation the kernel steps an empty R (one type signature for both cases)
        R = internal["R"] if self.orientation else np.empty((A.shape[0], 0, 0))
        norm2 = np.empty(A.shape[0])
        out_A, out_R, fin_A, fin_R, bad = integrate_topn(
            A,
            R,
            self.b,
            tab["A"],
            tab["b"],
            self.coeffs,
            self.lie,
            plan.h,
            plan.last_step,
            k_from,
            k_to,
            plan.nsteps,
            save_steps,
            project,
            self.threads,
            self.cayley,
            self.M,
            with_start,
            norm2,
        )
        # the step check's bound over every state this run has saved (or started a segment from);
        # a non-finite state makes it infinite (the check then looks at the rows themselves)
        largest = float(np.sqrt(np.maximum.reduce(norm2, initial=0.0)))
        self._radius_bound = max(self._radius_bound, largest) if math.isfinite(largest) else math.inf
        if bad >= 0:
            raise range_error(bad, plan, f"so({self.n})")
        new = {"A": fin_A, "R": fin_R} if self.orientation else {"A": fin_A}
        return new, self._user(out_A, out_R)

    def _user(self, A, R) -> dict:
        lead, n = A.shape[:-3], self.n
        if not self.identity_frame:
            A, R = to_user(A, R if self.orientation else None, self.P)  # skew(PÃPᵀ), R̃Pᵀ
        states = {"A": A.reshape(lead + self.batch + (n, n))}
        if self.orientation:
            states["R"] = R.reshape(lead + self.batch + (n, n))
        return states

    def generator_radius(self, states: dict, limit: float = 0.0) -> float | None:
        """The largest ad spectral radius of ``ξ(y) = Ω`` over the rows ``states`` (the user's
        frame), ``θ₁ + θ₂`` of ``Ω̃ = M ∘ PᵀAP`` (conjugation by P keeps the rotation angles),
        what ``lieint.integrate``'s step check needs, without the generic evaluation of ξ; None
        when a row is not finite (the generic check then handles it).

        When the Frobenius bound ``‖Ω̃‖_F ≥ θ₁ + θ₂`` that the compiled loop kept over every
        state of this run (its start and its saved rows, :meth:`advance`) is below ``limit``, that
        bound is returned (an upper bound: the check only asks whether the radius reaches its
        limit, π/h), without looking at the rows again. Otherwise, as the generic check, it looks
        at most at ``_WARN_SAMPLES`` rows, evenly spaced: when every row's bound is below
        ``limit`` the largest is returned, else the angles (a singular value decomposition) are
        computed only for the rows whose bound exceeds the largest radius found so far, largest
        bound first."""
        if self._radius_bound < limit:
            return self._radius_bound
        from ..groups.so import so_ad_spectral_radius
        from ..ivp import _WARN_SAMPLES

        A = states["A"].reshape(-1, self.n, self.n)
        if A.shape[0] > _WARN_SAMPLES:
            A = A[np.unique(np.linspace(0, A.shape[0] - 1, _WARN_SAMPLES).astype(int))]
        if not self.identity_frame:
            A = self.P.T @ A @ self.P
        omega = A * self.M
        squares = omega * omega
        bound = np.sqrt(np.add.reduce(squares.reshape(squares.shape[0], -1), axis=1))
        largest = np.maximum.reduce(bound)  # NaN when a row is not finite
        if not np.isfinite(largest):
            return None
        if largest < limit:
            return float(largest)
        order = np.argsort(bound)[::-1]
        best, start = 0.0, 0
        while start < order.size and bound[order[start]] > best:
            rows = order[start : start + 8]
            best = max(best, float(np.max(so_ad_spectral_radius(omega[rows]))))
            start += 8
        return best

    def user_state(self, internal: dict) -> dict:
        R = internal["R"][None] if self.orientation else None
        return {k: v[0] for k, v in self._user(internal["A"][None], R).items()}
