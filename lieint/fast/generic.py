"""One compiled loop for every system on SO(n) or SE(n) times a vector space (numba, cached).

A system moved by the right action of ``G = SO(n) × Rᵐ`` or ``G = SE(n) × Rᵐ`` (the heavy
top, the free body, the rolling and the Chaplygin ball, MATH.md §3–§5) supplies four compiled
*pieces* working on its state flattened to one float vector y — its generator, action, vector
field and projection, each given a scratch vector ``work`` of the length it declares (the
contract: :mod:`lieint.fast.pieces`). A piece that takes its temporaries there allocates nothing
per call and can be compiled without reference counts (:data:`lieint.fast._jit.NO_REFCOUNT`), as
the built-in pieces are: a per-call allocation and the counts on every array a compiled call
passes cost more than the arithmetic of a small body's stage.

The signatures are fixed, and the loop takes the pieces as first-class function values in one
compiled record, so it is compiled once per installation for every system (cached on disk) and
a system outside the package opts in by declaring its own pieces (``system.compiled()``
returning ``{"kind": "lie", ...}``, see :class:`LieKernel`). The stage code is
:mod:`lieint.fast.generic_step`.

One RKMK step in exponential coordinates with dexp⁻¹ truncated at the method's degree, as
the generic path (:mod:`lieint.methods.rkmk`)::

    u_i = h Σ_j a_ij k_j,   k_i = Σ_{d ≤ degree} (B_d/d!) ad_{−u_i}^d ξ(ρ(exp u_i, y)),
    y ← ρ(exp(h Σ_j b_j k_j), y),

with the bracket of ``se(n) ⊕ Rᵐ``, ``[(W₁, v₁, a₁), (W₂, v₂, a₂)] = ([W₁, W₂], W₁v₂ − W₂v₁, 0)``
(the vector factor is abelian: its dexp⁻¹ is the identity) and ``exp(W, v) = (exp W, φ₁(W) v)``
(:func:`lieint.fast.skew.expm_se`). A stage whose rotation part reaches the dexp⁻¹ radius
(``θ₁ + θ₂ ≥ 2π``, the same test as the generic path's) stops the body there. In Cayley
coordinates ``k_i = dcay⁻¹_{−u_i}(ξ(ρ(cay u_i, y)))`` with the exact
``dcay⁻¹_{−u}(k) = k + ½[u, k] − ¼ uku`` (homogeneous matrices of se(n)) and
``cay(W, x) = (M⁻¹(I + W/2), M⁻¹x)``, ``M = I − W/2`` (:func:`lieint.fast.skew.cayley_se_into`):
no range limit.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numba import njit, types

from . import _dexpinv_coefficients, range_error, use_threads
from .generic_step import _classical_step, step_either, step_work
from .pieces import BUNDLE, CompiledPieces

__all__ = ["LieKernel", "integrate_lie"]

_vec = types.float64[::1]
_mat = types.float64[:, ::1]

_RUN_SIGNATURE = types.void(
    BUNDLE,
    types.int64,  # lo
    types.int64,  # hi
    _mat,  # Y0 (N, d)
    _vec,  # params
    types.int64,  # n
    types.int64,  # nv: n on SE(n), 0 on SO(n)
    types.int64,  # m: size of the vector factor
    _mat,  # tableau A
    _vec,  # tableau b
    _vec,  # dexp⁻¹ coefficients
    types.boolean,  # lie
    types.boolean,  # cayley
    types.float64,  # h
    types.float64,  # h_last
    types.int64,  # k_from
    types.int64,  # k_to
    types.int64,  # nsteps
    types.int64[::1],  # save_steps
    types.boolean,  # project
    types.float64[:, :, ::1],  # out (saves, N, d)
    _mat,  # fin (N, d)
    types.int64[::1],  # status (N,)
    _vec,  # norm2 (N,)
    types.int64,  # work_size: the pieces' scratch length
)


@njit(cache=True)
def _norm2(W):
    """``‖W‖_F²``: ``‖W‖_F ≥ θ₁ + θ₂``, the ad spectral radius of W on so(n), and on se(n) × Rᵐ
    (whose translations and vector factor add no larger eigenvalue), the step check's bound."""
    total = 0.0
    for i in range(W.shape[0]):
        for j in range(W.shape[1]):
            total += W[i, j] * W[i, j]
    return total


@njit(_RUN_SIGNATURE, cache=True, nogil=True)
def _run_bodies(
    pieces, lo, hi, Y0, par, n, nv, m, tab, b, coeffs, lie, cayley, h, h_last, k_from, k_to,
    nsteps, save_steps, project, out, fin, status, norm2, work_size,
):  # fmt: skip
    """Steps ``k_from < k ≤ k_to`` of the bodies ``lo ≤ m < hi`` (see :func:`integrate_lie`);
    ``norm2[m]`` the largest ``‖W‖_F²`` of ``ξ = (W, v, a)`` over body m's starting state and
    saved rows. Releases the GIL, so that threads can run disjoint ranges of bodies."""
    # one by one: a tuple of function values makes numba unify their types (and warn)
    gen = pieces.generator
    act = pieces.action
    field = pieces.vector_field
    proj = pieces.projection
    s = b.shape[0]
    d = Y0.shape[1]
    KW = np.zeros((s, n, n))
    Kv = np.zeros((s, nv))
    Ka = np.zeros((s, m))
    K = np.zeros((s, d))
    y_stage = np.empty(d)
    y1 = np.empty(d)
    S, Sv, ua, aug, work = step_work(n, nv, m, work_size)
    uncounted = cayley or n == 3
    for body in range(lo, hi):
        y = Y0[body].copy()
        slot = 0
        status[body] = -1
        norm2[body] = 0.0
        # ξ(y) of the state that starts a Lie step is its first stage (u = 0): a saved row's ξ is
        # read there when another step follows, evaluated once otherwise
        pending = True
        if not lie:
            gen(y, par, KW[0], Kv[0], Ka[0], work)
            norm2[body] = _norm2(KW[0])
            pending = False
        for k in range(k_from, k_to):
            hk = h if k < nsteps - 1 else h_last
            if lie:
                ok = step_either(
                    uncounted, gen, act, y, par, nv, tab, b, hk, coeffs, KW, Kv, Ka, y_stage, y1, cayley,
                    S, Sv, ua, aug, work,
                )  # fmt: skip
                if not ok:
                    status[body] = k
                    pending = False
                    break
                if pending:
                    norm2[body] = max(norm2[body], _norm2(KW[0]))
                    pending = False
            else:
                _classical_step(field, y, par, tab, b, hk, K, y_stage, y1, work)
            if project:
                proj(y1, par, y, work)
            else:
                y[:] = y1
            if slot < save_steps.shape[0] and save_steps[slot] == k + 1:
                out[slot, body] = y
                slot += 1
                pending = True
                if not lie:
                    gen(y, par, KW[0], Kv[0], Ka[0], work)
                    norm2[body] = max(norm2[body], _norm2(KW[0]))
                    pending = False
        if pending:
            gen(y, par, KW[0], Kv[0], Ka[0], work)
            norm2[body] = max(norm2[body], _norm2(KW[0]))
        fin[body] = y


def integrate_lie(
    pieces: CompiledPieces,
    Y0,
    params,
    n: int,
    translation: bool,
    m: int,
    tableau_A,
    tableau_b,
    coeffs,
    lie: bool,
    h: float,
    h_last: float,
    k_from: int,
    k_to: int,
    nsteps: int,
    save_steps,
    project: bool,
    threads: int = 1,
    cayley: bool = False,
    start_row: bool = False,
    norm2=None,
):
    """Run the compiled loop over steps ``k_from < k ≤ k_to`` of N bodies.

    Parameters
    ----------
    pieces : CompiledPieces
        The system's compiled generator, action, vector field and projection.
    Y0 : ndarray, shape (N, d)
        The flattened states.
    params : ndarray, shape (p,)
        The system's parameters, as its pieces read them.
    n, translation, m : int, bool, int
        The group: SE(n) (``translation``) or SO(n), times ``Rᵐ``.
    tableau_A, tableau_b, coeffs, lie, h, h_last, k_from, k_to, nsteps, save_steps, project, threads
        As :func:`lieint.fast.topn.integrate_topn`.
    cayley : bool
        RKMK in Cayley coordinates (exact dcay⁻¹; ``coeffs`` unused).
    start_row : bool
        Save the starting states as a first row (``saves + 1`` rows).
    norm2 : ndarray, shape (N,), optional
        Filled with each body's largest ``‖W‖_F²`` of ``ξ = (W, v, a)`` over its starting state
        and its saved rows (``‖W‖_F`` bounds the ad spectral radius: the step check's bound).

    Returns
    -------
    out : ndarray, shape (saves, N, d)
    fin : ndarray, shape (N, d)
    bad : int
        The first step at which a stage left the dexp⁻¹ radius (-1: none).
    """
    Y0 = np.ascontiguousarray(Y0, dtype=float)
    save_steps = np.ascontiguousarray(save_steps, dtype=np.int64)
    N, d = Y0.shape
    s = int(bool(start_row))
    out = np.empty((save_steps.size + s, N, d))
    if s:
        out[0] = Y0
    fin = np.empty((N, d))
    status = np.empty(N, dtype=np.int64)
    norm2 = np.empty(N) if norm2 is None else norm2
    args = (
        Y0,
        np.require(params, float, ["C", "W"]),
        int(n),
        int(n) if translation else 0,
        int(m),
        # the registry's tableaux are read-only; the compiled signature takes writable arrays
        np.require(tableau_A, float, ["C", "W"]),
        np.require(tableau_b, float, ["C", "W"]),
        np.require(coeffs, float, ["C", "W"]),
        bool(lie),
        bool(cayley),
        float(h),
        float(h_last),
        int(k_from),
        int(k_to),
        int(nsteps),
        save_steps,
        bool(project),
        out[s:],  # a C-contiguous view
        fin,
        status,
        norm2,
        pieces.work_size(int(n)),
    )
    bundle = pieces.bundle
    threads = min(int(threads), N)
    if threads > 1:
        cuts = np.linspace(0, N, threads + 1).astype(np.int64)
        with ThreadPoolExecutor(threads) as pool:
            jobs = [pool.submit(_run_bodies, bundle, int(cuts[i]), int(cuts[i + 1]), *args) for i in range(threads)]
            for job in jobs:
                job.result()
    else:
        _run_bodies(bundle, 0, N, *args)
    bad = status[status >= 0]
    return out, fin, int(bad.min()) if bad.size else -1


class LieKernel:
    """The generic compiled kernel for a system declaring its compiled pieces.

    Parameters
    ----------
    sys_decl : dict
        ``{"kind": "lie", "pieces": CompiledPieces, "params": array, "n": int,
        "translation": bool, "abelian": int, "fields": {name: shape}, "group": str}``.
    meth_decl : dict
        ``{"kind": "rkmk" | "rk", "A", "b", "c"[, "dexpinv_degree"]}``.
    y : dict
        The initial state (unused: the layout does not depend on it).
    batch : tuple of int
        The batch shape of the run.
    """

    def __init__(self, sys_decl: dict, meth_decl: dict, y, batch: tuple[int, ...]):
        self.pieces = sys_decl["pieces"]
        self.params = np.require(sys_decl["params"], float, ["C", "W"])
        self.n = int(sys_decl["n"])
        self.translation = bool(sys_decl["translation"])
        self.m = int(sys_decl["abelian"])
        self.fields = {name: tuple(shape) for name, shape in sys_decl["fields"].items()}
        self.sizes = [math.prod(shape) for shape in self.fields.values()]
        self.group = sys_decl.get("group", f"{'se' if self.translation else 'so'}({self.n})")
        self.method = meth_decl
        self.lie = meth_decl["kind"] == "rkmk"
        self.cayley = self.lie and meth_decl.get("coordinates") == "cayley"
        self.stages = int(np.asarray(meth_decl["b"]).size)
        degree = meth_decl.get("dexpinv_degree") if self.lie and not self.cayley else 0
        self.coeffs = np.array(_dexpinv_coefficients(degree))  # writable, as the compiled signature has it
        self.batch = batch
        self.parallel, self.threads = use_threads(math.prod(batch))
        # the largest ‖W‖_F over the states of this run (from start, kept by advance); none yet
        self._radius_bound = math.inf

    def describe(self) -> str:
        """Which kernel runs."""
        threads = f"{self.threads} threads" if self.parallel else "serial"
        kind = ("RKMK (Cayley)" if self.cayley else "RKMK") if self.lie else "classical RK"
        return f"compiled Lie-group kernel on {self.group}, {kind}, per body, {threads}"

    def start(self, y: dict) -> dict:
        N = math.prod(self.batch)
        self._radius_bound = 0.0
        return {"Y": np.concatenate([np.asarray(y[name], dtype=float).reshape(N, -1) for name in self.fields], axis=1)}

    def advance(self, internal: dict, k_from: int, k_to: int, plan, save_steps, project: bool, with_start=False):
        tab = self.method
        norm2 = np.empty(internal["Y"].shape[0])
        out, fin, bad = integrate_lie(
            self.pieces,
            internal["Y"],
            self.params,
            self.n,
            self.translation,
            self.m,
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
            with_start,
            norm2,
        )
        # the step check's bound over every state this run has saved (or started a segment from);
        # a non-finite state makes it infinite (the check then looks at the rows themselves)
        largest = float(np.sqrt(np.maximum.reduce(norm2, initial=0.0)))
        self._radius_bound = max(self._radius_bound, largest) if math.isfinite(largest) else math.inf
        if bad >= 0:
            raise range_error(bad, plan, self.group)
        return {"Y": fin}, self._user(out)

    def generator_radius(self, states: dict, limit: float = 0.0) -> float | None:
        """An upper bound of the largest ad spectral radius of ξ(y) over the rows ``states``
        when it is below ``limit`` (π/h: all the step check asks), else None (the generic check
        then evaluates ξ at the rows).

        The bound is ``max ‖W‖_F`` over every state this run saved or started a segment from,
        kept by the compiled loop (:func:`integrate_lie`'s ``norm2``): ``‖W‖_F² = 2 Σ θ_k² ≥
        (θ₁ + θ₂)²``, and neither the translation of se(n) nor the vector factor adds a larger
        eigenvalue of ad."""
        return self._radius_bound if self._radius_bound < limit else None

    def _user(self, Y) -> dict:
        lead = Y.shape[:-2]
        states, start = {}, 0
        for (name, shape), size in zip(self.fields.items(), self.sizes, strict=True):
            states[name] = Y[..., start : start + size].reshape(lead + self.batch + shape)
            start += size
        return states

    def user_state(self, internal: dict) -> dict:
        return {k: v[0] for k, v in self._user(internal["Y"][None]).items()}
