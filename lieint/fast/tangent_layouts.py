"""Layouts of the bodies stepped in vectors: the compiled tangent forms' rows, and one body's plain rows.

A compiled tangent form (:mod:`lieint.fast.top3_tangent`, :mod:`lieint.fast.topn_tangent`,
:mod:`lieint.fast.heavy3_tangent`, :mod:`lieint.fast.chaplygin3_tangent`,
:mod:`lieint.fast.rolling3_tangent`) steps a body's state block and k tangent vectors of the same
layout, then (MEGNO, Lyapunov) the sums of :mod:`lieint.fast.tangent_sums`; the layouts here say
how the user's fields and their derivatives fill a block and back (``pack``, ``unpack``). The 3D
heavy top's and balls' rows with no tangent vectors are also how one such body's plain fixed-step
RKMK runs (:class:`HeavyTop3Layout`, :class:`Chaplygin3Layout`, :class:`RollingBall3Layout`,
chosen by :func:`lieint.fast.engine.engine_for`). The other layouts are in :mod:`lieint.fast.layouts`.
"""

from __future__ import annotations

import functools
import importlib
import math

import numpy as np

from .forms import Chaplygin3Form, HeavyTop3Form, RollingBall3Form, Top3Form, TopNForm
from .layouts import Layout, Top3Layout, rolling_ball_increments, rolling_ball_numbers

#: the attitude argument of a body without one: no 3 × 3 matrices (never written, shared)
_NO_MATRICES = np.empty((0, 3, 3))
#: the centre argument of a ball that does not track it: no vectors (never written, shared)
_NO_VECTORS = np.empty((0, 3))


@functools.cache
def _module(name: str):
    """The tangent module ``lieint.fast.<name>`` of a layout's compiled conversions, imported on
    first use and once (an ``import`` statement in a function costs 0.6 µs a call)."""
    return importlib.import_module(f"{__package__}.{name}")


__all__ = [
    "Chaplygin3Layout",
    "Chaplygin3LyapunovLayout",
    "Chaplygin3MegnoLayout",
    "Chaplygin3TangentLayout",
    "HeavyTop3Layout",
    "HeavyTop3LyapunovLayout",
    "HeavyTop3MegnoLayout",
    "HeavyTop3TangentLayout",
    "RollingBall3Layout",
    "RollingBall3LyapunovLayout",
    "RollingBall3MegnoLayout",
    "RollingBall3TangentLayout",
    "Top3LyapunovLayout",
    "Top3MegnoLayout",
    "Top3TangentLayout",
    "TopNLyapunovLayout",
    "TopNMegnoLayout",
    "TopNTangentLayout",
]


class Top3TangentLayout(Top3Layout):
    """The 3D top with k tangent vectors (:mod:`lieint.fast.top3_tangent`): a body's row is
    ``(Π, R̃)`` in the principal frame, then k vectors ``(δΠ, δR̃)`` of the same layout. The
    change of frame is linear, so the tangent vectors move with it as the state does; δR̃ is zero
    where the top carries no attitude."""

    module = "lieint.fast.top3_tangent"
    label = "3D top with its tangent vectors (principal frame)"

    def __init__(self, form: Top3Form, k: int):
        super().__init__(form)
        self.k = int(k)
        self.d = 12 * (1 + self.k)

    def pack(self, y: dict, dy: list[dict], N: int) -> np.ndarray:
        """The rows ``(N, d)`` of the states ``y`` and the tangent vectors ``dy`` (k dicts of the
        fields' derivatives, each of the batch's shape)."""
        Y = np.empty((N, self.d))
        Y[:, :12] = self.start(y, N)
        for m, v in enumerate(dy, start=1):
            rows = self.start(v, N)
            if not self.orientation:
                rows[:, 3:] = 0.0  # start() stands R = I in for a top without attitude: its δ is 0
            Y[:, 12 * m : 12 * (m + 1)] = rows
        return Y

    def unpack(self, Y: np.ndarray, batch: tuple) -> tuple[dict, list[dict]]:
        """The states and the k tangent vectors of the rows ``Y`` (:meth:`pack`'s inverse)."""
        y = self.user(Y, batch)
        dy = [Top3Layout.user(self, np.ascontiguousarray(Y[:, 12 * m : 12 * (m + 1)]), batch)
              for m in range(1, self.k + 1)]  # fmt: skip
        return y, dy

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        return super().user(np.ascontiguousarray(Y[..., :12]), batch)


class Top3MegnoLayout(Top3TangentLayout):
    """The 3D top with one tangent vector and MEGNO's sums after it
    (:func:`lieint.fast.tangent_sums.megno_update`): the steps' family is the map's own with
    ``_megno``; a row's user fields carry the sums as ``"megno"`` (five numbers)."""

    label = "3D top with its tangent vector and MEGNO's sums (principal frame)"

    def __init__(self, form: Top3Form):
        from .tangent_sums import MEGNO_SLOTS

        super().__init__(form, 1)
        self.d = 24 + MEGNO_SLOTS

    def family(self, method) -> str:
        return f"{method.family}_megno"

    def pack(self, y: dict, dy: list[dict], N: int) -> np.ndarray:
        Y = np.zeros((N, self.d))
        Y[:, :24] = super().pack(y, dy, N)[:, :24]
        return Y

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        states = super().user(Y, batch)
        states["megno"] = Y[..., 24:].reshape(Y.shape[:-2] + batch + (self.d - 24,))
        return states


class Top3LyapunovLayout(Top3TangentLayout):
    """The 3D top with k tangent vectors re-orthonormalised every ``every`` of ``total`` steps
    (:func:`lieint.fast.tangent_sums.lyapunov_update`): after the vectors a step counter and the
    k sums of ``log |diag R|``; the steps' family is the map's own with ``_lyapunov``, and a row's
    user fields carry the sums as ``"lyapunov"``."""

    label = "3D top with its tangent vectors and their growth sums (principal frame)"

    def __init__(self, form: Top3Form, k: int, every: int, total: int):
        super().__init__(form, k)
        self.d = 12 * (1 + self.k) + 1 + self.k
        self.params = np.concatenate([self.params, [float(every), float(total)]])

    def family(self, method) -> str:
        return f"{method.family}_lyapunov"

    def pack(self, y: dict, dy: list[dict], N: int) -> np.ndarray:
        Y = np.zeros((N, self.d))
        width = 12 * (1 + self.k)
        Y[:, :width] = super().pack(y, dy, N)[:, :width]
        return Y

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        states = super().user(Y, batch)
        states["lyapunov"] = Y[..., 12 * (1 + self.k) + 1 :].reshape(Y.shape[:-2] + batch + (self.k,))
        return states


class _TangentRows(Layout):
    """A compiled tangent form's rows (:mod:`lieint.fast.tangent_sums`): a body's state block of
    ``block`` numbers, then k tangent vectors of the same layout. A subclass says how the user's
    fields fill a block (``_block``, for a state or, ``tangent``, a derivative) and back
    (``_fields``)."""

    block: int

    def __init__(self, k: int):
        self.k = int(k)
        self.d = self.block * (1 + self.k)

    def increments_size(self, method) -> int:
        return 6

    def pack(self, y: dict, dy: list[dict], N: int) -> np.ndarray:
        """The rows ``(N, d)`` of the states ``y`` and the tangent vectors ``dy`` (k dicts of the
        fields' derivatives, each of the batch's shape); the sums after them zero."""
        Y = np.zeros((N, self.d))
        b = self.block
        Y[:, :b] = self._block(y, N, False)
        for m, v in enumerate(dy, start=1):
            Y[:, b * m : b * (m + 1)] = self._block(v, N, True)
        return Y

    def unpack(self, Y: np.ndarray, batch: tuple) -> tuple[dict, list[dict]]:
        """The states and the k tangent vectors of the rows ``Y`` (:meth:`pack`'s inverse)."""
        b = self.block
        y = self.user(Y, batch)
        dy = [self._fields(Y[:, b * m : b * (m + 1)], batch) for m in range(1, self.k + 1)]
        return y, dy

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        return self._fields(Y[..., : self.block], batch)


class _MegnoRows(_TangentRows):
    """One tangent vector and MEGNO's sums after it (:func:`lieint.fast.tangent_sums.megno_update`):
    the steps' family is the map's own with ``_megno``; a row's user fields carry the sums as
    ``"megno"`` (five numbers)."""

    def __init__(self, form):
        from .tangent_sums import MEGNO_SLOTS

        super().__init__(form, 1)
        self.d = 2 * self.block + MEGNO_SLOTS

    def family(self, method) -> str:
        return f"{method.family}_megno"

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        states = super().user(Y, batch)
        states["megno"] = Y[..., 2 * self.block :].reshape(Y.shape[:-2] + batch + (self.d - 2 * self.block,))
        return states


class _LyapunovRows(_TangentRows):
    """k tangent vectors re-orthonormalised every ``every`` of ``total`` steps
    (:func:`lieint.fast.tangent_sums.lyapunov_update`): after the vectors a step counter and the k
    sums of ``log |diag R|``, carried in a row's user fields as ``"lyapunov"``; ``every`` and
    ``total`` follow the form's parameters."""

    def __init__(self, form, k: int, every: int, total: int):
        super().__init__(form, k)
        self.d = self.block * (1 + self.k) + 1 + self.k
        self.params = np.concatenate([self.params, [float(every), float(total)]])

    def family(self, method) -> str:
        return f"{method.family}_lyapunov"

    def user(self, Y: np.ndarray, batch: tuple) -> dict:
        states = super().user(Y, batch)
        start = self.block * (1 + self.k) + 1
        states["lyapunov"] = Y[..., start:].reshape(Y.shape[:-2] + batch + (self.k,))
        return states


class HeavyTop3TangentLayout(_TangentRows):
    """The 3D heavy top with k tangent vectors (:mod:`lieint.fast.heavy3_tangent`): a body's block
    is ``(Π, Γ̃, R̃)`` in the principal frame of its top (``Γ̃ = PᵀΓ``, ``R̃ = R P``; R̃ = I for a
    top without attitude), a tangent vector's ``(δΠ, δΓ̃, δR̃)`` (δR̃ = 0 without attitude). The
    change of frame is linear: the tangent vectors move with it as the state does. Parameters:
    ``I⁻¹`` (3), ``Pᵀ M X_G`` (3), whether the top carries R."""

    module = "lieint.fast.heavy3_tangent"
    group = "se(3)"
    label = "3D heavy top with its tangent vectors (principal frame)"
    block = 15
    exact_radius = True

    def __init__(self, form: HeavyTop3Form, k: int):
        from . import _proper_frame

        self.moments = np.asarray(form.moments, dtype=float)
        self.P, self.identity_frame = _proper_frame(form.P)
        self.orientation = bool(form.orientation)
        mxg = np.asarray(form.MXG, dtype=float) @ self.P
        self.params = np.concatenate([1.0 / self.moments, mxg, [float(self.orientation)]])
        self.count = 21 if self.orientation else 12
        super().__init__(k)

    def _block(self, y: dict, N: int, tangent: bool) -> np.ndarray:
        A = np.ascontiguousarray(y["A"], dtype=float).reshape(N, 3, 3)
        G = np.ascontiguousarray(y["Gamma"], dtype=float).reshape(N, 3)
        R = np.ascontiguousarray(y["R"], dtype=float).reshape(N, 3, 3) if self.orientation else _NO_MATRICES
        Y = np.empty((N, self.block))
        _module("heavy3_tangent").user_to_rows(A, G, R, self.P, self.identity_frame, self.orientation, tangent, Y)
        return Y

    def _fields(self, Y: np.ndarray, batch: tuple) -> dict:
        lead = Y.shape[:-2] + batch
        M = math.prod(Y.shape[:-1])
        A, G = np.empty((M, 3, 3)), np.empty((M, 3))
        R = np.empty((M, 3, 3)) if self.orientation else _NO_MATRICES
        _module("heavy3_tangent").rows_to_user(
            Y.reshape(M, Y.shape[-1]), self.P, self.identity_frame, self.orientation, A, G, R
        )
        states = {"A": A.reshape(lead + (3, 3)), "Gamma": G.reshape(lead + (3,))}
        if self.orientation:
            states["R"] = R.reshape(lead + (3, 3))
        return states


class HeavyTop3MegnoLayout(_MegnoRows, HeavyTop3TangentLayout):
    """The 3D heavy top with one tangent vector and MEGNO's sums after it."""

    label = "3D heavy top with its tangent vector and MEGNO's sums (principal frame)"


class HeavyTop3LyapunovLayout(_LyapunovRows, HeavyTop3TangentLayout):
    """The 3D heavy top with k tangent vectors and Benettin's sums (every, total: ``par[7]``, ``par[8]``)."""

    label = "3D heavy top with its tangent vectors and their growth sums (principal frame)"


class Chaplygin3TangentLayout(_TangentRows):
    """The 3D Chaplygin ball with k tangent vectors (:mod:`lieint.fast.chaplygin3_tangent`): a
    body's block is ``(Π, Γ, c, R)`` in the user's frame (``A_K = −Π̂``; the centre zero when it is
    not tracked, R = I without attitude), a tangent vector's ``(δΠ, δΓ, δc, δR)`` (zero where the
    ball carries no such field). Parameters: ``J = tr(B_C) I − B_C`` (9), ``M r²``, r, whether the
    ball carries R and whether it tracks its centre."""

    module = "lieint.fast.chaplygin3_tangent"
    label = "3D Chaplygin ball with its tangent vectors"
    block = 18
    exact_radius = True

    def __init__(self, form: Chaplygin3Form, k: int):
        B = np.asarray(form.B_C, dtype=float)
        J = np.trace(B) * np.eye(3) - B
        self.orientation, self.center = bool(form.orientation), bool(form.center)
        flags = [float(self.orientation), float(self.center)]
        self.params = np.concatenate([J.ravel(), [form.Mr2, form.radius], flags])
        self.group = "se(3)" if self.center else "so(3)"
        self.count = 12 + (9 if self.orientation else 0) + (3 if self.center else 0)
        super().__init__(k)

    def _block(self, y: dict, N: int, tangent: bool) -> np.ndarray:
        A = np.ascontiguousarray(y["A"], dtype=float).reshape(N, 3, 3)
        G = np.ascontiguousarray(y["Gamma"], dtype=float).reshape(N, 3)
        c = np.ascontiguousarray(y["center"], dtype=float).reshape(N, 3) if self.center else _NO_VECTORS
        R = np.ascontiguousarray(y["R"], dtype=float).reshape(N, 3, 3) if self.orientation else _NO_MATRICES
        Y = np.empty((N, self.block))
        _module("chaplygin3_tangent").user_to_rows(A, G, c, R, self.center, self.orientation, tangent, Y)
        return Y

    def _fields(self, Y: np.ndarray, batch: tuple) -> dict:
        lead = Y.shape[:-2] + batch
        M = math.prod(Y.shape[:-1])
        A, G = np.empty((M, 3, 3)), np.empty((M, 3))
        c = np.empty((M, 3)) if self.center else _NO_VECTORS
        R = np.empty((M, 3, 3)) if self.orientation else _NO_MATRICES
        rows = np.ascontiguousarray(Y).reshape(M, Y.shape[-1])
        _module("chaplygin3_tangent").rows_to_user(rows, self.center, self.orientation, A, G, c, R)
        states = {"A": A.reshape(lead + (3, 3)), "Gamma": G.reshape(lead + (3,))}
        if self.orientation:
            states["R"] = R.reshape(lead + (3, 3))
        if self.center:
            states["center"] = c.reshape(lead + (3,))
        return states


class Chaplygin3MegnoLayout(_MegnoRows, Chaplygin3TangentLayout):
    """The 3D Chaplygin ball with one tangent vector and MEGNO's sums after it."""

    label = "3D Chaplygin ball with its tangent vector and MEGNO's sums"


class Chaplygin3LyapunovLayout(_LyapunovRows, Chaplygin3TangentLayout):
    """The 3D Chaplygin ball with k tangent vectors and Benettin's sums (every, total: ``par[13]``,
    ``par[14]``)."""

    label = "3D Chaplygin ball with its tangent vectors and their growth sums"


class RollingBall3TangentLayout(_TangentRows):
    """The 3D rolling ball with k tangent vectors (:mod:`lieint.fast.rolling3_tangent`): a body's
    block is ``(ω, Γ, c, G, R)`` in the user's frame (``Ω = ω̂``; zero where the ball carries no
    centre or G, R = I without attitude), a tangent vector's ``(δω, δΓ, δc, δG, δR)`` (zero where
    the ball carries no such field). Parameters: :mod:`lieint.fast.rolling_lanes`' (J, M, r, ν,
    whether the centre is tracked, the gravity mode, ⟨g, ν⟩, |g|, X_G), then whether the ball
    carries R."""

    module = "lieint.fast.rolling3_tangent"
    label = "3D rolling ball with its tangent vectors"
    block = 21
    exact_radius = True

    def __init__(self, form: RollingBall3Form, k: int):
        rolling_ball_numbers(self, form)  # the lanes' parameters, then whether the ball carries R
        self.params = np.concatenate([self.params, [float(self.orientation)]])
        super().__init__(k)

    def increments_size(self, method) -> int:
        return 9  # the pose's (u_w, u_v), then the so(3) factor's δ

    def _block(self, y: dict, N: int, tangent: bool) -> np.ndarray:
        Y = np.zeros((N, self.block))
        W = y["Omega"].reshape(N, 3, 3)
        Y[:, 0] = 0.5 * (W[:, 2, 1] - W[:, 1, 2])  # vee: Ω = ω̂
        Y[:, 1] = 0.5 * (W[:, 0, 2] - W[:, 2, 0])
        Y[:, 2] = 0.5 * (W[:, 1, 0] - W[:, 0, 1])
        Y[:, 3:6] = y["Gamma"].reshape(N, 3)
        if self.center:
            Y[:, 6:9] = y["center"].reshape(N, 3)
        if self.tilted:
            Y[:, 9:12] = y["G"].reshape(N, 3)
        if self.orientation:
            Y[:, 12:] = y["R"].reshape(N, 9)
        elif not tangent:
            Y[:, 12:] = np.eye(3).ravel()
        return Y

    def _fields(self, Y: np.ndarray, batch: tuple) -> dict:
        from ..groups.bivectors import hat

        lead = Y.shape[:-2] + batch
        states = {
            "Omega": hat(np.ascontiguousarray(Y[..., :3])).reshape(lead + (3, 3)),
            "Gamma": np.ascontiguousarray(Y[..., 3:6]).reshape(lead + (3,)),
        }
        if self.tilted:
            states["G"] = np.ascontiguousarray(Y[..., 9:12]).reshape(lead + (3,))
        if self.orientation:
            states["R"] = np.ascontiguousarray(Y[..., 12:21]).reshape(lead + (3, 3))
        if self.center:
            states["center"] = np.ascontiguousarray(Y[..., 6:9]).reshape(lead + (3,))
        return {name: states[name] for name in self.fields}


class RollingBall3MegnoLayout(_MegnoRows, RollingBall3TangentLayout):
    """The 3D rolling ball with one tangent vector and MEGNO's sums after it."""

    label = "3D rolling ball with its tangent vector and MEGNO's sums"


class RollingBall3LyapunovLayout(_LyapunovRows, RollingBall3TangentLayout):
    """The 3D rolling ball with k tangent vectors and Benettin's sums (every, total: ``par[22]``,
    ``par[23]``)."""

    label = "3D rolling ball with its tangent vectors and their growth sums"


class HeavyTop3Layout(HeavyTop3TangentLayout):
    """One 3D heavy top in vectors: the block ``(Π, Γ̃, R̃)`` of :class:`HeavyTop3TangentLayout`
    with no tangent vectors, stepped by :mod:`lieint.fast.heavy3_tangent`'s RKMK step with k = 0
    (exponential coordinates, fixed steps). The engine picks it for one body whose run does not
    project (its rows are the state alone; a projecting run goes through the compiled pieces)."""

    label = "3D heavy top in vectors (principal frame)"

    def __init__(self, form: HeavyTop3Form):
        super().__init__(form, 0)

    def start(self, y: dict, N: int) -> np.ndarray:
        return self._block(y, N, False)

    def increments(self, U: np.ndarray, batch: tuple):
        """The steps' increments in the user's se(3), ``[[(P u_w)^, P u_v], [0, 0]]``."""
        from ..groups.bivectors import hat
        from ..groups.se import se_join

        w, v = U[..., :3], U[..., 3:6]
        if not self.identity_frame:
            w, v = w @ self.P.T, v @ self.P.T
        return se_join(hat(w), v, algebra=True).reshape(U.shape[:-2] + batch + (4, 4))


class Chaplygin3Layout(Chaplygin3TangentLayout):
    """One 3D Chaplygin ball in vectors: the block ``(Π, Γ, c, R)`` of
    :class:`Chaplygin3TangentLayout` with no tangent vectors, stepped by
    :mod:`lieint.fast.chaplygin3_tangent`'s RKMK step with k = 0 (exponential coordinates, fixed
    steps); picked as :class:`HeavyTop3Layout` is."""

    label = "3D Chaplygin ball in vectors"

    def __init__(self, form: Chaplygin3Form):
        super().__init__(form, 0)

    def start(self, y: dict, N: int) -> np.ndarray:
        return self._block(y, N, False)

    def increments(self, U: np.ndarray, batch: tuple):
        """The steps' increments in the ball's algebra: ``[[û_w, u_v], [0, 0]]`` on se(3), ``û_w``
        on so(3) (without the centre)."""
        from ..groups.bivectors import hat
        from ..groups.se import se_join

        lead = U.shape[:-2] + batch
        if not self.center:
            return hat(U[..., :3]).reshape(lead + (3, 3))
        return se_join(hat(U[..., :3]), U[..., 3:6], algebra=True).reshape(lead + (4, 4))


class RollingBall3Layout(RollingBall3TangentLayout):
    """One 3D rolling ball in vectors: the block ``(ω, Γ, c, G, R)`` of
    :class:`RollingBall3TangentLayout` with no tangent vectors, stepped by
    :mod:`lieint.fast.rolling3_tangent`'s RKMK step with k = 0 (exponential coordinates, fixed
    steps); picked as :class:`HeavyTop3Layout` is."""

    label = "3D rolling ball in vectors"

    def __init__(self, form: RollingBall3Form):
        super().__init__(form, 0)

    def start(self, y: dict, N: int) -> np.ndarray:
        return self._block(y, N, False)

    def increments(self, U: np.ndarray, batch: tuple):
        """The steps' increments ``(u_w, u_v, δ)`` in the ball's algebra
        (:func:`lieint.fast.layouts.rolling_ball_increments`)."""
        return rolling_ball_increments(U[..., :3], U[..., 3:6], U[..., 6:9], U.shape[:-2] + batch, self.center)


class TopNTangentLayout(_TangentRows):
    """The n-dimensional top (n ≥ 4) with k tangent vectors (:mod:`lieint.fast.topn_tangent`): a
    body's block is ``(Ã, R̃) = (PᵀAP, RP)`` in the principal frame (R̃ = I without attitude), a
    tangent vector's ``(δÃ, δR̃)`` (δR̃ = 0 without attitude): 2n² numbers each. Parameters: n,
    whether the top carries R, ``M_ij = −1/(b_i + b_j)``."""

    module = "lieint.fast.topn_tangent"
    exact_radius = False

    def __init__(self, form: TopNForm, k: int):
        from . import _proper_frame
        from .topn import inertia_factors_of

        self.n = n = form.n
        P, self.identity_frame = _proper_frame(form.P)
        self.P = np.array(P)
        self.orientation = bool(form.orientation)
        M = inertia_factors_of(np.asarray(form.b, dtype=float).tobytes())
        self.params = np.concatenate([[n, float(self.orientation)], M.ravel()])
        self.block = 2 * n * n
        self.count = n * n * (2 if self.orientation else 1)
        self.group = f"so({n})"
        self.label = f"{n}D top with its tangent vectors (principal frame)"
        super().__init__(k)

    def increments_size(self, method) -> int:
        return self.n * self.n

    def _block(self, y: dict, N: int, tangent: bool) -> np.ndarray:
        from .principal import to_principal

        n = self.n
        A = y["A"].reshape(N, n, n)
        if self.orientation:
            R = y["R"].reshape(N, n, n)
        else:  # a writable stack: the conversion's compiled code takes no read-only arrays
            R = np.zeros((N, n, n)) if tangent else np.tile(np.eye(n), (N, 1, 1))
        if self.identity_frame:
            A = 0.5 * (A - np.swapaxes(A, -1, -2))
        else:
            A, R = to_principal(A, R, self.P)
        Y = np.empty((N, self.block))
        Y[:, : n * n], Y[:, n * n :] = A.reshape(N, n * n), R.reshape(N, n * n)
        return Y

    def _fields(self, Y: np.ndarray, batch: tuple) -> dict:
        from .principal import to_user

        n, lead = self.n, Y.shape[:-2]
        A = np.ascontiguousarray(Y[..., : n * n]).reshape(-1, n, n)
        R = np.ascontiguousarray(Y[..., n * n : 2 * n * n]).reshape(-1, n, n)
        if not self.identity_frame:
            A, R = to_user(A, R, self.P)
        states = {"A": np.ascontiguousarray(A).reshape(lead + batch + (n, n))}
        if self.orientation:
            states["R"] = np.ascontiguousarray(R).reshape(lead + batch + (n, n))
        return states


class TopNMegnoLayout(_MegnoRows, TopNTangentLayout):
    """The n-dimensional top with one tangent vector and MEGNO's sums after it."""


class TopNLyapunovLayout(_LyapunovRows, TopNTangentLayout):
    """The n-dimensional top with k tangent vectors and Benettin's sums (every, total after M)."""
