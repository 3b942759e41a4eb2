"""Compiled fast paths (numba), chosen by :func:`lieint.integrate` when they apply.

Three kernels: the 3D Euler top (:class:`Top3Kernel`, :mod:`lieint.fast.top3` and the SIMD
lanes of :mod:`lieint.fast.lanes`), the Euler top of any dimension n ≥ 4
(:class:`lieint.fast.topn.TopNKernel`), and one generic loop for every system on SO(n) or SE(n)
times a vector space that declares compiled pieces (:class:`lieint.fast.generic.LieKernel`:
heavy top, free body, rolling and Chaplygin ball, :mod:`lieint.fast.bodies`), each for
fixed-step RKMK in exponential coordinates with a truncated dexp⁻¹ and for classical RK. RKMK in
Cayley coordinates runs in the n-dimensional top's kernel and in the generic one (the 3D top
carries the generic kernel's declaration under ``"lie"``).

Only imported when first used, so ``import lieint`` stays light; numba compiles on the first
call in a fresh environment and caches the machine code on disk for later processes.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ..groups.base import DexpinvRangeError, bernoulli_dexpinv_coefficients

__all__ = ["Top3Kernel", "kernel_for", "range_error", "use_threads"]

#: bodies per block of the SIMD-lanes kernel (:mod:`lieint.fast.lanes`), one block per thread
LANES_BLOCK = 128


def kernel_for(system, method, y0, plan) -> tuple[object | None, str]:
    """A compiled kernel for this run, or None with the reason none applies.

    Kernels are chosen by what system and method *declare* (``system.compiled()`` and
    ``method.compiled()``), never by their class: a system from another package that declares
    the same structure gets the same kernel.
    """
    sys_decl = system.compiled()
    if sys_decl is None:
        label = type(system).__name__
        if isinstance(getattr(system, "n", None), int):
            label += f" (n = {system.n})"
        return None, f"{label} declares no compiled form"
    meth_decl = method.compiled()
    if meth_decl is None:
        return (
            None,
            f"{method.name!r} has no compiled form (compiled: RKMK in exp coordinates with truncated dexp⁻¹ or "
            "in Cayley coordinates, classical RK)",
        )
    kind = sys_decl.get("kind")
    if meth_decl.get("coordinates") == "cayley" and kind not in ("lie", "topn"):
        # the 3D top's kernel has no Cayley form: it carries the generic kernel's declaration
        if "lie" not in sys_decl:
            return None, f"no Cayley kernel for the compiled form {kind!r}"
        sys_decl, kind = sys_decl["lie"], "lie"
    if kind not in ("top3", "topn", "lie"):
        return None, f"no kernel for the compiled form {kind!r}"
    if meth_decl["kind"] not in ("rkmk", "rk"):
        label = {"top3": "3D-top", "topn": "n-dimensional-top", "lie": "Lie-group"}[kind]
        return None, f"no {label} kernel for {meth_decl['kind']!r} methods"
    if kind == "lie":
        from .generic import LieKernel

        batch = system.batch_shape(y0)
        if 0 in batch:
            return None, "the ensemble is empty"
        return LieKernel(pieces_of(sys_decl), meth_decl, y0, batch), ""
    if kind == "topn":
        from .topn import TopNKernel

        return TopNKernel(sys_decl, meth_decl, y0, system.batch_shape(y0)), ""
    return Top3Kernel(sys_decl, meth_decl, y0, system.batch_shape(y0)), ""


def pieces_of(sys_decl: dict) -> dict:
    """A ``"lie"`` declaration with its compiled pieces resolved (the built-in systems name
    theirs, :data:`lieint.fast.bodies.PIECES`)."""
    if not isinstance(sys_decl["pieces"], str):
        return sys_decl
    from .bodies import PIECES

    return dict(sys_decl, pieces=PIECES[sys_decl["pieces"]])


def use_threads(bodies: int) -> tuple[bool, int]:
    """``(parallel, threads)`` for a run of ``bodies`` independent bodies.

    Threads pay off only when every thread gets a body: with fewer bodies than threads (a
    single trajectory above all) the kernel runs serially in the calling thread, which on a
    busy machine saves the milliseconds a parallel region costs to start and join.
    """
    if bodies < 2:  # serial whatever the thread count (numba is not asked: a microsecond a call)
        return False, 1
    import numba

    threads = int(numba.get_num_threads())
    parallel = threads > 1 and bodies >= threads
    return parallel, threads if parallel else 1


def range_error(k: int, plan, where: str = "so(3)") -> DexpinvRangeError:
    """The error the generic path raises when a stage of step ``k`` leaves the dexp⁻¹ radius."""
    return DexpinvRangeError(
        f"Lie step too large for exponential coordinates on {where}: at step {k + 1} (t = {plan.time(k):.6g}) "
        "the spectral radius of ad_u reached 2*pi, where the dexp^-1 series diverges (for so(n): "
        "theta_1 + theta_2 >= 2*pi, the two largest rotation angles of the stage increment). Reduce the "
        "step `h`, or use `coordinates='cayley'`, whose dcay^-1 is exact at every step."
    )


class Top3Kernel:
    """The compiled 3D-top kernel with its own state representation ``(Π, R P)`` in the
    principal frame (P a proper eigenbasis of B), so that a run split into segments gives the
    same bits as one that is not: the conversion to ``(A, R)`` happens only on output."""

    #: ensembles of at least this many bodies run RKMK in SIMD lanes (:mod:`lieint.fast.lanes`)
    LANES_FROM = 64

    def __init__(self, sys_decl: dict, meth_decl: dict, y, batch: tuple[int, ...]):
        self.moments = np.asarray(sys_decl["moments"], dtype=float)
        self.inverse_moments = 1.0 / self.moments
        self.tableau_A = np.ascontiguousarray(meth_decl["A"], dtype=float)
        self.tableau_b = np.ascontiguousarray(meth_decl["b"], dtype=float)
        self.orientation = bool(sys_decl["orientation"])
        self.method = meth_decl
        self.lie = meth_decl["kind"] == "rkmk"
        self.stages = len(meth_decl["b"])
        self.batch = batch
        bodies = math.prod(self.batch)
        # the layout is fixed per run (and so per resume): Π as (N, 3) per body, or (3, N) in lanes
        self.lanes = self.lie and bodies >= self.LANES_FROM
        # a proper rotation keeps Π a vector (not a pseudo-vector); the identity skips the products
        self.P, self.identity_frame = _proper_frame(sys_decl["P"])
        self.coeffs = _dexpinv_coefficients(meth_decl["dexpinv_degree"] if self.lie else 0)
        # lanes run blocks of LANES_BLOCK bodies: threads pay off from one block per thread
        units = -(-bodies // LANES_BLOCK) if self.lanes else bodies
        self.parallel, self.threads = use_threads(units)

    def describe(self) -> str:
        """Which kernel runs."""
        layout = "SIMD lanes (ensemble)" if self.lanes else "per body"
        threads = f"{self.threads} threads" if self.parallel else "serial"
        return f"compiled 3D-top kernel, {'RKMK' if self.lie else 'classical RK'}, {layout}, {threads}"

    def start(self, y: dict) -> dict:
        minus_vee = _top3().minus_vee
        A = y["A"].reshape(-1, 3, 3)
        R = y["R"].reshape(-1, 3, 3) if "R" in y else np.broadcast_to(np.eye(3), A.shape)
        if self.identity_frame:
            pi = minus_vee(A)
        else:
            pi, R = minus_vee(self.P.T @ A @ self.P), R @ self.P
        if self.lanes:  # new arrays of momenta and quaternions: no copy of R needed
            from .quaternions import lanes_from_matrices

            return {"pi": np.ascontiguousarray(pi.T), "q": lanes_from_matrices(R)}
        # a copy of the caller's R: the run never holds the caller's arrays
        return {"pi": pi, "R": np.array(R) if self.identity_frame else np.ascontiguousarray(R)}

    def advance(self, internal: dict, k_from: int, k_to: int, plan, save_steps, project: bool, with_start=False):
        """Steps ``k_from < k ≤ k_to``: the state after them and the user's rows after the steps
        in ``save_steps`` (``with_start``: the starting state's row first)."""
        if self.lanes:
            return self._advance_lanes(internal, k_from, k_to, plan, save_steps, project, with_start)
        out_pi, out_R, fin_pi, fin_R, bad = _top3().integrate_top3(
            internal["pi"],
            internal["R"],
            self.inverse_moments,
            self.tableau_A,
            self.tableau_b,
            self.coeffs,
            self.lie,
            plan.h,
            plan.last_step,
            k_from,
            k_to,
            plan.nsteps,
            save_steps,
            project,
            self.parallel,
            with_start,
        )
        if bad >= 0:
            raise range_error(bad, plan)
        return {"pi": fin_pi, "R": fin_R}, self._user(out_pi, out_R)

    def _advance_lanes(self, internal, k_from, k_to, plan, save_steps, project, with_start=False):
        from .lanes import run_lanes

        tab = self.method
        pi, q = internal["pi"].copy(), internal["q"].copy()
        m, N, s = len(save_steps), pi.shape[1], int(bool(with_start))
        # the kernel writes the user's rows (the starting state's first when asked): no arrays
        # of momenta and quaternions to convert, copy and concatenate afterwards
        out_A = np.empty((m + s, N, 3, 3))
        out_R = np.empty((m + s, N if self.orientation else 0, 3, 3))
        bad = run_lanes(
            pi,
            q,
            self.inverse_moments,
            self.tableau_A,
            self.tableau_b,
            tab["c"],
            self.coeffs,
            plan.h,
            plan.last_step,
            k_from,
            k_to,
            plan.nsteps,
            np.asarray(save_steps, dtype=np.int64),
            project,
            self.P,
            self.identity_frame,
            s,
            out_A,
            out_R,
            self.parallel,
        )
        if bad >= 0:
            raise range_error(bad, plan)
        shape = (m + s,) + self.batch + (3, 3)
        states = {"A": out_A.reshape(shape)}
        if self.orientation:
            states["R"] = out_R.reshape(shape)
        return {"pi": pi, "q": q}, states

    def _user(self, pi, R) -> dict:
        minus_hat = _top3().minus_hat
        shape = pi.shape[:-2] + self.batch + (3, 3)
        if self.identity_frame:  # the products with I would only turn -0.0 into 0.0
            states = {"A": minus_hat(pi).reshape(shape)}
            if self.orientation:
                states["R"] = R.reshape(shape)
            return states
        states = {"A": (self.P @ minus_hat(pi) @ self.P.T).reshape(shape)}
        if self.orientation:
            states["R"] = (R @ self.P.T).reshape(shape)
        return states

    def generator_radius(self, states: dict, limit: float = 0.0) -> float | None:
        """The largest ad spectral radius of ``ξ(y) = Ω`` over the rows ``states`` (the user's
        frame): ``|ω|`` on so(3), what ``lieint.integrate``'s step check needs, in one compiled
        pass instead of the generic evaluation of ξ; None when a row is not finite (the generic
        check then handles it). ``limit`` is unused (the exact value costs no more)."""
        radius = _top3().largest_rate(states["A"], self.P, self.moments)
        return radius if math.isfinite(radius) else None

    def user_state(self, internal: dict) -> dict:
        if self.lanes:
            from .quaternions import matrices_from_lanes

            pi, R = internal["pi"].T, matrices_from_lanes(internal["q"])
        else:
            pi, R = internal["pi"], internal["R"]
        return {k: v[0] for k, v in self._user(pi[None], R[None]).items()}


def _top3():
    """:mod:`lieint.fast.top3`, imported on first use (it loads numba): a module lookup per call
    instead of an import statement's."""
    global _TOP3
    if _TOP3 is None:
        from . import top3

        _TOP3 = top3
    return _TOP3


_TOP3 = None


@lru_cache(maxsize=32)
def _proper_frame_of(data: bytes, n: int) -> tuple[np.ndarray, bool]:
    P = np.frombuffer(data).reshape(n, n).copy()
    if np.linalg.det(P) < 0:
        P[:, -1] *= -1.0
    P.flags.writeable = False
    return P, bool(np.array_equal(P, np.eye(n)))


def _proper_frame(P) -> tuple[np.ndarray, bool]:
    """The principal frame P with det P = +1 (its last axis turned when det P = −1), read-only,
    and whether it is the identity (a diagonal B); worked out once per frame (keyed on its bytes)."""
    P = np.asarray(P, dtype=float)
    return _proper_frame_of(P.tobytes(), P.shape[-1])


@lru_cache(maxsize=32)
def _dexpinv_coefficients(degree: int) -> np.ndarray:
    """The truncated dexp⁻¹ series as the kernels take it (a read-only float array; degree 0:
    ``(1.0,)``, what classical RK passes), without its trailing zeros: ``B_k = 0`` for odd
    k ≥ 3, and a kernel brackets up to the last coefficient — degree 5 costs what degree 4 does,
    and gives the same sum."""
    coeffs = np.array(bernoulli_dexpinv_coefficients(degree), dtype=float)
    coeffs = coeffs[: int(np.flatnonzero(coeffs)[-1]) + 1]
    coeffs.flags.writeable = False
    return coeffs
