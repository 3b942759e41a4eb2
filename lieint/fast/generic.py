"""One compiled loop for every system on SO(n) or SE(n) times a vector space (numba, cached).

A system moved by the right action of ``G = SO(n) × Rᵐ`` or ``G = SE(n) × Rᵐ`` (the heavy
top, the free body, the rolling and the Chaplygin ball, MATH.md §3–§5) supplies four compiled
*pieces* (:class:`CompiledPieces`) working on its state flattened to one float vector y:

* ``generator(y, params, W, v, a, work)`` writes ``ξ(y) = (W, v, a)``: W ∈ so(n), v ∈ Rⁿ the
  translation of se(n) (length 0 on SO(n)), a ∈ Rᵐ (length 0 without a vector factor);
* ``action(Q, t, a, y, params, out, work)`` writes ``ρ(g, y)`` for ``g = ((Q, t), a)``;
* ``vector_field(y, params, out, work)`` writes ``ẏ`` (classical RK, on the flattened state);
* ``projection(y, params, out, work)`` writes the projected state (``project=True``).

``work`` is scratch memory of the length the pieces declare (:attr:`CompiledPieces.work`),
allocated once per run and thread: a piece that takes its temporaries there allocates nothing
per call, and can be compiled without reference counts (:data:`lieint.fast._jit.NO_REFCOUNT`),
as the built-in pieces are — a per-call allocation and the counts on every array a compiled
call passes cost more than the arithmetic of a small body's stage.

Their signatures are fixed (:data:`GENERATOR`, :data:`ACTION`, :data:`FIELD`); the loop takes
them as first-class function values, so it is compiled once per installation for every
system (cached on disk) and a system outside the package opts in by declaring its own pieces
(``system.compiled()`` returning ``{"kind": "lie", ...}``, see :class:`LieKernel`).

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
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import njit, types
from numba.core.types.function_type import CompileResultWAP
from numba.experimental import structref

from . import _dexpinv_coefficients, range_error, use_threads
from ._jit import NO_REFCOUNT, compiled_copies
from .se_algebra import (
    coordinate_map,
    coordinate_map_uncounted,
    dcayinv,
    dexpinv,
    out_of_range,
    out_of_range_3,
)

__all__ = ["ACTION", "FIELD", "GENERATOR", "CompiledPieces", "LieKernel", "integrate_lie"]

_vec = types.float64[::1]
_mat = types.float64[:, ::1]
#: ``generator(y, params, W, v, a, work)``: writes ξ(y) = (W, v, a)
GENERATOR = types.void(_vec, _vec, _mat, _vec, _vec, _vec)
#: ``action(Q, t, a, y, params, out, work)``: writes ρ(((Q, t), a), y)
ACTION = types.void(_mat, _vec, _vec, _vec, _vec, _vec, _vec)
#: ``vector_field(y, params, out, work)`` and ``projection(y, params, out, work)``
FIELD = types.void(_vec, _vec, _vec, _vec)


@dataclass(frozen=True)
class CompiledPieces:
    """A system's compiled generator, action, vector field and projection: numba functions,
    compiled for the signatures :data:`GENERATOR`, :data:`ACTION`, :data:`FIELD`, :data:`FIELD`
    when first used (or declared with them); ``work``: the length of the scratch vector they
    are given, a number or a function of n."""

    generator: object
    action: object
    vector_field: object
    projection: object
    work: int | Callable[[int], int] = 0

    def work_size(self, n: int) -> int:
        """The scratch length for bodies of dimension n."""
        size = self.work(n) if callable(self.work) else self.work
        if not isinstance(size, (int, np.integer)) or size < 0:
            raise ValueError(f"`work` of compiled pieces must give a length >= 0; got {size!r} for n = {n}.")
        return int(size)

    @cached_property
    def functions(self) -> tuple:
        """The four pieces as first-class function values, resolved once (:class:`_Piece`)."""
        signatures = (GENERATOR, ACTION, FIELD, FIELD)
        pieces = (self.generator, self.action, self.vector_field, self.projection)
        return tuple(_Piece(f, sig) for f, sig in zip(pieces, signatures, strict=True))

    @cached_property
    def bundle(self) -> PiecesBundle:
        """The four pieces in one compiled record, as the loops take them (:data:`BUNDLE`): made
        once per declaration, it passes into compiled code for the cost of one reference, where
        each first-class function argument costs ~3.5 µs per call (numba unpickles its signature
        twice to look up its addresses)."""
        return _bundle(*self.functions)


class _Piece:
    """A compiled function as a first-class function value whose address and numba type are
    worked out once: numba's wrapper-address protocol, and ``_numba_type_`` so that typing the
    argument is an attribute read. Passing the numba function itself costs ~50 µs per argument
    per call (its compile result and address are looked up every time)."""

    def __init__(self, function, signature):
        if not hasattr(function, "get_compile_result"):
            raise TypeError(f"a compiled piece must be a numba function; got {type(function).__name__}.")
        try:
            result = function.get_compile_result(signature)
        except Exception as exc:  # numba's typing error: the piece does not take these arguments
            name = getattr(function, "__name__", repr(function))
            raise TypeError(
                f"the compiled piece {name!r} must take the arguments {signature.args} "
                f"(lieint.fast.generic.GENERATOR, ACTION or FIELD, the last one the scratch vector `work`); "
                f"numba could not compile it for them: {str(exc).splitlines()[0]}"
            ) from None
        self._address = CompileResultWAP(result).address
        self._signature = signature
        self._numba_type_ = types.FunctionType(signature)

    def __wrapper_address__(self) -> int:
        return self._address

    def signature(self):
        return self._signature


@structref.register
class _BundleType(types.StructRef):
    """numba's type of :class:`PiecesBundle`."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


class PiecesBundle(structref.StructRefProxy):
    """A system's compiled pieces as one compiled record (fields ``generator``, ``action``,
    ``vector_field``, ``projection``), made by :attr:`CompiledPieces.bundle`."""


structref.define_boxing(_BundleType, PiecesBundle)
#: the numba type of a bundle of pieces with the signatures above
BUNDLE = _BundleType(
    [
        ("generator", types.FunctionType(GENERATOR)),
        ("action", types.FunctionType(ACTION)),
        ("vector_field", types.FunctionType(FIELD)),
        ("projection", types.FunctionType(FIELD)),
    ]
)


@njit(BUNDLE(*BUNDLE.field_dict.values()), cache=True)
def _bundle(generator, action, vector_field, projection):
    record = structref.new(BUNDLE)
    record.generator = generator
    record.action = action
    record.vector_field = vector_field
    record.projection = projection
    return record


@njit(cache=True, **NO_REFCOUNT)
def _combine(out, K, weights, upto, h):
    """``out = Σ_{j < upto} (h w_j) K[j]`` over the nonzero weights (zero if none), on flat
    views (out of shape (size,), K of shape (stages, size)); returns whether any weight was
    nonzero."""
    size = out.shape[0]
    for i in range(size):
        out[i] = 0.0
    any_weight = False
    for j in range(upto):
        if weights[j] != 0.0:
            any_weight = True
            w = h * weights[j]
            for i in range(size):
                out[i] += w * K[j, i]
    return any_weight


@njit(cache=True)
def step_work(n, nv, m, work_size):
    """The work arrays of :func:`lie_step` and :func:`move`, allocated once per run and thread:
    ``S`` (5, n, n) for ``uW, Q, tW, P`` and dcay⁻¹'s result, ``Sv`` (4, nv) for
    ``uv, t, tv, nw``, ``ua`` (m,), ``aug`` (n, 2n + 1) for the Cayley map's elimination, and
    the pieces' ``work`` (``work_size``,)."""
    return np.empty((5, n, n)), np.empty((4, nv)), np.empty(m), np.empty((n, 2 * n + 1)), np.empty(work_size)


@njit(cache=True)
def lie_step(gen, act, y, par, nv, tab, b, h, coeffs, KW, Kv, Ka, y_stage, y1, cayley, S, Sv, ua, aug, work):
    """One RKMK step from y into ``y1`` in exponential (dexp⁻¹ truncated at ``coeffs``) or
    Cayley coordinates (exact dcay⁻¹); False when a stage leaves the dexp⁻¹ radius.
    ``S, Sv, ua, aug, work``: :func:`step_work`'s arrays (nothing is allocated here)."""
    s = b.shape[0]
    n = KW.shape[1]
    uW, Q, tW, P, new = S[0], S[1], S[2], S[3], S[4]
    uv, t, tv, nw = Sv[0], Sv[1], Sv[2], Sv[3]
    uW_flat, KW_flat = uW.reshape(n * n), KW.reshape(KW.shape[0], n * n)
    for i in range(s):
        row = tab[i]
        _combine(uW_flat, KW_flat, row, i, h)
        _combine(uv, Kv, row, i, h)
        kW, kv, ka = KW[i], Kv[i], Ka[i]
        if not _combine(ua, Ka, row, i, h):
            gen(y, par, kW, kv, ka, work)  # u = 0: k_i = ξ(y)
            continue
        if not cayley and out_of_range(uW, nv):
            return False
        coordinate_map(uW, uv, nv, Q, t, cayley, aug)
        act(Q, t, ua, y, par, y_stage, work)
        gen(y_stage, par, kW, kv, ka, work)
        if cayley:
            dcayinv(uW, uv, kW, kv, tW, tv, new)
        else:
            dexpinv(uW, uv, kW, kv, coeffs, tW, tv, P, nw)
    move(act, y, par, nv, KW, Kv, Ka, b, h, y1, cayley, S, Sv, ua, aug, work)
    return True


@njit(cache=True)
def move(act, y, par, nv, KW, Kv, Ka, w, h, out, cayley, S, Sv, ua, aug, work):
    """``out = ρ(φ(h Σ_j w_j k_j), y)``: the step's new state (weights b) or an embedded
    solution (weights b̂), in :func:`step_work`'s arrays."""
    n = KW.shape[1]
    uW, Q = S[0], S[1]
    uv, t = Sv[0], Sv[1]
    s = w.shape[0]
    _combine(uW.reshape(n * n), KW.reshape(KW.shape[0], n * n), w, s, h)
    _combine(uv, Kv, w, s, h)
    _combine(ua, Ka, w, s, h)
    coordinate_map(uW, uv, nv, Q, t, cayley, aug)
    act(Q, t, ua, y, par, out, work)


#: :func:`lie_step` and :func:`move` compiled without reference counts, for Cayley coordinates at
#: every n and exponential coordinates at n = 3, where the coordinate map and the range test
#: allocate nothing: each view of a stage and each call counted references (two atomic operations
#: an array), ~100 a step, 18 % of a 3D heavy top's RKMK6 run
_UNCOUNTED = compiled_copies(
    [lie_step, move],
    {"coordinate_map": coordinate_map_uncounted, "out_of_range": out_of_range_3},
    "_uncounted",
    **NO_REFCOUNT,
)
lie_step_uncounted, move_uncounted = _UNCOUNTED["lie_step"], _UNCOUNTED["move"]


@njit(cache=True, inline="always")
def step_either(
    uncounted, gen, act, y, par, nv, tab, b, h, coeffs, KW, Kv, Ka, y_stage, y1, cayley, S, Sv, ua, aug, work
):
    """:func:`lie_step`, or its copy without reference counts when ``uncounted`` (Cayley
    coordinates, or n = 3)."""
    if uncounted:
        return lie_step_uncounted(
            gen, act, y, par, nv, tab, b, h, coeffs, KW, Kv, Ka, y_stage, y1, cayley, S, Sv, ua, aug, work
        )
    return lie_step(gen, act, y, par, nv, tab, b, h, coeffs, KW, Kv, Ka, y_stage, y1, cayley, S, Sv, ua, aug, work)


@njit(cache=True, inline="always")
def move_either(uncounted, act, y, par, nv, KW, Kv, Ka, w, h, out, cayley, S, Sv, ua, aug, work):
    """:func:`move`, or its copy without reference counts when ``uncounted``."""
    if uncounted:
        move_uncounted(act, y, par, nv, KW, Kv, Ka, w, h, out, cayley, S, Sv, ua, aug, work)
    else:
        move(act, y, par, nv, KW, Kv, Ka, w, h, out, cayley, S, Sv, ua, aug, work)


@njit(cache=True)
def _classical_step(field, y, par, tab, b, h, K, y_stage, y1, work):
    """One classical RK step on the flattened state: ``y1 = y + h Σ_j b_j K_j``."""
    s = b.shape[0]
    for i in range(s):
        _combine(y_stage, K, tab[i], i, h)
        y_stage += y
        field(y_stage, par, K[i], work)
    _combine(y1, K, b, s, h)
    y1 += y


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
