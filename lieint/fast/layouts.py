"""Layouts: how a system's state flattens into a compiled form's vector and back.

A layout turns the user's fields (a dict of arrays over a batch) into the flat states a form of
the one compiled loop steps (:mod:`lieint.fast.loop`) — in the form's own frame: the principal
frame of the tops, structure-of-arrays blocks of bodies in SIMD lanes, the fields one after
another for compiled pieces — and the rows and increments a run keeps back into the user's fields
and algebra elements. It also says which module's stage functions step the form (``module``), the
form's parameters (``params``), the components of the user's state (``count``, the error norm's
N) and whether its ``radius2`` is exact. :func:`lieint.fast.engine.engine_for` picks one.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from .forms import (
    Chaplygin3Form,
    ExpProductForm,
    HeavyTop3Form,
    MapForm,
    PiecesForm,
    PrescribedForm,
    RollingBall3Form,
    Top3Form,
    TopNForm,
)

__all__ = [
    "Chaplygin3LanesLayout",
    "HeavyTop3LanesLayout",
    "Layout",
    "PiecesEnergyLayout",
    "PiecesLayout",
    "PrescribedLayout",
    "RollingBall3LanesLayout",
    "Top3EnergyLayout",
    "Top3LanesLayout",
    "Top3Layout",
    "Top4LanesLayout",
    "TopNEnergyLayout",
    "TopNLayout",
    "algebra_element",
    "increment_blocks",
    "orbit_dimension",
    "orbit_numbers",
    "orbit_parts",
    "rolling_ball_increments",
    "rolling_ball_numbers",
    "vector_factors",
]


def increment_blocks(method) -> int:
    """Algebra elements in a step's increment: one (RKMK, a map), the step's exponents (a product
    of exponentials), none (classical RK: dense output interpolates the state arrays)."""
    if isinstance(method, ExpProductForm):
        return method.outputs
    return 1 if method.family == "rkmk" or isinstance(method, MapForm) else 0


class Layout:
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


class Top3Layout(Layout):
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
        return 3 * increment_blocks(method)

    def increments(self, U: np.ndarray, batch: tuple):
        """The steps' increments in the user's so(3): ``(P u)^`` (conjugation by a proper P moves
        the vector of a hat matrix by P)."""
        from ..groups.bivectors import hat

        u = U if self.identity_frame else U @ self.P.T
        return hat(u).reshape(U.shape[:-2] + batch + (3, 3))


class Top3EnergyLayout(Top3Layout):
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


class Top3LanesLayout(Top3Layout):
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


class HeavyTop3LanesLayout(Top3Layout):
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


class Chaplygin3LanesLayout(Layout):
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


class RollingBall3LanesLayout(Layout):
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

        rolling_ball_numbers(self, form)
        assert self.params.size == PARAMS
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
        """The steps' increments in the ball's algebra (:func:`rolling_ball_increments`)."""
        from .rolling_lanes import increments_to_user

        w, v, delta = increments_to_user(U, self.N)
        return rolling_ball_increments(w, v, delta, U.shape[:-2] + batch, self.center)


class TopNLayout(Layout):
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
        return self.n * self.n * increment_blocks(method)

    def increments(self, U: np.ndarray, batch: tuple):
        n = self.n
        u = U.reshape(U.shape[:-1] + (n, n))
        if not self.identity_frame:
            u = self.P @ u @ self.P.T
        return u.reshape(U.shape[:-2] + batch + (n, n))


class Top4LanesLayout(TopNLayout):
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


class TopNEnergyLayout(TopNLayout):
    """The n-D top under an energy-keeping pair: ``(Ã, R̃)``, then the level H₀ every accepted
    step ends on (:mod:`lieint.fast.topn_energy`)."""

    module = "lieint.fast.topn_energy"

    def __init__(self, form: TopNForm, system):
        super().__init__(form)
        self.system = system
        self.energy = system.invariants["energy"]  # the system's invariants are built at each look
        self.fields_size = self.d
        self.d = self.fields_size + 1  # count stays the fields' components: the level is no user's

    def family(self, method) -> str:
        return "rkmk_energy"

    def start(self, y: dict, N: int) -> np.ndarray:
        # H₀ as the generic path takes it (the system's own energy): the level both paths aim at
        level = np.asarray(self.energy(0.0, y), dtype=float).reshape(N, 1)
        return np.concatenate([super().start(y, N), level], axis=1)

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        return super().user(Y[..., : self.fields_size], batch)


class PiecesLayout(Layout):
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
        return (self.n * self.n + self.nv + self.m) * increment_blocks(method)

    def increments(self, U: np.ndarray, batch: tuple):
        """The steps' increments as elements of the system's algebra (a skew matrix on so(n),
        a homogeneous matrix on se(n), tuples over a product with vector factors)."""
        n, nv, lead = self.n, self.nv, U.shape[:-2] + batch
        W = U[..., : n * n].reshape(lead + (n, n))
        v = U[..., n * n : n * n + nv].reshape(lead + (nv,))
        a = U[..., n * n + nv :].reshape(lead + (self.m,))
        return algebra_element(self.system.group, W, v, a)


class PiecesEnergyLayout(PiecesLayout):
    """A system through compiled pieces under an energy-keeping pair: its fields, then the level
    H₀ every accepted step ends on (:mod:`lieint.fast.generic_energy`); the context carries the
    orbit's basis and the group elements of its central differences."""

    module = "lieint.fast.generic_energy"

    def __init__(self, form: PiecesForm, system, needs_field: bool = True, needs_projection: bool = True):
        super().__init__(form, system, needs_field, needs_projection)
        self.energy = system.invariants["energy"]  # the system's invariants are built at each look
        self.fields_size = self.d
        self.d = self.fields_size + 1  # count stays the fields' components: the level is no user's
        self.orbit = orbit_numbers(vector_factors(system.group), self.n, self.nv, self.m)
        self.dim = orbit_dimension(self.n, self.nv, self.m, self.orbit.size)

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
        level = np.asarray(self.energy(0.0, y), dtype=float).reshape(N, 1)
        return np.concatenate([super().start(y, N), level], axis=1)

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        return super().user(Y[..., : self.fields_size], batch)

    def user_flat(self, y: dict, N: int) -> np.ndarray:
        return np.ascontiguousarray(super().start(y, N))


def skew_basis(n: int) -> np.ndarray:
    """``E_kj − E_jk`` for j < k (the generic path's basis of so(n), in its order)."""
    pairs = [(j, k) for j in range(n) for k in range(j + 1, n)]
    out = np.zeros((len(pairs), n, n))
    for i, (j, k) in enumerate(pairs):
        out[i, j, k], out[i, k, j] = -1.0, 1.0
    return out


def vector_factors(group) -> tuple:
    """``(shape, antisymmetric)`` of each vector factor of ``group`` after its pose (none for
    SO(n) or SE(n) alone): what the orbit basis of the compiled pieces depends on, hashable."""
    from ..groups.vector import ProductGroup

    factors = group.factors[1:] if isinstance(group, ProductGroup) else ()
    return tuple((tuple(f.shape), bool(getattr(f, "antisymmetric", False))) for f in factors)


def orbit_dimension(n: int, nv: int, m: int, size: int) -> int:
    """dim 𝔤 from the length of the flat orbit numbers (9 blocks of dim elements each)."""
    per = 3 * (n * n + nv + m)
    return size // per


@lru_cache(maxsize=64)
def orbit_numbers(factors: tuple, n: int, nv: int, m: int) -> np.ndarray:
    """The basis of the algebra of ``SO(n)/SE(n) × Rᵐ`` as the compiled pieces lay it out,
    ``(W, v, a)`` per element (the generic path's basis and order: the rotations, the
    translations, each vector factor's unit vectors or, for a factor of skew matrices, its skew
    basis), and the group elements ``exp(±ε e_i)`` as ``(Q, t, a)``, stacked ``(2, dim, …)``,
    in one flat array, kept per layout and never written (:func:`lieint.fast.generic_energy._orbit`
    reads it; writable, as the compiled pieces' signatures take their arrays); ``factors`` as
    :func:`vector_factors` gives them."""
    from .generic_energy import EPSILON

    rotations = skew_basis(n)
    parts = []  # the vector factor's basis elements, flat in a
    start = 0
    for shape, antisymmetric in factors:
        size = int(np.prod(shape))
        if antisymmetric:
            block = skew_basis(shape[0]).reshape(-1, size)
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
    """``(W, v, a, Q, t, a±)`` of :func:`orbit_numbers`' flat array, as the compiled side reads
    it (the tests compare them with the generic path's basis)."""
    dim = orbit_dimension(n, nv, m, flat.size)
    shapes = ((dim, n, n), (dim, nv), (dim, m), (2, dim, n, n), (2, dim, nv), (2, dim, m))
    out, start = [], 0
    for shape in shapes:
        size = math.prod(shape)
        out.append(flat[start : start + size].reshape(shape))
        start += size
    return tuple(out)


def algebra_element(group, W, v, a):
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
        parts, start = [algebra_element(first, W, v, a[..., :0])], 0
        for factor in rest:
            size = int(np.prod(factor.shape))
            parts.append(a[..., start : start + size].reshape(a.shape[:-1] + tuple(factor.shape)))
            start += size
        return tuple(parts)
    raise TypeError(f"no algebra element of {group!r} from a compiled increment")


def rolling_ball_numbers(layout, form: RollingBall3Form) -> None:
    """What a 3D rolling ball's layouts share, set on ``layout``: ``params`` — ``J = tr(B_C) I − B_C``
    (9), M, r, ν (3), whether the centre is tracked, the gravity mode (0 none, 1 along ν, 2 tilted:
    G a field), ``⟨g, ν⟩``, ``|g|``, X_G (3): :mod:`lieint.fast.rolling_lanes`' 21 numbers — the flags
    ``orientation``, ``center``, ``tilted``, the pose's ``group``, the user's ``fields`` in the
    state's order (Ω, Γ, G on an incline, R, the centre) and their ``count``."""
    B = np.asarray(form.B_C, dtype=float)
    J = np.trace(B) * np.eye(3) - B
    layout.orientation, layout.center, layout.tilted = bool(form.orientation), bool(form.center), form.mode == 2
    layout.params = np.concatenate(
        [J.ravel(), [form.mass, form.radius], np.asarray(form.normal, dtype=float), [float(layout.center)],
         [float(form.mode), form.g_normal, form.g_norm], np.asarray(form.center_of_mass, dtype=float)]
    )  # fmt: skip
    layout.group = "se(3)" if layout.center else "so(3)"
    layout.fields = ["Omega", "Gamma"] + ["G"] * layout.tilted + ["R"] * layout.orientation + ["center"] * layout.center
    layout.count = 12 + 3 * layout.tilted + 9 * layout.orientation + 3 * layout.center


def rolling_ball_increments(w, v, delta, lead: tuple, center: bool):
    """A 3D rolling ball's step increments in its algebra ``se(3) × so(3)`` (``so(3) × so(3)``
    without the centre), ``([[ŵ, v], [0, 0]], δ̂)``, from the vectors ``(..., 3)`` of its pose's
    rotation and translation and of the so(3) factor, over the leading axes ``lead``."""
    from ..groups.bivectors import hat
    from ..groups.se import se_join

    W, D = hat(w).reshape(lead + (3, 3)), hat(delta).reshape(lead + (3, 3))
    pose = se_join(W, np.reshape(v, lead + (3,)), algebra=True) if center else W
    return pose, D


class PrescribedLayout(Layout):
    """A rotation moved by prescribed body rates (:class:`lieint.fast.forms.PrescribedForm`),
    stepped by the Magnus methods (:mod:`lieint.fast.magnus`): a body's state is R row-major (n²),
    a step's increment u (n²). The rates at the Gauss nodes of a call's steps go into that call's
    parameters (:meth:`call_params`)."""

    module = "lieint.fast.magnus"

    def __init__(self, form: PrescribedForm):
        self.n, self.rates = int(form.n), form.rates
        self.d = self.count = self.n * self.n
        self.group = f"so({self.n})"
        self.label = f"prescribed rotation (n = {self.n})"
        self.params = np.array([float(self.n), 0.0, 0.0])

    def increments_size(self, method) -> int:
        return self.n * self.n

    def start(self, y: dict, N: int) -> np.ndarray:
        return np.ascontiguousarray(y["R"], dtype=float).reshape(N, self.d)

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        return {"R": Y.reshape(Y.shape[:-2] + batch + (self.n, self.n))}

    def increments(self, U: np.ndarray, batch: tuple):
        """The steps' increments u, skew ``(…, n, n)`` in the user's so(n)."""
        return U.reshape(U.shape[:-2] + batch + (self.n, self.n))

    def call_params(self, plan, k_from: int, k_to: int, numbers) -> np.ndarray:
        """The parameters of a call stepping ``k_from ≤ k < k_to``: n, the nodes per step, k_from,
        then Ω at the nodes ``t_k + c_i h_k`` of each step (``(steps, nodes, n, n)`` row-major) —
        refused beyond ``LIEINT_MAX_MEMORY`` (they are held for the call)."""
        from ..limits import check

        nodes = np.asarray(numbers.nodes, dtype=float)
        steps = k_to - k_from
        size = 8.0 * steps * nodes.size * self.d
        check(
            "LIEINT_MAX_MEMORY",
            size,
            lambda: f"the prescribed rates at the {nodes.size} Gauss nodes of {steps} steps (bytes)",
            "stream the run (lieint.runs.run), which steps it in segments",
        )
        k = np.arange(k_from, k_to, dtype=np.int64)
        starts = plan.times(k)
        sizes = np.full(steps, float(plan.h))
        if steps and k_to == plan.nsteps:
            sizes[-1] = plan.last_step
        times = (starts[:, None] + nodes[None, :] * sizes[:, None]).ravel()
        rates = np.asarray(self.rates(times), dtype=float).reshape(-1)
        return np.concatenate([[float(self.n), float(nodes.size), float(k_from)], rates])
