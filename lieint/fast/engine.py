"""The compiled engine's Python side: which form steps a run, and the one loop bound to it.

:func:`engine_for` matches a system's compiled form (:mod:`lieint.fast.forms`) with a method's
and returns an :class:`Engine` — or None with the reason, which ``sol.stats.backend_reason``
reports. An engine holds a *layout* (:mod:`lieint.fast.layouts`: how the system's state flattens
into the form's vector, in the form's frame, and back) and the loop of :mod:`lieint.fast.loop` compiled for the form's
stage functions (:func:`bound_loops`: one copy of the loop's source per form and method family,
cached on disk by numba under its own name). The driver (:mod:`lieint.loops`) calls
:meth:`Engine.start`, :meth:`Engine.advance` (fixed steps),
:meth:`Engine.advance_adaptive` (the controller) and :meth:`Engine.user_state`.
"""

from __future__ import annotations

import math
import threading
import types
import warnings
from collections import OrderedDict, namedtuple
from concurrent.futures import ThreadPoolExecutor
from functools import cache, lru_cache

import numpy as np

from ..groups.base import DexpinvRangeError, bernoulli_dexpinv_coefficients
from .dispatch import typed_context
from .forms import (
    Chaplygin3Form,
    ClassicalForm,
    ExpProductForm,
    HeavyTop3Form,
    MapForm,
    PiecesForm,
    PrescribedForm,
    RKMKForm,
    RollingBall3Form,
    Top3Form,
    TopNForm,
)
from .layouts import (
    Chaplygin3LanesLayout,
    HeavyTop3LanesLayout,
    Layout,
    PiecesEnergyLayout,
    PiecesLayout,
    PrescribedLayout,
    RollingBall3LanesLayout,
    Top3EnergyLayout,
    Top3LanesLayout,
    Top3Layout,
    Top4LanesLayout,
    TopNEnergyLayout,
    TopNLayout,
)
from .tangent_layouts import Chaplygin3Layout, HeavyTop3Layout, RollingBall3Layout

__all__ = [
    "Engine",
    "Products",
    "Tableau",
    "bound_loops",
    "engine_for",
    "range_error",
    "use_threads",
]

#: a method's numbers as the compiled steps read them (one numba type for every tableau form)
Tableau = namedtuple("Tableau", "A b c coeffs cayley")
#: the step sizes the loop reads on a grid (no entries: h, and the grid's last step its own)
_GRID_STEPS = np.empty(0)
#: a product of exponentials' numbers (:class:`lieint.fast.forms.ExpProductForm`; ``cayley`` is
#: False: the observer reads it as a tableau's)
Products = namedtuple("Products", "weights bounds c cayley")

#: the largest step count a loop takes (``np.iinfo`` costs a few microseconds a look)
_INT64_MAX = int(np.iinfo(np.int64).max)


#: rows the controller loop buffers per call before handing them back (memory stays bounded) ...
ROWS_PER_CALL = 4096
#: ... and the bytes those rows may take (fewer rows per call for a large batch)
BYTES_PER_CALL = 32_000_000


def row_capacity(bytes_per_row: int, max_accept: int, save_every: int) -> int:
    """Rows to buffer for one call of the controller loop: at most :data:`ROWS_PER_CALL`,
    :data:`BYTES_PER_CALL` and the rows ``max_accept`` accepted steps can save; at least one."""
    return max(1, min(ROWS_PER_CALL, BYTES_PER_CALL // bytes_per_row, max_accept // save_every + 1))


def range_error(k: int, plan, where: str = "so(3)") -> DexpinvRangeError:
    """The error a run raises when a stage of step ``k`` leaves the dexp⁻¹ radius."""
    return DexpinvRangeError(
        f"Lie step too large for exponential coordinates on {where}: at step {k + 1} (t = {plan.time(k):.6g}) "
        "the spectral radius of ad_u reached 2*pi, where the dexp^-1 series diverges (for so(n): "
        "theta_1 + theta_2 >= 2*pi, the two largest rotation angles of the stage increment). Reduce the "
        "step `h`, or use `coordinates='cayley'`, whose dcay^-1 is exact at every step."
    )


def _unsolved(k: int, plan, family: str = "moser_veselov") -> RuntimeError:
    """The error a run of a map raises when its step ``k`` failed: Newton's method did not solve a
    Moser–Veselov equation (the numpy path's message, with the step), the midpoint's fixed-point
    iteration did not converge, or the exact flow's quadrature of the precession angle did not
    settle however finely the step was cut."""
    h = plan.step_size(k)
    if family == "midpoint":
        return RuntimeError(
            f"implicit midpoint step h = {h:g} at t = {plan.time(k):.6g} (step {k + 1}): the fixed-point iteration "
            "did not converge; take a smaller `h`."
        )
    if family == "exact_flow":
        return RuntimeError(
            f"exact_flow step h = {h:g}: the precession angle's quadrature did not settle at step {k + 1} "
            f"(t = {plan.time(k):.6g}) even cut into 4096 substeps; run it with backend='numpy' (the closed form)."
        )
    return RuntimeError(
        f"Moser–Veselov step h = {h:g}: Newton did not reach round-off at step {k + 1} (t = {plan.time(k):.6g}); "
        "take a smaller `h`."
    )


def use_threads(bodies: int) -> tuple[bool, int]:
    """``(parallel, threads)`` for a run of ``bodies`` independent bodies (or blocks of them).

    Threads pay off only when every thread gets a body: with fewer bodies than threads (a
    single trajectory above all) the loop runs serially in the calling thread, which on a busy
    machine saves the milliseconds a parallel region costs to start and join.
    """
    if bodies < 2:  # serial whatever the thread count (numba is not asked: a microsecond a call)
        return False, 1
    import numba

    threads = int(numba.get_num_threads())
    parallel = threads > 1 and bodies >= threads
    return parallel, threads if parallel else 1


_POOLS: dict[tuple[int, int], ThreadPoolExecutor] = {}
_POOLS_LOCK = threading.Lock()


def worker_pool(workers: int) -> ThreadPoolExecutor:
    """The process's pool of ``workers`` threads for the compiled loops' ranges of bodies, made on
    first use and kept: a pool started and joined at every call cost about 0.9 ms, three times a
    two-body 3D heavy top's whole run. Keyed by the process too: a forked child (a sweep's worker)
    gets a pool of its own, not its parent's, whose threads it does not have. Callers in several
    threads share the workers (each waits for its own ranges only)."""
    import os

    key = (os.getpid(), int(workers))
    with _POOLS_LOCK:
        pool = _POOLS.get(key)
        if pool is None:
            pool = _POOLS[key] = ThreadPoolExecutor(workers, thread_name_prefix="lieint-engine")
        return pool


# -- the loop bound to a form ----------------------------------------------------------------------


def _source_salt() -> str:
    """A digest of the compiled layer's sources: numba keys its disk cache on the source file of
    the function it compiles only, so a change in a form's stage code (another file) would
    otherwise leave a stale copy of the loop in the cache. The digest is part of every copy's
    name."""
    import hashlib
    from pathlib import Path

    digest = hashlib.sha1()
    for path in sorted(Path(__file__).parent.glob("*.py")):
        digest.update(path.read_bytes())
    return digest.hexdigest()[:10]


@lru_cache(maxsize=1)
def _salt() -> str:
    return _source_salt()


@cache
def bound_loops(module: str, family: str) -> types.SimpleNamespace:
    """The loop of :mod:`lieint.fast.loop` compiled for the stage functions of the form in
    ``module`` (its ``NAMESPACES[family]``): ``fixed``, ``adaptive`` and ``first_trial_step``,
    each a numba function of its own (cached on disk under the copy's name; compiled on its
    first call, announced on stderr by :mod:`lieint.fast._jit`)."""
    import importlib

    from numba import njit

    from . import _jit, loop

    namespace = importlib.import_module(module).NAMESPACES[family]
    suffix = f"__{module.rsplit('.', 1)[-1]}_{family}_{_salt()}"
    copies = {}
    for name, options in (("fixed", {"nogil": True}), ("adaptive", {}), ("first_trial_step", {})):
        template = getattr(loop, name)
        scope = {**template.__globals__, **namespace}
        clone = types.FunctionType(template.__code__, scope, name + suffix, template.__defaults__)
        clone.__qualname__ = template.__qualname__ + suffix
        clone.__module__, clone.__doc__ = template.__module__, template.__doc__
        label = f"{module.rsplit('.', 1)[-1]} {family} {name.replace('_', ' ')}"
        copies[name] = _jit.announced(njit(cache=True, **options)(clone), label)
        _forget_stale(copies[name], name + suffix[: -len(_salt())])
    return types.SimpleNamespace(**copies)


def _forget_stale(dispatcher, stem: str) -> None:
    """Remove the disk cache's copies of this loop made from other sources (another digest):
    they can never be loaded again, and each holds a compiled loop."""
    import re
    from pathlib import Path

    try:
        folder = Path(dispatcher._cache._cache_path)  # numba's cache directory of the template's file
        copy = re.compile(rf"^loop\.{re.escape(stem)}([0-9a-f]{{10}})-")
        for path in folder.glob(f"loop.{stem}*"):
            found = copy.match(path.name)
            if found and found.group(1) != _salt():
                path.unlink(missing_ok=True)
    except (AttributeError, OSError):  # another cache layout, a read-only folder: nothing to forget
        pass


# -- method data -----------------------------------------------------------------------------------


@lru_cache(maxsize=32)
def dexpinv_coefficients(degree: int) -> np.ndarray:
    """The truncated dexp⁻¹ series as the steps take it (degree 0: ``(1.0,)``, what classical RK
    and Cayley coordinates pass), without its trailing zeros: ``B_k = 0`` for odd k ≥ 3, and a
    step brackets up to the last coefficient — degree 5 costs what degree 4 does."""
    coeffs = np.array(bernoulli_dexpinv_coefficients(degree), dtype=float)
    coeffs = coeffs[: int(np.flatnonzero(coeffs)[-1]) + 1]
    coeffs.flags.writeable = False
    return coeffs


def _tableau(method) -> Tableau | Products:
    """The method form's numbers as the compiled steps read them (writable C arrays, as numba's
    types for them in the loops' copies)."""
    if isinstance(method, ExpProductForm):
        return Products(
            np.require(method.weights, float, ["C", "W"]),
            np.require(method.bounds, np.int64, ["C", "W"]),
            np.require(method.c, float, ["C", "W"]),
            False,
        )
    cayley = method.family == "rkmk" and method.coordinates == "cayley"
    degree = method.degree if method.family == "rkmk" and not cayley else 0
    return Tableau(
        np.require(method.A, float, ["C", "W"]),
        np.require(method.b, float, ["C", "W"]),
        np.require(method.c, float, ["C", "W"]),
        np.array(dexpinv_coefficients(degree)),
        bool(cayley),
    )


# -- the engine ------------------------------------------------------------------------------------


class Engine:
    """A run's compiled engine: a layout, a method form and the loop bound to them.

    The carry between segments is ``{"Y": (N, d)}``, the form's flat states (the principal frame
    of the tops): a run split into segments gives the bits of one that is not.
    """

    def __init__(self, layout: Layout, method, batch: tuple[int, ...], adaptive: bool, stage_module: str = "",
                 group=None):  # fmt: skip
        self.layout, self.method, self.batch = layout, method, batch
        self.group = group  # the system's group: a product of exponentials' increments compose in it
        self.N = math.prod(batch)
        units = getattr(layout, "units", self.N)  # bodies, or blocks of bodies in SIMD lanes
        module = stage_module or layout.module  # a map's own stage code (MapForm.module_for)
        self.du = layout.increments_size(method)
        if isinstance(method, MapForm):
            import importlib

            stage = importlib.import_module(module)
            self.tableau = stage.numbers(method, layout)
            if not getattr(stage, "INCREMENT", True):  # its steps report none: dense output from the states
                self.du = 0
        else:
            self.tableau = _tableau(method)
        self.stages = method.stages
        self.adaptive = adaptive
        self.loops = bound_loops(module, layout.family(method))
        if adaptive:
            self.parallel, self.threads = False, 1  # a batch shares one step size
            low = method.b_low
            self.pair = (
                np.require(method.b_hat, float, ["C", "W"]),
                np.require(low if low is not None else np.zeros_like(method.b_hat), float, ["C", "W"]),
                low is not None,
                int(method.error_order),
            )
        else:
            self.parallel, self.threads = use_threads(units)
        # the largest ad radius bound over the states of this run (kept by advance); none yet
        self._radius2 = math.inf
        self.cacheable = True
        # what the copies of this engine (:meth:`fresh`) share and work out once: the loops' typed
        # context (typing a context with compiled pieces in it costs 10–20 µs a call)
        self._shared: dict = {}

    @property
    def context(self):
        """The layout's context of the loops, typed once (:func:`lieint.fast.dispatch.typed_context`)
        for this engine and its copies."""
        ctx = self._shared.get("context")
        if ctx is None:
            ctx = self._shared["context"] = typed_context(self.layout.context())
        return ctx

    # -- description -------------------------------------------------------------------------
    def describe(self) -> str:
        """Which loop runs, in words (``sol.stats.backend_reason``)."""
        words = self._shared.get("describe")
        if words is None:
            words = self._shared["describe"] = self._description()
        return words

    def _description(self) -> str:
        m = self.method
        if m.family == "rkmk":
            kind = "RKMK (Cayley)" if m.coordinates == "cayley" else "RKMK"
            if self.adaptive:
                kind = "adaptive " + kind + " (whole controller loop)"
            if getattr(m, "keeps_energy", False):
                kind += ", energy kept"
        elif isinstance(m, ExpProductForm):
            kind = "product of exponentials (commutator-free, Crouch–Grossman)"
        elif isinstance(m, MapForm):
            kind = {
                "moser_veselov": "Moser–Veselov map",
                "splitting": "splitting into exact rotations",
                "exact_flow": "exact flow (double-double short steps)",
                "midpoint": "implicit midpoint (fixed-point iteration)",
                "magnus": "Magnus method (the rates sampled at its nodes)",
            }.get(m.family, m.family)
        else:
            kind = "classical RK"
        threads = f"{self.threads} threads" if self.parallel else "serial"
        return f"compiled engine: {self.layout.label}, {kind}, {threads}"

    # -- state -------------------------------------------------------------------------------
    def start(self, y: dict) -> dict:
        """The carry of a run starting at ``y`` (the step check's bound starts afresh)."""
        self._radius2 = 0.0
        return self.internal(y)

    def internal(self, y: dict) -> dict:
        """The form's flat states of the user's state ``y``."""
        return {"Y": np.ascontiguousarray(self.layout.start(y, self.N), dtype=float)}

    @property
    def row_bytes(self) -> int:
        """The bytes of one saved row of the user's state (every field float64, the batch's bodies)."""
        return 8 * self.N * self.layout.count

    @property
    def lanes(self) -> bool:
        return self.layout.in_lanes

    def user_state(self, internal: dict) -> dict:
        return {k: v[0] for k, v in self.layout.user(internal["Y"][None], self.batch).items()}

    def user_rows(self, Y: np.ndarray) -> dict:
        """The user's fields of rows ``(m, N, d)``."""
        return self.layout.user(Y, self.batch)

    def increments(self, U: np.ndarray):
        """The steps' increments ``(m, N, du)`` as elements of the user's algebra: for a product
        of exponentials the log of the product of the exponentials of its step's exponents, the
        numpy path's ``group.log(g₁g₂…)``."""
        if not isinstance(self.method, ExpProductForm):
            return self.layout.increments(U, self.batch)
        blocks = self.method.outputs
        parts = U.reshape(U.shape[:-1] + (blocks, U.shape[-1] // blocks))
        group, g = self.group, None
        for j in range(blocks):
            element = group.exp(self.layout.increments(np.ascontiguousarray(parts[..., j, :]), self.batch))
            g = element if g is None else group.multiply(g, element)
        return group.log(g)

    # -- fixed steps -------------------------------------------------------------------------
    def advance(self, internal: dict, k_from: int, k_to: int, plan, save_steps, project: bool, with_start=False,
                keep=False):  # fmt: skip
        """Steps ``k_from < k ≤ k_to``: the state after them, the user's rows after the steps in
        ``save_steps`` (``with_start``: the starting state's row first) and, with ``keep``, every
        step's flat state and increment (``(k_to − k_from, N, d)``, ``(…, N, du)``) for dense
        output and events (the flat states with the starting one first, ``(k_to − k_from + 1, N, d)``)."""
        Y0 = internal["Y"]
        N, d = Y0.shape
        save_steps = np.ascontiguousarray(save_steps, dtype=np.int64)
        s = 1 if with_start else 0
        out = np.empty((save_steps.size + s, N, d))
        if s:
            out[0] = Y0
        fin, norm2 = np.empty((N, d)), np.empty(N)
        status, evals = np.empty(N, dtype=np.int64), np.zeros(N, dtype=np.int64)  # every count written
        if keep:
            # the kept states with the starting one first (row 0): the observer's table of steps
            # needs both ends of every step, and gets them in one conversion, without a copy
            kept_Y = np.empty((k_to - k_from + 1, N, d))
            kept_Y[0] = Y0
            kept_U = np.empty((k_to - k_from, N, self.du))  # the steps write their increments
            kept = (kept_Y[1:], kept_U)
        else:  # none kept: arrays of no rows (the kernel's types), shared by the runs of this engine
            kept = self._nothing_kept(N, d)
        # a schedule's own step sizes (``plan.sizes``, :class:`lieint.tangent.compiled`'s steps held
        # fixed), else none: the grid's
        sizes = getattr(plan, "sizes", None)
        sizes = _GRID_STEPS if sizes is None else np.ascontiguousarray(sizes, dtype=float)
        grid = (float(plan.h), float(plan.last_step), int(k_from), int(k_to), int(plan.nsteps), bool(project), sizes)
        outs = (out[s:], fin, status, norm2, evals, *kept)
        ctx, tab = self.context, self.tableau
        # a generator of t alone (the Magnus methods' prescribed rates): its values at this call's
        # nodes in the call's parameters; else the layout's
        timed = getattr(self.layout, "call_params", None)
        par = self.layout.params if timed is None else timed(plan, k_from, k_to, tab)
        fixed = self.loops.fixed
        threads = min(self.threads, N)
        if threads > 1:
            # the other ranges on the process's pool, the last in this thread (the kernel releases
            # the GIL); every range is its bodies' alone, so the bits are those of a serial run
            cuts = np.linspace(0, N, threads + 1).astype(np.int64)
            pool = worker_pool(threads - 1)
            jobs = [
                pool.submit(fixed, ctx, (int(cuts[i]), int(cuts[i + 1])), Y0, par, tab, grid, save_steps, outs)
                for i in range(threads - 1)
            ]
            try:
                fixed(ctx, (int(cuts[-2]), N), Y0, par, tab, grid, save_steps, outs)
            finally:
                for job in jobs:
                    job.result()
        else:
            fixed(ctx, (0, N), Y0, par, tab, grid, save_steps, outs)
        # the step check's bound over every state this run has saved (or started a segment from);
        # a non-finite state makes it infinite (the check then looks at the rows themselves)
        # the evaluations the steps report (a map's Newton or fixed-point iterations): the most any
        # body spent, as the numpy path's batch counts an evaluation that moves every member
        if N == 1:  # one unit: its numbers as they are (numpy's reductions cost microseconds a call)
            self.evaluations = max(int(evals[0]), 0)
            largest = float(norm2[0])
            largest = 0.0 if largest < 0.0 else largest  # NaN stays NaN, as in the reduction
            first_bad = int(status[0])
        else:
            self.evaluations = int(evals.max(initial=0))
            largest = float(np.maximum.reduce(norm2, initial=0.0))
            bad = status[status >= 0]
            first_bad = int(bad.min()) if bad.size else -1
        self._radius2 = max(self._radius2, largest) if math.isfinite(largest) else math.inf
        if first_bad >= 0:
            if isinstance(self.method, MapForm):
                raise _unsolved(first_bad, plan, self.method.family)
            raise range_error(first_bad, plan, self.layout.group)
        result = {"Y": fin}, self.user_rows(out)
        if keep:
            return (*result, (kept_Y, kept_U))
        return result

    def _nothing_kept(self, N: int, d: int) -> tuple[np.ndarray, np.ndarray]:
        """The kept states and increments of a call that keeps none: ``(0, N, d)``, ``(0, N, du)``
        (made once per shape; having no entries, they are never written)."""
        key = (N, d)
        cached = self.__dict__.get("_no_rows")
        if cached is None or cached[0] != key:
            cached = (key, (np.empty((0, N, d)), np.empty((0, N, self.du))))
            self._no_rows = cached
        return cached[1]

    def fresh(self) -> Engine:
        """A copy for another run: the layout, numbers and bound loops shared (read-only), the
        per-run state (the step check's bound, the evaluations reported) its own."""
        other = object.__new__(type(self))  # copy.copy's result, without its generic protocol
        other.__dict__.update(self.__dict__)
        other._radius2 = math.inf
        other.__dict__.pop("evaluations", None)
        return other

    @property
    def radius_bound(self) -> float:
        """The largest bound of the ad spectral radius of ξ over every state this run saved or
        started a segment from (the loop's ``radius2``; infinite after a non-finite state)."""
        return math.sqrt(self._radius2) if math.isfinite(self._radius2) else math.inf

    def generator_radius(self, states: dict, limit: float = 0.0) -> float | None:
        """The largest ad spectral radius of ξ(y) over this run's saved states (from the loop's
        bound, ``radius2``), when it is exact or below ``limit`` (π/h: all the step check asks),
        else None (the generic check then evaluates ξ at the rows)."""
        radius = self.radius_bound
        if self.layout.exact_radius and math.isfinite(radius):
            return radius
        return radius if radius < limit else None

    # -- the controller ----------------------------------------------------------------------
    def initial_step(self, y: dict, t0: float, t1: float, controller, error_order: int) -> float:
        """The first trial step's size (:meth:`lieint.control.StepSizeController.initial_step`) with
        the form's compiled vector field, the norms on the user's fields (its Euler step goes
        towards ``t1``: backward in time when ``t1 < t0``)."""
        Yu = self.layout.user_flat(y, self.N)
        tolerances = (float(controller.rtol), float(controller.atol))
        ctx, par, span = self.context, self.layout.params, float(t1 - t0)
        return float(self.loops.first_trial_step(ctx, Yu, par, self.tableau, tolerances, span, int(error_order)))

    def advance_adaptive(self, internal: dict, t, t1, h, k, max_accept, save_every, project, controller, h_min,
                         h_max=math.inf, keep=False, with_start=False):  # fmt: skip
        """Accepted steps from ``(t, h)`` at step ``k`` until ``t1`` (backward in time when ``h`` is
        negative), ``max_accept`` accepted steps or a buffer of rows (:func:`row_capacity`); no
        trial step longer than ``h_max`` (scipy's ``max_step``).

        Returns the new internal state, ``(t, h, k)``, the accepted, rejected and evaluation
        counts, the saved times and user states (``with_start``: the starting state's row
        first), whether the step size fell below ``h_min`` and, with ``keep``, the saved rows'
        flat states and increments."""
        if keep and with_start:
            raise ValueError("`with_start` and `keep` together: the kept rows are the steps' own")
        Y = internal["Y"].copy()
        N, d = Y.shape
        s = int(bool(with_start))
        cap = row_capacity(8 * d * N, max_accept, save_every)
        out_t_all, out_Y_all = np.empty(cap + s), np.empty((cap + s, N, d))
        if s:
            out_t_all[0], out_Y_all[0] = t, Y
        out_t, out_Y = out_t_all[s:], out_Y_all[s:]
        out_U = np.empty((cap if keep else 0, N, self.du))
        control = (
            float(controller.rtol), float(controller.atol), float(controller.safety), float(controller.factor_min),
            float(controller.factor_max), float(h_min), float(N * self.layout.count), float(h_max),
        )  # fmt: skip
        clock = (
            float(t), float(t1), float(h), int(k), int(min(max_accept, _INT64_MAX)), int(save_every),
            bool(project),
        )  # fmt: skip
        status, t, h, k, accepted, rejected, nfev, rows = self.loops.adaptive(
            self.context,
            Y,
            self.layout.params,
            self.tableau,
            self.pair,
            control,
            clock,
            out_t,
            out_Y,
            out_U,
        )
        saved = self.user_rows(out_Y_all[: rows + s])
        result = ({"Y": Y}, (t, h, k), (accepted, rejected, nfev), out_t_all[: rows + s].copy(), saved, status == 1)
        if keep:
            return (*result, (out_Y[:rows], out_U[:rows]))
        return result

    def restep(self, Y: np.ndarray, t: float, tau: float) -> dict:
        """The method's own step of size ``tau`` from the flat states ``Y`` (N, d) at ``t``, in the
        user's fields: an adaptive pair's step taken whatever its error estimate (the tolerances
        at 1e300), as :class:`lieint.dense.Restep` takes it on the generic path — the energy
        pairs' dense output between their steps."""
        huge = _RestepController()
        *_, saved, _ = self.advance_adaptive(
            {"Y": np.ascontiguousarray(Y)}, float(t), float(t + tau), float(tau), 0, 1, 1, False, huge, 0.0
        )
        return {k: v[-1] for k, v in saved.items()}


class _RestepController:
    """The step-size controller of :meth:`Engine.restep`: every trial step is accepted."""

    rtol = atol = 1e300
    safety, factor_min, factor_max = 0.9, 0.2, 10.0


# -- the selector ----------------------------------------------------------------------------------


def _label(system) -> str:
    label = type(system).__name__
    if isinstance(getattr(system, "n", None), int):
        label += f" (n = {system.n})"
    return label


#: the engines of recent runs (:func:`engine_for`): key → (system, method, form, engine)
_ENGINES: OrderedDict = OrderedDict()
#: how many :data:`_ENGINES` holds (each keeps its system and method alive)
ENGINE_CACHE_SIZE = 32
_ENGINES_LOCK = threading.Lock()


def engine_for(
    system, method, y0, adaptive: bool = False, project: bool = True, h: float | None = None
) -> tuple[Engine | None, str]:
    """The compiled engine for this run, or None with the reason none applies (``project``:
    whether the run projects its states; a run that does not compiles no projection; ``h``: the
    fixed step, for a map whose stage code takes only some steps — its module's ``decline``).

    Chosen by what system and method *declare* (``system.compiled()``, ``method.compiled()``),
    never by their class: a system from another package that declares the same form gets the
    same engine.

    The choice takes 25–45 µs of Python; a run of the same system object, method object, batch
    shape and options as one of the last :data:`ENGINE_CACHE_SIZE` runs gets a copy of that
    run's engine instead (its per-run state fresh), provided the system declares the very same
    form object and no stage module looks at the steps (``decline``). The Euler tops cache their
    declaration per inertia operator (a new one is a new form); the heavy top and the balls
    declare a new form at every call (their parameter arrays are writeable), so their engines
    are chosen afresh each run.
    """
    form = system.compiled()
    batch = system.batch_shape(y0) if form is not None else None
    threads = 0
    if batch is not None and math.prod(batch) >= 2:
        import numba

        threads = int(numba.get_num_threads())  # the engine's threads are chosen from it
    key = (id(system), id(method), batch, bool(adaptive), bool(project), threads)
    with _ENGINES_LOCK:  # runs in threads (a threaded sweep) share the cache
        hit = _ENGINES.get(key)
        if hit is not None and hit[0] is system and hit[1] is method and hit[2] is form and form is not None:
            _ENGINES.move_to_end(key)
            return hit[3].fresh(), ""
    engine, reason = _select(system, method, y0, form, adaptive, project, h)
    if engine is not None and engine.cacheable:
        with _ENGINES_LOCK:
            _ENGINES[key] = (system, method, form, engine.fresh())
            while len(_ENGINES) > ENGINE_CACHE_SIZE:
                _ENGINES.popitem(last=False)
    return engine, reason


def _select(system, method, y0, form, adaptive: bool, project: bool, h) -> tuple[Engine | None, str]:
    """:func:`engine_for`'s choice, from the system's declared ``form``."""
    if form is None:
        return None, f"{_label(system)} declares no compiled form"
    meth = method.compiled()
    if meth is None or not isinstance(meth, (RKMKForm, ClassicalForm, MapForm, ExpProductForm)):
        what = "adaptive " if adaptive else ""
        return None, (
            f"{method.name!r} has no compiled {what}form (compiled: RKMK in exp coordinates with truncated dexp⁻¹ "
            "or in Cayley coordinates, their embedded pairs, products of exponentials, classical RK)"
        )
    if adaptive and not (meth.family == "rkmk" and meth.pair):
        return None, f"{method.name!r} has no compiled adaptive form (compiled: RKMK embedded pairs)"
    keeps_energy = getattr(meth, "keeps_energy", False)
    if keeps_energy:
        reason = _energy_reason(form, meth, system, adaptive)
        if reason:
            return None, f"{method.name!r} {reason}"
    batch = system.batch_shape(y0)
    if 0 in batch:
        return None, "the ensemble is empty"
    if keeps_energy and meth.coordinates == "cayley" and isinstance(form, Top3Form):
        form = _as_top_n(form)  # the spin's flow and the reduced stages are the n-D top's energy form's
    generic = getattr(form, "generic", None)
    if isinstance(meth, MapForm) and not meth.covers(form) and generic is not None and meth.covers(generic):
        form = generic  # a map with stage code for compiled pieces only (the midpoint): the tops' pieces
    if meth.coordinates == "cayley" and isinstance(form, Top3Form):
        form = form.generic  # the 3D top's Cayley coordinates: through its compiled pieces
        if form is None:
            return None, "no Cayley form of this 3D top"
    if isinstance(form, Top3Form):
        N = math.prod(batch)
        lanes = not adaptive and meth.family == "rkmk" and N >= Top3LanesLayout.FROM
        if keeps_energy:
            layout = Top3EnergyLayout(form)
        else:
            layout = Top3LanesLayout(form, N) if lanes else Top3Layout(form)
    elif isinstance(form, TopNForm):
        N = math.prod(batch)
        lanes = form.n == 4 and not adaptive and meth.family == "rkmk" and meth.coordinates == "exp"
        if keeps_energy:
            layout = TopNEnergyLayout(form, system)
        else:
            layout = Top4LanesLayout(form, N) if lanes and N >= Top4LanesLayout.FROM else TopNLayout(form)
    elif isinstance(form, PiecesForm) and keeps_energy:
        layout = PiecesEnergyLayout(form, system, True, project)
    elif isinstance(form, PiecesForm):
        N = math.prod(batch)
        lanes = {
            HeavyTop3Form: HeavyTop3LanesLayout, Chaplygin3Form: Chaplygin3LanesLayout,
            RollingBall3Form: RollingBall3LanesLayout,
        }.get(type(form.lanes))  # fmt: skip
        vector = {
            HeavyTop3Form: HeavyTop3Layout, Chaplygin3Form: Chaplygin3Layout, RollingBall3Form: RollingBall3Layout,
        }.get(type(form.lanes))  # fmt: skip
        rkmk_exp = not adaptive and meth.family == "rkmk" and meth.coordinates == "exp"
        if lanes and rkmk_exp and N >= lanes.FROM:
            layout = lanes(form.lanes, N)
        elif vector and rkmk_exp and N == 1 and not project:
            # one body in vectors: its step with no tangent vectors (no projection: a projecting
            # run goes through the pieces, which project R and Γ)
            layout = vector(form.lanes)
        else:
            # the vector field compiles only for the runs that call it: classical RK, the midpoint,
            # an adaptive run's first trial step
            layout = PiecesLayout(form, system, adaptive or meth.family in ("rk", "midpoint"), project)
    elif isinstance(form, PrescribedForm):
        if not (isinstance(meth, MapForm) and meth.family == "magnus"):
            return None, (
                f"{method.name!r} has no compiled form for a prescribed rotation (compiled there: the Magnus "
                "methods, whose steps read the rates at their nodes; the others evaluate them at their stages)"
            )
        layout = PrescribedLayout(form)
    else:
        return None, f"no engine for the compiled form {type(form).__name__}"
    if isinstance(meth, MapForm) and not meth.covers(form):
        return None, f"{method.name!r} has no compiled form for the {layout.label} (it runs on the numpy path)"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", category=_experimental_warning())
        stage_module = meth.module_for(form) if isinstance(meth, MapForm) else ""
        if stage_module:
            import importlib

            decline = getattr(importlib.import_module(stage_module), "decline", None)
            reason = "" if decline is None else decline(layout, layout.start(y0, math.prod(batch)), h)
            if reason:
                return None, reason
        engine = Engine(layout, meth, batch, adaptive, stage_module, system.group)
        # a stage module that declines some steps decides per run (from y0 and h): not cached
        engine.cacheable = not (stage_module and decline is not None)
        return engine, ""


def _as_top_n(form: Top3Form) -> TopNForm:
    """The 3D top as the n-D top's form (eigenvalues ``b = tr(B) − I`` of B, ``tr B = ΣI/2``):
    the energy pairs' Cayley coordinates run there (its pieces, where the plain pairs' Cayley
    coordinates run, have no flow of the spin)."""
    moments = np.asarray(form.moments, dtype=float)
    return TopNForm(0.5 * moments.sum() - moments, form.P, form.orientation, form.generic)


def _energy_reason(form, meth, system, adaptive: bool) -> str:
    """Why an energy-keeping pair does not run compiled on ``form`` ("" when it does): it is
    compiled as an adaptive pair on the tops (the 3D top's Cayley coordinates on the n-D top's
    energy form) and on systems whose compiled pieces declare an energy and whose generator has
    no commuting part."""
    if not adaptive:
        return "has no compiled form for fixed steps (compiled: the adaptive pairs)"
    if isinstance(form, (Top3Form, TopNForm)):
        return ""
    if isinstance(form, PiecesForm):
        pieces = form.pieces.resolve() if hasattr(form.pieces, "resolve") else form.pieces
        if getattr(system, "commuting_generator", None) is not None:
            return f"has no compiled form for {_label(system)}: its generator's commuting part flows on the numpy path"
        if getattr(pieces, "energy", None) is None:
            return f"has no compiled form for {_label(system)}: its compiled pieces declare no energy"
        return ""
    return f"has no compiled form for the compiled form {type(form).__name__}"


def _experimental_warning():
    from numba.core.errors import NumbaExperimentalFeatureWarning

    return NumbaExperimentalFeatureWarning
