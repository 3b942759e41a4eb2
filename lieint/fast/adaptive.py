"""The compiled adaptive path: which runs it covers and the kernel object the driver steps.

Chosen, like the fixed-step kernels, by declaration: the method declares an RKMK embedded pair
(``method.compiled()`` with ``"b_hat"``, ``"error_order"`` and, for DOP853's combined estimate,
``"b_hat_low"``), and the system either the 3D top (``"top3"``: its own kernel,
:mod:`lieint.fast.top3_adaptive`, for exponential coordinates), the top in n ≥ 4 dimensions
(``"topn"``: :mod:`lieint.fast.topn_adaptive`, exponential and Cayley coordinates) or compiled
pieces (``"lie"``, or the 3D top's declaration under ``"lie"`` for its Cayley runs:
:mod:`lieint.fast.generic_adaptive`, exponential and Cayley coordinates). The numba code is
imported on the first step.
"""

from __future__ import annotations

import numpy as np

from . import Top3Kernel
from .pairs import CompiledPair, row_capacity

__all__ = ["Top3AdaptiveKernel", "TopNAdaptiveKernel", "adaptive_kernel_for"]


def adaptive_kernel_for(system, method, y0) -> tuple[object | None, str]:
    """The compiled adaptive kernel for this run, or None with the reason none applies."""
    sys_decl = system.compiled()
    if sys_decl is None:
        label = type(system).__name__
        if isinstance(getattr(system, "n", None), int):
            label += f" (n = {system.n})"
        return None, f"{label} declares no compiled form"
    meth_decl = method.compiled()
    cayley = meth_decl is not None and meth_decl.get("coordinates") == "cayley"
    if cayley and sys_decl.get("kind") == "top3" and "lie" in sys_decl:
        sys_decl = sys_decl["lie"]  # the 3D top's Cayley coordinates: through the generic kernel
    if sys_decl.get("kind") not in ("top3", "topn", "lie"):
        return None, f"no adaptive kernel for the compiled form {sys_decl.get('kind')!r}"
    if cayley and sys_decl["kind"] == "top3":
        return None, f"no adaptive Cayley kernel for the compiled form {sys_decl['kind']!r}"
    if meth_decl is None or meth_decl.get("kind") != "rkmk" or "b_hat" not in meth_decl:
        return None, (
            f"{method.name!r} has no compiled adaptive form (compiled: RKMK embedded pairs in exp "
            "coordinates with truncated dexp⁻¹ or in Cayley coordinates)"
        )
    batch = system.batch_shape(y0)
    if 0 in batch:
        return None, "the ensemble is empty"
    if sys_decl["kind"] == "lie":
        from . import pieces_of
        from .generic_adaptive import LieAdaptiveKernel

        return LieAdaptiveKernel(pieces_of(sys_decl), meth_decl, batch), ""
    if sys_decl["kind"] == "topn":
        return TopNAdaptiveKernel(sys_decl, meth_decl, batch), ""
    return Top3AdaptiveKernel(sys_decl, meth_decl, batch), ""


class Top3AdaptiveKernel(Top3Kernel):
    """Adaptive RKMK on the 3D top in machine code, state ``(Π, R P)`` per body (as
    :class:`~lieint.fast.Top3Kernel`'s per-body layout; a batch shares one step size).

    :meth:`advance` takes accepted steps from ``(t, h)``, the controller's state between
    accepted steps, and returns where it stopped; every field of the user's state enters the
    error norm as on the generic path (:mod:`lieint.fast.top3_adaptive`).
    """

    def __init__(self, sys_decl: dict, meth_decl: dict, batch: tuple[int, ...]):
        super().__init__(sys_decl, meth_decl, None, batch)
        self.lanes, self.parallel, self.threads = False, False, 1
        self.pair = CompiledPair.from_declaration(meth_decl)

    def describe(self) -> str:
        return "compiled 3D-top kernel, adaptive RKMK (whole controller loop), per body, serial"

    def advance_adaptive(self, internal: dict, t, t1, h, k, max_accept, save_every, project, controller, h_min):
        """Accepted steps from ``(t, h)`` at step ``k`` until ``t1``, ``max_accept`` accepted
        steps or :data:`lieint.fast.pairs.ROWS_PER_CALL` saved rows.

        Returns the new internal state, ``(t, h, k)``, the accepted, rejected and evaluation
        counts, the saved times and user states, and whether the step size fell below ``h_min``.
        """
        from .top3_adaptive import adaptive_top3

        pi, R = internal["pi"].copy(), internal["R"].copy()
        N = pi.shape[0]
        cap = row_capacity(8 * 12 * N, max_accept, save_every)
        out_t, out_pi, out_R = np.empty(cap), np.empty((cap, N, 3)), np.empty((cap, N, 3, 3))
        pair = self.pair
        status, t, h, k, accepted, rejected, nfev, rows = adaptive_top3(
            pi,
            R,
            self.inverse_moments,
            self.tableau_A,
            self.tableau_b,
            pair.b_hat,
            pair.b_low,
            pair.has_low,
            self.coeffs,
            self.P,
            self.orientation,
            float(controller.rtol),
            float(controller.atol),
            pair.error_order,
            float(controller.safety),
            float(controller.factor_min),
            float(controller.factor_max),
            float(h_min),
            float(t),
            float(t1),
            float(h),
            int(k),
            int(max_accept),
            int(save_every),
            bool(project),
            out_t,
            out_pi,
            out_R,
        )
        saved = self._user(out_pi[:rows], out_R[:rows])
        return {"pi": pi, "R": R}, (t, h, k), (accepted, rejected, nfev), out_t[:rows].copy(), saved, status == 1


class TopNAdaptiveKernel:
    """Adaptive RKMK on the Euler top in n ≥ 4 dimensions in machine code, state
    ``(Ã, R̃) = (PᵀAP, RP)`` per body in the principal frame (as
    :class:`~lieint.fast.topn.TopNKernel`'s; a batch shares one step size). The error norm is
    taken on the user's fields, as on the generic path (:mod:`lieint.fast.topn_adaptive`)."""

    def __init__(self, sys_decl: dict, meth_decl: dict, batch: tuple[int, ...]):
        from .topn import TopNKernel

        self.frame = TopNKernel(sys_decl, meth_decl, None, batch)  # layout, frame, conversions
        self.stages, self.parallel, self.threads = self.frame.stages, False, 1
        self.M = self.frame.M
        self.tab_A = np.ascontiguousarray(meth_decl["A"], dtype=float)
        self.tab_b = np.ascontiguousarray(meth_decl["b"], dtype=float)
        self.pair = CompiledPair.from_declaration(meth_decl)
        self.coeffs = np.asarray(self.frame.coeffs, dtype=float)

    def describe(self) -> str:
        kind = "adaptive RKMK (Cayley)" if self.frame.cayley else "adaptive RKMK"
        return f"compiled {self.frame.n}D-top kernel, {kind} (whole controller loop), per body, serial"

    def start(self, y: dict) -> dict:
        return self.frame.start(y)

    def user_state(self, internal: dict) -> dict:
        return self.frame.user_state(internal)

    def initial_step(self, internal: dict, t0: float, t1: float, controller, error_order: int) -> float:
        """The first trial step, :meth:`lieint.control.StepSizeController.initial_step` with the
        vector field in machine code (:func:`lieint.fast.topn_adaptive.initial_step_topn`)."""
        from .topn_adaptive import initial_step_topn

        f = self.frame
        A = internal["A"]
        R = internal["R"] if f.orientation else np.empty((A.shape[0], 0, 0))
        return float(
            initial_step_topn(
                A, R, f.orientation, self.M, f.P, f.identity_frame, float(controller.rtol), float(controller.atol),
                float(t1 - t0), int(error_order),
            )
        )  # fmt: skip

    def advance_adaptive(self, internal: dict, t, t1, h, k, max_accept, save_every, project, controller, h_min):
        """Accepted steps from ``(t, h)`` at step ``k`` (see
        :meth:`Top3AdaptiveKernel.advance_adaptive`)."""
        from .topn_adaptive import adaptive_topn

        f = self.frame
        A = internal["A"].copy()
        R = internal["R"].copy() if f.orientation else np.empty((A.shape[0], 0, 0))
        N, n, r = A.shape[0], f.n, R.shape[1]
        cap = row_capacity(8 * (n * n + r * r) * N, max_accept, save_every)
        out_t, out_A, out_R = np.empty(cap), np.empty((cap, N, n, n)), np.empty((cap, N, r, r))
        p = self.pair
        status, t, h, k, accepted, rejected, nfev, rows = adaptive_topn(
            A, R, f.orientation, self.M, f.P, f.identity_frame, self.tab_A, self.tab_b, p.b_hat, p.b_low,
            p.has_low, self.coeffs, f.cayley, float(controller.rtol), float(controller.atol), p.error_order,
            float(controller.safety), float(controller.factor_min), float(controller.factor_max), float(h_min),
            float(t), float(t1), float(h), int(k), int(min(max_accept, np.iinfo(np.int64).max)), int(save_every),
            bool(project), out_t, out_A, out_R,
        )  # fmt: skip
        new = {"A": A, "R": R} if f.orientation else {"A": A}
        saved = f._user(out_A[:rows], out_R[:rows])
        return new, (t, h, k), (accepted, rejected, nfev), out_t[:rows].copy(), saved, status == 1
