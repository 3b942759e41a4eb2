"""The compiled engine's Python side: which form steps a run, the one loop bound to it, and the
conversions between the user's fields and the form's flat state.

:func:`engine_for` matches a system's compiled form (:mod:`lieint.fast.forms`) with a method's
and returns an :class:`Engine` — or None with the reason, which ``sol.stats.backend_reason``
reports. An engine holds a *layout* (how the system's state flattens into the form's vector, in
the form's frame, and back) and the loop of :mod:`lieint.fast.loop` compiled for the form's
stage functions (:func:`bound_loops`: one copy of the loop's source per form and method family,
cached on disk by numba under its own name). The driver (:mod:`lieint.loops`) calls
:meth:`Engine.start`, :meth:`Engine.advance` (fixed steps),
:meth:`Engine.advance_adaptive` (the controller) and :meth:`Engine.user_state`.
"""

from __future__ import annotations

import math
import types
import warnings
from collections import namedtuple
from concurrent.futures import ThreadPoolExecutor
from functools import cache, lru_cache

import numpy as np

from ..groups.base import DexpinvRangeError, bernoulli_dexpinv_coefficients
from .forms import (
    Chaplygin3Form,
    ClassicalForm,
    ExpProductForm,
    HeavyTop3Form,
    MapForm,
    PiecesForm,
    RKMKForm,
    RollingBall3Form,
    Top3Form,
    TopNForm,
)

__all__ = ["Engine", "Products", "Tableau", "bound_loops", "engine_for", "range_error", "use_threads"]

#: a method's numbers as the compiled steps read them (one numba type for every tableau form)
Tableau = namedtuple("Tableau", "A b c coeffs cayley")
#: a product of exponentials' numbers (:class:`lieint.fast.forms.ExpProductForm`; ``cayley`` is
#: False: the observer reads it as a tableau's)
Products = namedtuple("Products", "weights bounds c cayley")

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


# -- layouts: the user's fields <-> a form's flat state ----------------------------------------------


def _increment_blocks(method) -> int:
    """Algebra elements in a step's increment: one (RKMK, a map), the step's exponents (a product
    of exponentials), none (classical RK: dense output interpolates the state arrays)."""
    if isinstance(method, ExpProductForm):
        return method.outputs
    return 1 if method.family == "rkmk" or isinstance(method, MapForm) else 0


class _Layout:
    """How one system form lays out a body's state, and what its loop needs (subclasses)."""

    module: str  # the module of the form's stage functions
    group: str
    d: int  # length of a body's flat state
    count: int  # components of the user's state per body (the error norm's N)
    exact_radius = False  # radius2 is the exact squared ad spectral radius (not a bound)
    in_lanes = False  # a unit of the loop is a block of bodies in SIMD lanes

    def context(self):
        return 0

    def family(self, method) -> str:
        """The family of the form's stage functions that steps ``method``."""
        return method.family

    def increments_size(self, method) -> int:
        """Length of a step's increment (0: none, classical RK)."""
        return 0


class _Top3Layout(_Layout):
    """The 3D top: ``(Π, R P)`` in the principal frame (R = I when the top carries none)."""

    module = "lieint.fast.top3"
    group = "so(3)"
    label = "3D top (principal frame)"
    d = 12
    exact_radius = True

    def __init__(self, form: Top3Form):
        from . import _proper_frame

        self.moments = np.asarray(form.moments, dtype=float)
        self.P, self.identity_frame = _proper_frame(form.P)
        self.orientation = bool(form.orientation)
        self.params = np.concatenate(
            [1.0 / self.moments, self.P.ravel(), [float(self.orientation), float(self.identity_frame)]]
        )
        self.count = 18 if self.orientation else 9

    def start(self, y: dict, N: int) -> np.ndarray:
        from .top3 import minus_vee

        A = y["A"].reshape(N, 3, 3)
        R = y["R"].reshape(N, 3, 3) if self.orientation else np.broadcast_to(np.eye(3), (N, 3, 3))
        if self.identity_frame:
            pi = minus_vee(A)
        else:
            pi, R = minus_vee(self.P.T @ A @ self.P), R @ self.P
        Y = np.empty((N, 12))
        Y[:, :3] = pi
        Y[:, 3:] = R.reshape(N, 9)
        return Y

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        from .top3 import minus_hat

        lead = Y.shape[:-2]
        pi, R = Y[..., :3], Y[..., 3:].reshape(Y.shape[:-1] + (3, 3))
        shape = lead + batch + (3, 3)
        if self.identity_frame:  # the products with I would only turn -0.0 into 0.0
            states = {"A": minus_hat(pi).reshape(shape)}
            if self.orientation:
                states["R"] = np.ascontiguousarray(R).reshape(shape)
            return states
        states = {"A": (self.P @ minus_hat(pi) @ self.P.T).reshape(shape)}
        if self.orientation:
            states["R"] = (R @ self.P.T).reshape(shape)
        return states

    def user_flat(self, y: dict, N: int) -> np.ndarray:
        parts = [y["A"].reshape(N, 9)]
        if self.orientation:
            parts.append(y["R"].reshape(N, 9))
        return np.ascontiguousarray(np.concatenate(parts, axis=1))

    def increments_size(self, method) -> int:
        return 3 * _increment_blocks(method)

    def increments(self, U: np.ndarray, batch: tuple):
        """The steps' increments in the user's so(3): ``(P u)^`` (conjugation by a proper P moves
        the vector of a hat matrix by P)."""
        from ..groups.bivectors import hat

        u = U if self.identity_frame else U @ self.P.T
        return hat(u).reshape(U.shape[:-2] + batch + (3, 3))


class _Top3EnergyLayout(_Top3Layout):
    """The 3D top under an energy-keeping pair: ``(Π, R P, H₀)``, the level every accepted step
    ends on carried as a 13th entry (:mod:`lieint.fast.top3`, family ``rkmk_energy``)."""

    d = 13

    def family(self, method) -> str:
        return "rkmk_energy"

    def start(self, y: dict, N: int) -> np.ndarray:
        Y = super().start(y, N)
        pi, inverse = Y[:, :3], 1.0 / self.moments
        # H₀ = ½ Σ Π_i²/I_i, in the compiled step's order of operations
        p0, p1, p2 = pi[:, 0], pi[:, 1], pi[:, 2]
        level = 0.5 * (inverse[0] * p0 * p0 + inverse[1] * p1 * p1 + inverse[2] * p2 * p2)
        return np.concatenate([Y, level[:, None]], axis=1)

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        return super().user(Y[..., :12], batch)


class _Top3LanesLayout(_Top3Layout):
    """An ensemble of 3D tops in SIMD lanes: blocks of bodies structure-of-arrays (Π rows and
    the attitude as quaternion rows; :mod:`lieint.fast.lanes`). A unit of the loop is a block."""

    in_lanes = True
    module = "lieint.fast.lanes"
    label = "3D top in SIMD lanes (ensemble)"
    #: ensembles of at least this many bodies run RKMK in lanes
    FROM = 64

    def __init__(self, form: Top3Form, N: int):
        super().__init__(form)
        from .lanes import block_lanes

        self.N, self.L = N, block_lanes(N)
        self.d = 7 * (self.L + 8)
        self.units = -(-N // self.L)

    def start(self, y: dict, N: int) -> np.ndarray:
        from .lanes import blocks_from_state
        from .quaternions import lanes_from_matrices

        Y = super().start(y, N)
        return blocks_from_state(Y[:, :3], lanes_from_matrices(Y[:, 3:].reshape(N, 3, 3)), N)

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        from .lanes import blocks_to_user

        lead = Y.shape[:-2]
        A, R = blocks_to_user(Y, self.N, self.P, self.identity_frame, self.orientation)
        states = {"A": A.reshape(lead + batch + (3, 3))}
        if self.orientation:
            states["R"] = R.reshape(lead + batch + (3, 3))
        return states

    def increments_size(self, method) -> int:
        return 3 * (self.L + 8)

    def increments(self, U: np.ndarray, batch: tuple):
        from ..groups.bivectors import hat
        from .lanes import increments_to_user

        u = increments_to_user(U, self.N, self.P, self.identity_frame)
        return hat(u).reshape(U.shape[:-2] + batch + (3, 3))


class _HeavyTop3LanesLayout(_Top3Layout):
    """An ensemble of 3D heavy tops in SIMD lanes (:mod:`lieint.fast.heavy_lanes`): blocks of
    bodies structure-of-arrays in the principal frame of the top (Π, the attitude as quaternion
    rows, Γ). A unit of the loop is a block."""

    in_lanes = True
    module = "lieint.fast.heavy_lanes"
    group = "se(3)"
    label = "3D heavy top in SIMD lanes (ensemble)"
    #: ensembles of at least this many bodies run RKMK in lanes (measured: 2 bodies in a block of
    #: 8 lanes already cost less than two bodies on the per-body path; benchmarks/ensembles.py)
    FROM = 2

    def __init__(self, form: HeavyTop3Form, N: int):
        super().__init__(form)
        from .heavy_lanes import ROWS
        from .lanes import block_lanes

        self.MXG = np.asarray(form.MXG, dtype=float)
        self.params = np.concatenate([1.0 / self.moments, self.P.T @ self.MXG, [float(form.gravity)]])
        self.count = 12 + (9 if self.orientation else 0)
        self.N, self.L = N, block_lanes(N)
        self.d = ROWS * (self.L + 8)
        self.units = -(-N // self.L)

    def start(self, y: dict, N: int) -> np.ndarray:
        from .heavy_lanes import blocks_from_state
        from .quaternions import lanes_from_matrices

        Y = super().start(y, N)  # Π and R P in the principal frame
        gamma = y["Gamma"].reshape(N, 3)
        if not self.identity_frame:
            gamma = gamma @ self.P
        return blocks_from_state(Y[:, :3], lanes_from_matrices(Y[:, 3:].reshape(N, 3, 3)), gamma, N)

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        from .heavy_lanes import blocks_to_user

        lead = Y.shape[:-2]
        A, G, R = blocks_to_user(Y, self.N, self.P, self.identity_frame, self.orientation)
        states = {"A": A.reshape(lead + batch + (3, 3)), "Gamma": G.reshape(lead + batch + (3,))}
        if self.orientation:
            states["R"] = R.reshape(lead + batch + (3, 3))
        return states

    def user_flat(self, y: dict, N: int) -> np.ndarray:
        parts = [y["A"].reshape(N, 9), y["Gamma"].reshape(N, 3)]
        if self.orientation:
            parts.append(y["R"].reshape(N, 9))
        return np.ascontiguousarray(np.concatenate(parts, axis=1))

    def increments_size(self, method) -> int:
        from .heavy_lanes import INCREMENT_ROWS

        return INCREMENT_ROWS * (self.L + 8)

    def increments(self, U: np.ndarray, batch: tuple):
        """The steps' increments in the user's se(3), ``[[(P u_w)^, P u_v], [0, 0]]``."""
        from ..groups.bivectors import hat
        from ..groups.se import se_join
        from .heavy_lanes import increments_to_user

        w, v = increments_to_user(U, self.N, self.P, self.identity_frame)
        return se_join(hat(w), v, algebra=True).reshape(U.shape[:-2] + batch + (4, 4))


class _Chaplygin3LanesLayout(_Layout):
    """An ensemble of 3D Chaplygin balls in SIMD lanes (:mod:`lieint.fast.chaplygin_lanes`):
    blocks of bodies structure-of-arrays in the user's frame (Π, the attitude as quaternion rows,
    Γ, the centre). A unit of the loop is a block."""

    in_lanes = True
    module = "lieint.fast.chaplygin_lanes"
    label = "3D Chaplygin ball in SIMD lanes (ensemble)"
    exact_radius = True
    #: ensembles of at least this many bodies run RKMK in lanes (benchmarks/ensembles.py)
    FROM = 2

    def __init__(self, form: Chaplygin3Form, N: int):
        from .chaplygin_lanes import ROWS
        from .lanes import block_lanes

        B = np.asarray(form.B_C, dtype=float)
        J = np.trace(B) * np.eye(3) - B
        normal = np.asarray(form.normal, dtype=float)
        self.orientation, self.center = bool(form.orientation), bool(form.center)
        self.params = np.concatenate([J.ravel(), [form.Mr2, form.radius], normal, [float(self.center)]])
        self.group = "se(3)" if self.center else "so(3)"
        self.count = 12 + (9 if self.orientation else 0) + (3 if self.center else 0)
        self.N, self.L = N, block_lanes(N)
        self.d = ROWS * (self.L + 8)
        self.units = -(-N // self.L)

    def start(self, y: dict, N: int) -> np.ndarray:
        from .chaplygin_lanes import blocks_from_state
        from .quaternions import lanes_from_matrices
        from .top3 import minus_vee

        R = y["R"].reshape(N, 3, 3) if self.orientation else np.broadcast_to(np.eye(3), (N, 3, 3))
        center = y["center"].reshape(N, 3) if self.center else np.zeros((N, 3))
        pi = minus_vee(y["A"].reshape(N, 3, 3))
        return blocks_from_state(pi, lanes_from_matrices(R), y["Gamma"].reshape(N, 3), center, N)

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        from .chaplygin_lanes import blocks_to_user

        lead = Y.shape[:-2]
        A, G, R, C = blocks_to_user(Y, self.N, self.orientation, self.center)
        states = {"A": A.reshape(lead + batch + (3, 3)), "Gamma": G.reshape(lead + batch + (3,))}
        if self.orientation:
            states["R"] = R.reshape(lead + batch + (3, 3))
        if self.center:
            states["center"] = C.reshape(lead + batch + (3,))
        return states

    def user_flat(self, y: dict, N: int) -> np.ndarray:
        names = ["A", "Gamma"] + (["R"] if self.orientation else []) + (["center"] if self.center else [])
        return np.ascontiguousarray(np.concatenate([y[k].reshape(N, -1) for k in names], axis=1))

    def increments_size(self, method) -> int:
        from .heavy_lanes import INCREMENT_ROWS

        return INCREMENT_ROWS * (self.L + 8)

    def increments(self, U: np.ndarray, batch: tuple):
        """The steps' increments in the ball's algebra: ``[[û_w, u_v], [0, 0]]`` on se(3), ``û_w``
        on so(3) (without the centre)."""
        from ..groups.bivectors import hat
        from ..groups.se import se_join
        from .chaplygin_lanes import increments_to_user

        w, v = increments_to_user(U, self.N)
        lead = U.shape[:-2] + batch
        if not self.center:
            return hat(w).reshape(lead + (3, 3))
        return se_join(hat(w), v, algebra=True).reshape(lead + (4, 4))


class _RollingBall3LanesLayout(_Layout):
    """An ensemble of 3D rolling balls in SIMD lanes (:mod:`lieint.fast.rolling_lanes`): blocks of
    bodies structure-of-arrays in the user's frame (ω, the attitude as quaternion rows, Γ, the
    centre, G). A unit of the loop is a block."""

    in_lanes = True
    module = "lieint.fast.rolling_lanes"
    label = "3D rolling ball in SIMD lanes (ensemble)"
    exact_radius = True
    #: ensembles of at least this many bodies run RKMK in lanes (benchmarks/ensembles.py)
    FROM = 2

    def __init__(self, form: RollingBall3Form, N: int):
        from .lanes import block_lanes
        from .rolling_lanes import PARAMS, ROWS

        B = np.asarray(form.B_C, dtype=float)
        J = np.trace(B) * np.eye(3) - B
        self.orientation, self.center, self.tilted = bool(form.orientation), bool(form.center), form.mode == 2
        self.params = np.concatenate(
            [J.ravel(), [form.mass, form.radius], np.asarray(form.normal, dtype=float), [float(self.center)],
             [float(form.mode), form.g_normal, form.g_norm], np.asarray(form.center_of_mass, dtype=float)]
        )  # fmt: skip
        assert self.params.size == PARAMS
        self.group = "se(3)" if self.center else "so(3)"
        # the ball's fields in its state's order (lieint.RollingBall): Ω, Γ, G on an incline, R, the centre
        self.fields = ["Omega", "Gamma"] + ["G"] * self.tilted + ["R"] * self.orientation + ["center"] * self.center
        self.count = 12 + (3 if self.tilted else 0) + (9 if self.orientation else 0) + (3 if self.center else 0)
        self.N, self.L = N, block_lanes(N)
        self.d = ROWS * (self.L + 8)
        self.units = -(-N // self.L)

    def start(self, y: dict, N: int) -> np.ndarray:
        from .quaternions import lanes_from_matrices
        from .rolling_lanes import blocks_from_state

        W = y["Omega"].reshape(N, 3, 3)
        omega = 0.5 * np.stack([W[:, 2, 1] - W[:, 1, 2], W[:, 0, 2] - W[:, 2, 0], W[:, 1, 0] - W[:, 0, 1]], axis=1)
        R = y["R"].reshape(N, 3, 3) if self.orientation else np.broadcast_to(np.eye(3), (N, 3, 3))
        center = y["center"].reshape(N, 3) if self.center else np.zeros((N, 3))
        G = y["G"].reshape(N, 3) if self.tilted else np.zeros((N, 3))
        return blocks_from_state(omega, lanes_from_matrices(R), y["Gamma"].reshape(N, 3), center, G, N)

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        from ..groups.bivectors import hat
        from .quaternions import matrices_from_lanes
        from .rolling_lanes import blocks_to_rows

        lead = Y.shape[:-2]
        X = blocks_to_rows(Y, self.N)
        states = {"Omega": hat(X[..., :3]).reshape(lead + batch + (3, 3))}
        states["Gamma"] = X[..., 7:10].reshape(lead + batch + (3,))
        if self.tilted:
            states["G"] = X[..., 13:16].reshape(lead + batch + (3,))
        if self.orientation:
            R = matrices_from_lanes(np.swapaxes(X[..., 3:7], 1, 2))
            states["R"] = R.reshape(lead + batch + (3, 3))
        if self.center:
            states["center"] = X[..., 10:13].reshape(lead + batch + (3,))
        return {name: np.ascontiguousarray(states[name]) for name in self.fields}

    def user_flat(self, y: dict, N: int) -> np.ndarray:
        return np.ascontiguousarray(np.concatenate([y[k].reshape(N, -1) for k in self.fields], axis=1))

    def increments_size(self, method) -> int:
        from .rolling_lanes import STEP_ROWS

        return STEP_ROWS * (self.L + 8)

    def increments(self, U: np.ndarray, batch: tuple):
        """The steps' increments in the ball's algebra ``se(3) × so(3)`` (``so(3) × so(3)`` without
        the centre): ``([[û_w, u_v], [0, 0]], δ̂)``."""
        from ..groups.bivectors import hat
        from ..groups.se import se_join
        from .rolling_lanes import increments_to_user

        w, v, delta = increments_to_user(U, self.N)
        lead = U.shape[:-2] + batch
        W, D = hat(w).reshape(lead + (3, 3)), hat(delta).reshape(lead + (3, 3))
        pose = se_join(W, v.reshape(lead + (3,)), algebra=True) if self.center else W
        return pose, D


class _TopNLayout(_Layout):
    """The Euler top in n ≥ 4 dimensions: ``(Ã, R̃) = (PᵀAP, RP)`` in the principal frame."""

    module = "lieint.fast.topn"

    def __init__(self, form: TopNForm):
        from . import _proper_frame
        from .topn import inertia_factors_of

        self.n = n = form.n
        self.b = np.asarray(form.b, dtype=float)
        P, self.identity_frame = _proper_frame(form.P)
        self.P = np.array(P)
        self.orientation = bool(form.orientation)
        self.r = n if self.orientation else 0
        self.M = inertia_factors_of(self.b.tobytes())
        head = [n, self.r, float(self.identity_frame)]
        self.params = np.concatenate([head, self.M.ravel(), self.P.ravel()])
        self.d = n * n + self.r * self.r
        self.count = self.d
        self.group = f"so({n})"
        self.label = f"{n}D top (principal frame)"

    def start(self, y: dict, N: int) -> np.ndarray:
        from .principal import to_principal

        n = self.n
        A = y["A"].reshape(N, n, n)
        R = y["R"].reshape(N, n, n) if self.orientation else None
        if self.identity_frame:
            A = 0.5 * (A - np.swapaxes(A, -1, -2))  # exactly skew (the identity on a skew A)
        else:
            A, R = to_principal(A, R, self.P)
        Y = np.empty((N, n * n + self.r * self.r))  # the fields (an energy pair's level is added after)
        Y[:, : n * n] = A.reshape(N, n * n)
        if self.orientation:
            Y[:, n * n :] = R.reshape(N, n * n)
        return Y

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        from .principal import to_user

        n, lead = self.n, Y.shape[:-2]
        A = Y[..., : n * n].reshape(-1, n, n)
        R = Y[..., n * n :].reshape(-1, n, n) if self.orientation else None
        if not self.identity_frame:
            A, R = to_user(A, R, self.P)
        states = {"A": np.ascontiguousarray(A).reshape(lead + batch + (n, n))}
        if self.orientation:
            states["R"] = np.ascontiguousarray(R).reshape(lead + batch + (n, n))
        return states

    def user_flat(self, y: dict, N: int) -> np.ndarray:
        n = self.n
        parts = [y["A"].reshape(N, n * n)]
        if self.orientation:
            parts.append(y["R"].reshape(N, n * n))
        return np.ascontiguousarray(np.concatenate(parts, axis=1))

    def increments_size(self, method) -> int:
        return self.n * self.n * _increment_blocks(method)

    def increments(self, U: np.ndarray, batch: tuple):
        n = self.n
        u = U.reshape(U.shape[:-1] + (n, n))
        if not self.identity_frame:
            u = self.P @ u @ self.P.T
        return u.reshape(U.shape[:-2] + batch + (n, n))


class _Top4LanesLayout(_TopNLayout):
    """An ensemble of 4D tops in SIMD lanes (:mod:`lieint.fast.top4_lanes`): blocks of bodies
    structure-of-arrays in the principal frame, the momentum in the coordinates of
    so(3) ⊕ so(3) and the attitude as a pair of unit quaternions. A unit of the loop is a block."""

    in_lanes = True
    module = "lieint.fast.top4_lanes"
    exact_radius = True
    #: ensembles of at least this many bodies run RKMK in lanes (benchmarks/ensembles.py)
    FROM = 2

    def __init__(self, form: TopNForm, N: int):
        from .lanes import block_lanes
        from .top4_lanes import ROWS, generator_matrix

        super().__init__(form)
        self.params = np.ascontiguousarray(generator_matrix(self.M).ravel())
        self.label = "4D top in SIMD lanes (ensemble)"
        self.N, self.L = N, block_lanes(N)
        self.d = ROWS * (self.L + 8)  # count stays the user's components
        self.units = -(-N // self.L)

    def start(self, y: dict, N: int) -> np.ndarray:
        from .top4_lanes import blocks_from_state

        Y = super().start(y, N)
        R = Y[:, 16:].reshape(N, 4, 4) if self.orientation else np.broadcast_to(np.eye(4), (N, 4, 4))
        return blocks_from_state(Y[:, :16].reshape(N, 4, 4), R, N)

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        from .top4_lanes import blocks_to_principal

        A, R = blocks_to_principal(Y, self.N)
        parts = [A.reshape(A.shape[:2] + (16,))] + ([R.reshape(R.shape[:2] + (16,))] if self.orientation else [])
        flat = np.concatenate(parts, axis=-1).reshape(Y.shape[:-2] + (self.N, 16 + self.r * self.r))
        return super().user(flat, batch)

    def increments_size(self, method) -> int:
        from .top4_lanes import INCREMENT_ROWS

        return INCREMENT_ROWS * (self.L + 8)

    def increments(self, U: np.ndarray, batch: tuple):
        from .top4_lanes import increments_to_principal

        u = increments_to_principal(U, self.N)
        return super().increments(u.reshape(U.shape[:-2] + (self.N, 16)), batch)


class _TopNEnergyLayout(_TopNLayout):
    """The n-D top under an energy-keeping pair: ``(Ã, R̃)``, then the level H₀ every accepted
    step ends on (:mod:`lieint.fast.topn_energy`)."""

    module = "lieint.fast.topn_energy"

    def __init__(self, form: TopNForm, system):
        super().__init__(form)
        self.system = system
        self.fields_size = self.d
        self.d = self.fields_size + 1  # count stays the fields' components: the level is no user's

    def family(self, method) -> str:
        return "rkmk_energy"

    def start(self, y: dict, N: int) -> np.ndarray:
        # H₀ as the generic path takes it (the system's own energy): the level both paths aim at
        level = np.asarray(self.system.invariants["energy"](0.0, y), dtype=float).reshape(N, 1)
        return np.concatenate([super().start(y, N), level], axis=1)

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        return super().user(Y[..., : self.fields_size], batch)


class _PiecesLayout(_Layout):
    """A system through compiled pieces: its fields flattened one after another, user's frame."""

    module = "lieint.fast.generic"

    def __init__(self, form: PiecesForm, system, needs_field: bool = True, needs_projection: bool = True):
        from .pieces import CompiledPieces

        pieces = form.pieces.resolve() if hasattr(form.pieces, "resolve") else form.pieces
        if not isinstance(pieces, CompiledPieces):
            raise TypeError(f"`pieces` of a compiled form must be CompiledPieces; got {type(pieces).__name__}.")
        self.pieces, self.system = pieces, system
        self.params = np.require(form.params, float, ["C", "W"])
        self.n, self.translation, self.m = int(form.n), bool(form.translation), int(form.abelian)
        self.nv = self.n if self.translation else 0
        self.fields = {name: tuple(shape) for name, shape in form.fields.items()}
        self.sizes = [math.prod(shape) for shape in self.fields.values()]
        self.d = self.count = sum(self.sizes)
        self.group = form.group
        self.label = f"compiled pieces on {form.group}"
        self.work = pieces.work_size(self.n)
        self.needs_field, self.needs_projection = needs_field, needs_projection

    def family(self, method) -> str:
        """RKMK in Cayley coordinates, or in exponential coordinates at n = 3, steps through a
        copy of the stage code without reference counts, one per coordinates (each its own
        family: a run compiles the one it uses, and the coordinates are the copy's compile-time
        constant, :mod:`lieint.fast.generic_step`)."""
        if method.family == "rkmk" and method.coordinates == "cayley":
            return "rkmk_cayley"
        if method.family == "rkmk" and self.n == 3:
            return "rkmk_uncounted"
        return method.family

    def context(self):
        bundle = self.pieces.bundle_for(self.needs_field, self.needs_projection)
        return (bundle, np.array([self.n, self.nv, self.m, self.work], dtype=np.int64))

    def start(self, y: dict, N: int) -> np.ndarray:
        return np.concatenate([np.asarray(y[name], dtype=float).reshape(N, -1) for name in self.fields], axis=1)

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        lead = Y.shape[:-2]
        states, start = {}, 0
        for (name, shape), size in zip(self.fields.items(), self.sizes, strict=True):
            states[name] = Y[..., start : start + size].reshape(lead + batch + shape)
            start += size
        return states

    def user_flat(self, y: dict, N: int) -> np.ndarray:
        return np.ascontiguousarray(self.start(y, N))

    def increments_size(self, method) -> int:
        return (self.n * self.n + self.nv + self.m) * _increment_blocks(method)

    def increments(self, U: np.ndarray, batch: tuple):
        """The steps' increments as elements of the system's algebra (a skew matrix on so(n),
        a homogeneous matrix on se(n), tuples over a product with vector factors)."""
        n, nv, lead = self.n, self.nv, U.shape[:-2] + batch
        W = U[..., : n * n].reshape(lead + (n, n))
        v = U[..., n * n : n * n + nv].reshape(lead + (nv,))
        a = U[..., n * n + nv :].reshape(lead + (self.m,))
        return _algebra_element(self.system.group, W, v, a)


class _PiecesEnergyLayout(_PiecesLayout):
    """A system through compiled pieces under an energy-keeping pair: its fields, then the level
    H₀ every accepted step ends on (:mod:`lieint.fast.generic_energy`); the context carries the
    orbit's basis and the group elements of its central differences."""

    module = "lieint.fast.generic_energy"

    def __init__(self, form: PiecesForm, system, needs_field: bool = True, needs_projection: bool = True):
        super().__init__(form, system, needs_field, needs_projection)
        self.fields_size = self.d
        self.d = self.fields_size + 1  # count stays the fields' components: the level is no user's
        self.orbit = _orbit_numbers(_vector_factors(system.group), self.n, self.nv, self.m)
        self.dim = _orbit_dimension(self.n, self.nv, self.m, self.orbit.size)

    def family(self, method) -> str:
        plain = super().family(method)  # the plain form's copy the pair's step goes through
        copies = {"rkmk_uncounted": "rkmk_energy_uncounted", "rkmk_cayley": "rkmk_energy_cayley"}
        return copies.get(plain, "rkmk_energy")

    def context(self):
        bundle = self.pieces.bundle_for(self.needs_field, self.needs_projection, energy=True)
        dims = np.array([self.n, self.nv, self.m, self.work, self.dim], dtype=np.int64)
        return (bundle, dims, self.orbit)

    def start(self, y: dict, N: int) -> np.ndarray:
        # H₀ as the generic path takes it (the system's own energy): the level both paths aim at
        level = np.asarray(self.system.invariants["energy"](0.0, y), dtype=float).reshape(N, 1)
        return np.concatenate([super().start(y, N), level], axis=1)

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        return super().user(Y[..., : self.fields_size], batch)

    def user_flat(self, y: dict, N: int) -> np.ndarray:
        return np.ascontiguousarray(super().start(y, N))


def _skew_basis(n: int) -> np.ndarray:
    """``E_kj − E_jk`` for j < k (the generic path's basis of so(n), in its order)."""
    pairs = [(j, k) for j in range(n) for k in range(j + 1, n)]
    out = np.zeros((len(pairs), n, n))
    for i, (j, k) in enumerate(pairs):
        out[i, j, k], out[i, k, j] = -1.0, 1.0
    return out


def _vector_factors(group) -> tuple:
    """``(shape, antisymmetric)`` of each vector factor of ``group`` after its pose (none for
    SO(n) or SE(n) alone): what the orbit basis of the compiled pieces depends on, hashable."""
    from ..groups.vector import ProductGroup

    factors = group.factors[1:] if isinstance(group, ProductGroup) else ()
    return tuple((tuple(f.shape), bool(getattr(f, "antisymmetric", False))) for f in factors)


def _orbit_dimension(n: int, nv: int, m: int, size: int) -> int:
    """dim 𝔤 from the length of the flat orbit numbers (9 blocks of dim elements each)."""
    per = 3 * (n * n + nv + m)
    return size // per


@lru_cache(maxsize=64)
def _orbit_numbers(factors: tuple, n: int, nv: int, m: int) -> np.ndarray:
    """The basis of the algebra of ``SO(n)/SE(n) × Rᵐ`` as the compiled pieces lay it out,
    ``(W, v, a)`` per element (the generic path's basis and order: the rotations, the
    translations, each vector factor's unit vectors or, for a factor of skew matrices, its skew
    basis), and the group elements ``exp(±ε e_i)`` as ``(Q, t, a)``, stacked ``(2, dim, …)``,
    in one flat array, kept per layout and never written (:func:`lieint.fast.generic_energy._orbit`
    reads it; writable, as the compiled pieces' signatures take their arrays); ``factors`` as
    :func:`_vector_factors` gives them."""
    from .generic_energy import EPSILON

    rotations = _skew_basis(n)
    parts = []  # the vector factor's basis elements, flat in a
    start = 0
    for shape, antisymmetric in factors:
        size = int(np.prod(shape))
        if antisymmetric:
            block = _skew_basis(shape[0]).reshape(-1, size)
        else:
            block = np.eye(size)
        for row in block:
            element = np.zeros(m)
            element[start : start + size] = row
            parts.append(element)
        start += size
    if start != m:
        raise TypeError(f"the compiled pieces' vector factor has {m} entries; the group's vector factors {start}")
    dim = len(rotations) + nv + len(parts)
    W, v, a = np.zeros((dim, n, n)), np.zeros((dim, nv)), np.zeros((dim, m))
    W[: len(rotations)] = rotations
    for i in range(nv):
        v[len(rotations) + i, i] = 1.0
    for i, element in enumerate(parts):
        a[len(rotations) + nv + i] = element
    # exp(±ε e_i): a plane rotation, a unit translation (φ₁(0) = I), a vector's shift
    Q = np.broadcast_to(np.eye(n), (2, dim, n, n)).copy()
    c, sn = np.cos(EPSILON), np.sin(EPSILON)
    for i in range(len(rotations)):
        j, k = np.argwhere(rotations[i] == 1.0)[0][::-1]  # e_i = E_kj − E_jk
        for sign, side in ((1.0, 0), (-1.0, 1)):
            Q[side, i, j, j] = Q[side, i, k, k] = c
            Q[side, i, k, j], Q[side, i, j, k] = sign * sn, -sign * sn
    t = np.stack([EPSILON * v, -EPSILON * v])
    shift = np.stack([EPSILON * a, -EPSILON * a])
    return np.concatenate([part.ravel() for part in (W, v, a, Q, t, shift)])


def orbit_parts(flat: np.ndarray, n: int, nv: int, m: int) -> tuple:
    """``(W, v, a, Q, t, a±)`` of :func:`_orbit_numbers`' flat array, as the compiled side reads
    it (the tests compare them with the generic path's basis)."""
    dim = _orbit_dimension(n, nv, m, flat.size)
    shapes = ((dim, n, n), (dim, nv), (dim, m), (2, dim, n, n), (2, dim, nv), (2, dim, m))
    out, start = [], 0
    for shape in shapes:
        size = math.prod(shape)
        out.append(flat[start : start + size].reshape(shape))
        start += size
    return tuple(out)


def _algebra_element(group, W, v, a):
    """``(W, v, a)`` of the flat increment as an element of ``group``'s algebra."""
    from ..groups.se import SE, se_join
    from ..groups.so import SO
    from ..groups.vector import ProductGroup

    if isinstance(group, SE):
        return se_join(W, v, algebra=True)
    if isinstance(group, SO):
        return W
    if isinstance(group, ProductGroup):
        first, rest = group.factors[0], group.factors[1:]
        parts, start = [_algebra_element(first, W, v, a[..., :0])], 0
        for factor in rest:
            size = int(np.prod(factor.shape))
            parts.append(a[..., start : start + size].reshape(a.shape[:-1] + tuple(factor.shape)))
            start += size
        return tuple(parts)
    raise TypeError(f"no algebra element of {group!r} from a compiled increment")


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

    def __init__(self, layout: _Layout, method, batch: tuple[int, ...], adaptive: bool, stage_module: str = "",
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

    # -- description -------------------------------------------------------------------------
    def describe(self) -> str:
        """Which loop runs, in words (``sol.stats.backend_reason``)."""
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
        s = int(bool(with_start))
        out = np.empty((save_steps.size + s, N, d))
        if s:
            out[0] = Y0
        fin = np.empty((N, d))
        status = np.empty(N, dtype=np.int64)
        norm2 = np.empty(N)
        evals = np.empty(N, dtype=np.int64)
        steps = k_to - k_from if keep else 0
        # the kept states with the starting one first (row 0): the observer's table of steps
        # needs both ends of every step, and gets them in one conversion, without a copy
        kept_Y = np.empty((steps + 1, N, d))
        kept_Y[0] = Y0
        kept_U = np.empty((steps, N, self.du))  # the steps write their increments: its length always
        grid = (float(plan.h), float(plan.last_step), int(k_from), int(k_to), int(plan.nsteps), bool(project))
        outs = (out[s:], fin, status, norm2, evals, kept_Y[1:], kept_U)
        ctx, par, tab = self.layout.context(), self.layout.params, self.tableau
        fixed = self.loops.fixed
        threads = min(self.threads, N)
        if threads > 1:
            cuts = np.linspace(0, N, threads + 1).astype(np.int64)
            with ThreadPoolExecutor(threads) as pool:
                jobs = [
                    pool.submit(fixed, ctx, (int(cuts[i]), int(cuts[i + 1])), Y0, par, tab, grid, save_steps, outs)
                    for i in range(threads)
                ]
                for job in jobs:
                    job.result()
        else:
            fixed(ctx, (0, N), Y0, par, tab, grid, save_steps, outs)
        # the step check's bound over every state this run has saved (or started a segment from);
        # a non-finite state makes it infinite (the check then looks at the rows themselves)
        largest = float(np.maximum.reduce(norm2, initial=0.0))
        self._radius2 = max(self._radius2, largest) if math.isfinite(largest) else math.inf
        bad = status[status >= 0]
        if bad.size:
            if isinstance(self.method, MapForm):
                raise _unsolved(int(bad.min()), plan, self.method.family)
            raise range_error(int(bad.min()), plan, self.layout.group)
        result = {"Y": fin}, self.user_rows(out)
        if keep:
            return (*result, (kept_Y, kept_U))
        return result

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
        ctx, par, span = self.layout.context(), self.layout.params, float(t1 - t0)
        return float(self.loops.first_trial_step(ctx, Yu, par, self.tableau, tolerances, span, int(error_order)))

    def advance_adaptive(self, internal: dict, t, t1, h, k, max_accept, save_every, project, controller, h_min,
                         h_max=math.inf, keep=False):  # fmt: skip
        """Accepted steps from ``(t, h)`` at step ``k`` until ``t1`` (backward in time when ``h`` is
        negative), ``max_accept`` accepted steps or a buffer of rows (:func:`row_capacity`); no
        trial step longer than ``h_max`` (scipy's ``max_step``).

        Returns the new internal state, ``(t, h, k)``, the accepted, rejected and evaluation
        counts, the saved times and user states, whether the step size fell below ``h_min`` and,
        with ``keep``, the saved rows' flat states and increments."""
        Y = internal["Y"].copy()
        N, d = Y.shape
        cap = row_capacity(8 * d * N, max_accept, save_every)
        out_t, out_Y = np.empty(cap), np.empty((cap, N, d))
        out_U = np.empty((cap if keep else 0, N, self.du))
        control = (
            float(controller.rtol), float(controller.atol), float(controller.safety), float(controller.factor_min),
            float(controller.factor_max), float(h_min), float(N * self.layout.count), float(h_max),
        )  # fmt: skip
        clock = (
            float(t), float(t1), float(h), int(k), int(min(max_accept, np.iinfo(np.int64).max)), int(save_every),
            bool(project),
        )  # fmt: skip
        status, t, h, k, accepted, rejected, nfev, rows = self.loops.adaptive(
            self.layout.context(), Y, self.layout.params, self.tableau, self.pair, control, clock, out_t, out_Y, out_U
        )
        saved = self.user_rows(out_Y[:rows])
        result = ({"Y": Y}, (t, h, k), (accepted, rejected, nfev), out_t[:rows].copy(), saved, status == 1)
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


def engine_for(
    system, method, y0, adaptive: bool = False, project: bool = True, h: float | None = None
) -> tuple[Engine | None, str]:
    """The compiled engine for this run, or None with the reason none applies (``project``:
    whether the run projects its states; a run that does not compiles no projection; ``h``: the
    fixed step, for a map whose stage code takes only some steps — its module's ``decline``).

    Chosen by what system and method *declare* (``system.compiled()``, ``method.compiled()``),
    never by their class: a system from another package that declares the same form gets the
    same engine.
    """
    form = system.compiled()
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
        lanes = not adaptive and meth.family == "rkmk" and N >= _Top3LanesLayout.FROM
        if keeps_energy:
            layout = _Top3EnergyLayout(form)
        else:
            layout = _Top3LanesLayout(form, N) if lanes else _Top3Layout(form)
    elif isinstance(form, TopNForm):
        N = math.prod(batch)
        lanes = form.n == 4 and not adaptive and meth.family == "rkmk" and meth.coordinates == "exp"
        if keeps_energy:
            layout = _TopNEnergyLayout(form, system)
        else:
            layout = _Top4LanesLayout(form, N) if lanes and N >= _Top4LanesLayout.FROM else _TopNLayout(form)
    elif isinstance(form, PiecesForm) and keeps_energy:
        layout = _PiecesEnergyLayout(form, system, True, project)
    elif isinstance(form, PiecesForm):
        N = math.prod(batch)
        lanes = {
            HeavyTop3Form: _HeavyTop3LanesLayout, Chaplygin3Form: _Chaplygin3LanesLayout,
            RollingBall3Form: _RollingBall3LanesLayout,
        }.get(type(form.lanes))  # fmt: skip
        if lanes and not adaptive and meth.family == "rkmk" and meth.coordinates == "exp" and N >= lanes.FROM:
            layout = lanes(form.lanes, N)
        else:
            # the vector field compiles only for the runs that call it: classical RK, the midpoint,
            # an adaptive run's first trial step
            layout = _PiecesLayout(form, system, adaptive or meth.family in ("rk", "midpoint"), project)
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
        return Engine(layout, meth, batch, adaptive, stage_module, system.group), ""


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
