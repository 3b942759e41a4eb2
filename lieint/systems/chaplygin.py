"""The Chaplygin ball: centre of mass at the geometric centre, gravity along the normal.

With ``X_G = 0`` and g ∥ ν, the momentum about the contact point ``a = −(b_K ω + ω b_K)`` is
constant in space (docs/theory.md §4), so the body momentum ``A_K = Rᵀ a R`` is isospectral::

    Ȧ_K = [A_K, Ω],   Γ̇ = −ΩΓ,   A_K = −(B_K Ω + Ω B_K),   B_K(Γ) = B_C + M r² ΓΓᵀ,

with Ω recovered from A_K in the eigenbasis of ``B_K(Γ)`` at every evaluation. SO(n) acts by
``Q·(A_K, Γ, R) = (QᵀA_K Q, QᵀΓ, RQ)`` (SE(n) with the centre ``p + Rv``, twist ``(Ω, rΩΓ)``),
so spec(A_K), ``|Γ|`` and ``ΓᵀA_K²Γ`` are kept to round-off; the energy is kept by the flow only.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .._validation import check_skew, describe
from ..fast.forms import BUILTIN_PIECES, Chaplygin3Form, PiecesForm
from ..groups.bivectors import inner, skew_part
from ..groups.se import SE
from ..groups.so import SO
from .base import Invariant, LieGroupSystem, Output, State
from .mass import solve_lyapunov
from .rigid import casimir_invariant, momentum_outputs, pose_invariants
from .rolling_ball import NORMAL_REFUSAL, RollingPose, check_ball, rolling_initial_kinematics

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

__all__ = ["ChaplyginBall"]

#: what the compiled declaration stands for (see :meth:`LieGroupSystem.dynamics_as`)
_DYNAMICS = (
    "generator", "act", "infinitesimal_action", "vector_field", "project", "contact_mass_tensor", "angular_velocity",
    "_twist", "_move_pose", "_pose_rate", "_project_pose",
)  # fmt: skip


class ChaplyginBall(RollingPose, LieGroupSystem):
    """Chaplygin's ball: a ball with centre of mass at its centre rolling on a plane.

    Parameters
    ----------
    mass_tensor : array_like, shape (n, n)
        ``B_C = ∫ m X Xᵀ`` about the centre.
    mass, radius : float
        M > 0 and r > 0.
    normal : array_like, shape (n,), optional
        Upward unit normal ν of the plane (default ``e_n``).
    orientation, track_center : bool, default True
        Integrate R / the centre (the centre needs R and brings it along).

    Notes
    -----
    Invariants: ``energy`` ``T = ¼ tr(Ω A_K)``, ``casimirs`` (rotation angles of A_K),
    ``gamma_norm`` ``|Γ|``, ``gamma_A2_gamma`` ``ΓᵀA_K²Γ``, ``momentum`` ``a = R A_K Rᵀ``
    and ``orthogonality`` (with R).

    Examples
    --------
    >>> import numpy as np, lieint
    >>> ball = lieint.ChaplyginBall(np.diag([0.10, 0.15, 0.20]), mass=1.0, radius=1.0)
    >>> y0 = ball.initial_state(angular_velocity=[0.3, 1.0, 2.0])
    >>> sol = lieint.integrate(ball, y0, (0.0, 5.0), h=0.01, method="rkmk4")
    >>> list(sol.states), round(float(sol.states["center"][-1, 2]), 8)  # the centre stays at height r
    (['A', 'Gamma', 'R', 'center'], 1.0)
    >>> bool(sol.drift("energy") < 1e-10 and sol.drift("gamma_norm") < 1e-13)
    True
    """

    autonomous = True
    structure = frozenset({"chaplygin_ball"})

    def __init__(
        self,
        mass_tensor: ArrayLike,
        mass: float,
        radius: float,
        normal: ArrayLike | None = None,
        *,
        orientation: bool = True,
        track_center: bool = True,
    ):
        self.B_C, self.mass, self.radius, _, self.normal = check_ball(mass_tensor, mass, radius, None, normal)
        n = self.n = self.B_C.shape[0]
        for flag, label in ((orientation, "orientation"), (track_center, "track_center")):
            if not isinstance(flag, (bool, np.bool_)):
                raise TypeError(f"`{label}` must be True or False; got {flag!r}.")
        self.orientation, self.track_center = bool(orientation), bool(track_center)
        self.fields = {"A": (n, n), "Gamma": (n,)}
        self._pose_fields(n, self.orientation)
        self.group = SE(n) if self.track_center else SO(n)
        self._Mr2 = self.mass * self.radius**2

    # -- physics -----------------------------------------------------------------------
    def contact_mass_tensor(self, Gamma: np.ndarray) -> np.ndarray:
        """The mass tensor about the contact point, ``B_K(Γ) = B_C + M r² ΓΓᵀ``.

        Parameters
        ----------
        Gamma : ndarray, shape (..., n)
            The plane's normal in the body frame, ``Γ = Rᵀν``.

        Returns
        -------
        ndarray, shape (..., n, n)
            ``B_K``.
        """
        return self.B_C + self._Mr2 * Gamma[..., :, None] * Gamma[..., None, :]

    def momentum(self, Omega: np.ndarray, Gamma: np.ndarray) -> np.ndarray:
        """The body momentum about the contact, ``A_K = −(B_K Ω + Ω B_K)``.

        Parameters
        ----------
        Omega : ndarray, shape (..., n, n)
            Body angular velocity bivectors.
        Gamma : ndarray, shape (..., n)
            ``Γ = Rᵀν``.

        Returns
        -------
        ndarray, shape (..., n, n)
            ``A_K``.
        """
        BK = self.contact_mass_tensor(Gamma)
        return -(BK @ Omega + Omega @ BK)

    def angular_velocity(self, A: np.ndarray, Gamma: np.ndarray) -> np.ndarray:
        """Ω from ``A_K = −(B_K Ω + Ω B_K)`` in the eigenbasis of ``B_K(Γ)``.

        Parameters
        ----------
        A : ndarray, shape (..., n, n)
            Body momentum bivectors about the contact.
        Gamma : ndarray, shape (..., n)
            ``Γ = Rᵀν``.

        Returns
        -------
        ndarray, shape (..., n, n)
            Ω (NaN for a member whose ``B_K`` is not finite).
        """
        return solve_lyapunov(self.contact_mass_tensor(Gamma), -A)

    def energy(self, y: State) -> np.ndarray:
        """``T = ¼ tr(Ω A_K) = −¼⟨Ω, A_K⟩`` (gravity does no work: the centre stays at height r).

        Parameters
        ----------
        y : dict of ndarray
            States (any leading shape).

        Returns
        -------
        ndarray
            T per state.
        """
        return -0.25 * inner(self.angular_velocity(y["A"], y["Gamma"]), y["A"])

    def compiled(self) -> PiecesForm | None:
        """The compiled engine's form (:class:`lieint.fast.forms.PiecesForm`) for n ≥ 3.

        The Chaplygin ball's pieces in :mod:`lieint.fast.balls`; parameters n, the offsets of R
        and of the centre, ``M r²``, r, ``B_C`` and ν; for n = 3 also the form of its ensembles
        in SIMD lanes (:class:`lieint.fast.forms.Chaplygin3Form`).

        Returns
        -------
        PiecesForm or None
            The form, or None (n = 2, or a subclass with other dynamics).
        """
        if self.n < 3 or not self.dynamics_as(ChaplyginBall, _DYNAMICS):
            return None
        # every number of the declaration (comparing them is cheaper than building its parameters)
        key = (tuple(self.fields), self.track_center, self._Mr2, self.radius, self.B_C.tobytes(), self.normal.tobytes())

        def build():
            offset = self.field_offsets()
            head = [self.n, offset.get("R", -1), offset.get("center", -1), self._Mr2, self.radius]
            params = np.concatenate([head, self.B_C.ravel(), self.normal])
            lanes = None
            if self.n == 3:  # ensembles of the 3D ball run in SIMD lanes
                lanes = Chaplygin3Form(
                    self.B_C, self._Mr2, self.radius, self.normal, "R" in self.fields, self.track_center
                )  # fmt: skip
            return PiecesForm(BUILTIN_PIECES.chaplygin, params, self.n, self.track_center, 0, self.fields, lanes=lanes)

        return self._declared_once(key, build)

    # -- the LieGroupSystem contract ---------------------------------------------------
    def generator(self, t: float | np.ndarray, y: State) -> np.ndarray:
        return self._twist(self.angular_velocity(y["A"], y["Gamma"]), y["Gamma"])

    def act(self, g: np.ndarray, y: State) -> State:
        Q, v = self._split(g)
        Qt = np.swapaxes(Q, -1, -2)
        out = {"A": Qt @ y["A"] @ Q, "Gamma": (Qt @ y["Gamma"][..., None])[..., 0]}
        self._move_pose(out, y, Q, v)
        return out

    def infinitesimal_action(self, xi: np.ndarray, y: State) -> State:
        Om, V = self._split(xi)
        A = y["A"]
        out = {"A": A @ Om - Om @ A, "Gamma": -(Om @ y["Gamma"][..., None])[..., 0]}
        self._pose_rate(out, y, Om, V)
        return out

    def project(self, y: State) -> State:
        out = dict(y)
        out["A"] = skew_part(y["A"])
        out["Gamma"] = y["Gamma"] / np.linalg.norm(y["Gamma"], axis=-1, keepdims=True)
        self._project_pose(out, y)
        return out

    @property
    def invariants(self) -> dict[str, Invariant]:
        declared = {
            "energy": Invariant(lambda t, y: self.energy(y), "integral", "kinetic energy T = ¼ tr(Ω A_K)"),
            "casimirs": casimir_invariant("A"),
            "gamma_norm": Invariant(lambda t, y: np.linalg.norm(y["Gamma"], axis=-1), "integral", "|Γ|"),
            # ΓᵀA²Γ = −|AΓ|² for skew A
            "gamma_A2_gamma": Invariant(
                lambda t, y: -np.sum(((y["A"] @ y["Gamma"][..., None])[..., 0]) ** 2, axis=-1),
                "integral",
                "Γᵀ A_K² Γ",
            ),
        }
        if "R" in self.fields:
            declared.update(pose_invariants("A"))
        return declared

    @property
    def outputs(self) -> dict[str, Output]:
        n = self.n
        out = dict(super().outputs)
        out.update(
            momentum_outputs(n, lambda y: self.angular_velocity(y["A"], y["Gamma"]), "momentum about the contact A_K")
        )
        return self._pose_outputs(out)

    # -- states ------------------------------------------------------------------------
    def initial_state(
        self,
        *,
        R: ArrayLike | Rotation | None = None,
        Omega: ArrayLike | None = None,
        angular_velocity: ArrayLike | None = None,
        center: ArrayLike | None = None,
        velocity: ArrayLike | None = None,
    ) -> State:
        """State from the orientation, the body angular velocity and the centre.

        Parameters
        ----------
        R : array_like, shape (..., n, n), or scipy Rotation, optional
            Orientation, body to space (default: the identity).
        Omega : array_like, shape (..., n, n), optional
            Body angular velocity bivector (give it or ``angular_velocity``).
        angular_velocity : array_like, shape (..., 3), optional
            n = 3: the body angular velocity vector w.
        center : array_like, shape (..., n), optional
            The ball's centre (default ``rν``: on the plane through the origin).
        velocity : array_like, shape (..., n), optional
            The centre's velocity, checked against the rolling constraint (it follows from Ω).

        Returns
        -------
        dict of ndarray
            ``{"A", "Gamma"}`` and, as tracked, ``"R"`` and ``"center"``.
        """
        Om, Rm, p = rolling_initial_kinematics(self, R, Omega, angular_velocity, center, velocity)
        Gam = np.swapaxes(Rm, -1, -2) @ self.normal
        return self._add_pose({"A": self.momentum(Om, Gam), "Gamma": Gam}, Rm, p)

    def validate_state(self, y: Mapping[str, np.ndarray], name: str = "y0") -> State:
        out = super().validate_state(y, name)
        out["A"] = check_skew(out["A"], f"{name}['A']")
        return self._validate_pose(out, name)

    # -- numeric parameters (lieint.sensitivity) ------------------------------------------
    def parameter_values(self) -> dict[str, np.ndarray]:
        """The numeric parameters a run can be differentiated by (:func:`lieint.sensitivity`).

        Returns
        -------
        dict of ndarray
            ``mass_tensor``, ``mass`` and ``radius``.
        """
        return {"mass_tensor": self.B_C.copy(), "mass": np.array(self.mass), "radius": np.array(self.radius)}

    def parameter_refusals(self) -> dict[str, str]:
        """Numeric arguments not offered as parameters, with why.

        Returns
        -------
        dict of str
            ``normal``: it fixes the frame in which the state's ``Γ = Rᵀν`` is read.
        """
        return {"normal": NORMAL_REFUSAL}

    def _assign_parameter(self, name: str, value: np.ndarray) -> None:
        if name == "mass_tensor":
            self.B_C = value
        elif name == "mass":
            self.mass = value
        else:
            self.radius = value
        self._Mr2 = self.mass * self.radius**2

    def __repr__(self) -> str:
        return (
            f"ChaplyginBall(n={self.n}, mass={self.mass:g}, radius={self.radius:g}, "
            f"normal={describe(self.normal)}, fields={list(self.fields)})"
        )
