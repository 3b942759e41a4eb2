"""A ball rolling without sliding on a fixed plane, any n ≥ 2 (docs/theory.md §4).

Body frame (what is integrated), with ``Γ = Rᵀν``, ``G = Rᵀg``, ``κ = rΓ``::

    B_K Ω̇ + Ω̇ B_K = B_K Ω² − Ω² B_K − M (X_G + κ) ∧ (G + Ω²κ),
    B_K = B_C + M (X_G κᵀ + κ X_Gᵀ) + M κκᵀ,   Γ̇ = −ΩΓ,   Ġ = −ΩG,

and the pose on SE(n): ``Ṙ = RΩ``, centre ``ṗ = r RΩΓ`` (body twist ``(Ω, rΩΓ)``). The
Lyapunov equation is solved in the eigenbasis of ``B_K`` at each evaluation.

The group is ``SE(n) × so(n)``: the pose part moves (Γ, G, R, centre) by
``(Q, v)·(Γ, G, R, p) = (QᵀΓ, QᵀG, RQ, p + Rv)`` and the vector-space part adds to Ω. So a
Lie-group method keeps ``|Γ|`` and R on SO(n), and the rolling constraint ``ṗ = ω k`` holds
along the computed path by construction.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .._validation import (
    as_bivector_array,
    as_rotation_array,
    check_finite_positive,
    check_rotation,
    check_skew,
    check_vector,
    describe,
)
from ..fast.forms import BUILTIN_PIECES, PiecesForm, RollingBall3Form
from ..groups.bivectors import hat, inner, skew_part, wedge
from ..groups.se import SE, se_join, se_split
from ..groups.so import SO, project_to_so
from ..groups.vector import ProductGroup, VectorSpace
from .base import Invariant, LieGroupSystem, Output, State
from .mass import check_mass_tensor, solve_lyapunov
from .rigid import orientation_output, pose_invariants

#: what the compiled declaration stands for (see :meth:`LieGroupSystem.dynamics_as`)
_DYNAMICS = (
    "generator", "act", "infinitesimal_action", "vector_field", "project", "contact_mass_tensor", "body_gravity",
    "angular_acceleration", "_twist", "_move_pose", "_pose_rate", "_project_pose",
)  # fmt: skip

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

__all__ = ["NORMAL_REFUSAL", "RollingBall", "RollingPose", "check_ball", "rolling_initial_kinematics"]

#: why a ball's plane normal is not a parameter of :func:`lieint.sensitivity`
NORMAL_REFUSAL = (
    "the plane's normal fixes the frame in which the state's Γ = Rᵀν is read; turn the initial attitude "
    "instead (lieint.tangent_flow)"
)


def check_ball(mass_tensor, mass, radius, center_of_mass=None, normal=None):
    """Validate the physical data of a ball; return ``(B_C, M, r, X_G, ν)``.

    Checks: r > 0, M > 0, ``|X_G| < r``, ν nonzero (normalised), and that ``B_C`` is the mass
    tensor of a body inside the ball: symmetric, ``B_C − M X_G X_Gᵀ ⪰ 0`` (a covariance) and
    ``tr B_C ≤ M r²`` (every particle within distance r of the centre).
    """
    B, _, _ = check_mass_tensor(mass_tensor, "mass_tensor")
    n = B.shape[0]
    M = check_finite_positive(mass, "mass")
    r = check_finite_positive(radius, "radius")
    XG = np.zeros(n) if center_of_mass is None else check_vector(center_of_mass, "center_of_mass", n)
    if np.linalg.norm(XG) >= r:
        raise ValueError(
            f"`center_of_mass` must lie inside the ball (|X_G| < radius = {r:g}); got |X_G| = {np.linalg.norm(XG):.6g}."
        )
    if normal is None:
        nu = np.eye(n)[-1]
    else:
        nu = check_vector(normal, "normal", n)
        norm = np.linalg.norm(nu)
        if norm == 0.0:
            raise ValueError("`normal` must be a nonzero vector (the plane's upward normal); got the zero vector.")
        nu = nu / norm
    cov = B - M * np.outer(XG, XG)
    lam = np.linalg.eigvalsh(cov)
    scale = max(np.max(np.abs(B)), M * r * r)
    if lam[0] < -1e-12 * scale:
        raise ValueError(
            "`mass_tensor` is not the mass tensor of a body with this centre of mass: B_C − M X_G X_Gᵀ "
            f"must be positive semi-definite; its eigenvalues are {describe(lam)}."
        )
    if np.trace(B) > M * r * r * (1 + 1e-12):
        raise ValueError(
            f"`mass_tensor` is not the mass tensor of a body inside the ball: tr B_C = ∫ m|X|² must be "
            f"<= M r² = {M * r * r:.6g}; got {np.trace(B):.6g}."
        )
    return B, M, r, XG, nu


class RollingPose:
    """The pose of a ball on SE(n), shared by :class:`RollingBall` and the Chaplygin ball.

    ``(Q, v)·(R, p) = (RQ, p + Rv)`` with the body twist ``(Ω, rΩΓ)``; R is carried when an
    output needs it or when the centre is tracked (the centre moves by R v). Subclasses set
    ``fields``, ``track_center``, ``normal`` and ``radius``.
    """

    @property
    def orientation_is_passive(self) -> bool:
        """R moves only itself unless the centre is tracked (it moves by ``p + R v``)."""
        return not self.track_center

    def _parameter_state_change(self, name: str, direction: np.ndarray, y: State) -> State:
        if name == "radius" and self.track_center:  # the ball stays on the plane: the centre at height r
            return {"center": direction * self.normal}
        if name == "gravity":
            if "R" not in y:
                raise ValueError(
                    "`parameters` names 'gravity', which enters a tilted rolling ball through its state G = Rᵀg; "
                    "without the attitude R in the state G cannot follow g (build the ball with orientation=True)."
                )
            return {"G": (np.swapaxes(y["R"], -1, -2) @ direction[:, None])[..., 0]}
        return {}

    def _pose_fields(self, n: int, orientation: bool) -> None:
        if orientation or self.track_center:  # the centre moves by p + R v: it needs R
            self.fields["R"] = (n, n)
        if self.track_center:
            self.fields["center"] = (n,)

    def _split(self, g):
        """``(Q, v)`` of a pose element (``v`` None without the centre)."""
        return se_split(g) if self.track_center else (g, None)

    def _twist(self, Om, Gamma):
        """The algebra element of the pose: ``(Ω, rΩΓ)`` on se(n), or Ω on so(n)."""
        if not self.track_center:
            return Om
        return se_join(Om, self.radius * (Om @ Gamma[..., None])[..., 0], algebra=True)

    def _move_pose(self, out: State, y: State, Q, v) -> None:
        if "R" in self.fields:
            out["R"] = y["R"] @ Q
        if self.track_center:
            out["center"] = y["center"] + (y["R"] @ v[..., None])[..., 0]

    def _pose_rate(self, out: State, y: State, Om, V) -> None:
        if "R" in self.fields:
            out["R"] = y["R"] @ Om
        if self.track_center:
            out["center"] = (y["R"] @ V[..., None])[..., 0]

    def _project_pose(self, out: State, y: State) -> None:
        if "R" in self.fields:
            out["R"] = project_to_so(y["R"])
        if self.track_center:
            # back onto the constraint ⟨p, ν⟩ = r (the SE(n) step keeps it to truncation error)
            height = y["center"] @ self.normal - self.radius
            out["center"] = y["center"] - height[..., None] * self.normal

    def _add_pose(self, state: State, Rm, p) -> State:
        if "R" in self.fields:
            state["R"] = Rm
        if self.track_center:
            state["center"] = p
        return state

    def _validate_pose(self, out: State, name: str) -> State:
        if "R" in self.fields:
            check_rotation(out["R"], f"{name}['R']", atol=1e-9)
        return out

    def contact_point(self, center: np.ndarray) -> np.ndarray:
        """Contact point ``K = q_C − rν`` on the plane.

        Parameters
        ----------
        center : ndarray, shape (..., n)
            The ball's centre ``q_C``.

        Returns
        -------
        ndarray, shape (..., n)
            K.
        """
        return center - self.radius * self.normal

    def _pose_outputs(self, out: dict) -> dict:
        """Orientation, centre and contact path where the state carries them."""
        n = self.n
        if "R" in self.fields:
            out["orientation"] = orientation_output(n)
        if self.track_center:
            out["contact_path"] = Output(
                lambda t, y: self.contact_point(y["center"]), (n,), "contact point K on the plane", "point"
            )
        out["gamma"] = Output(lambda t, y: y["Gamma"], (n,), "body normal Γ = Rᵀν", "vector")
        return out


class RollingBall(RollingPose, LieGroupSystem):
    """A ball of radius r rolling without sliding on the plane ``⟨q, ν⟩ = 0``.

    Parameters
    ----------
    mass_tensor : array_like, shape (n, n)
        ``B_C = ∫ m X Xᵀ`` about the geometric centre C (the body origin).
    mass : float
        Total mass M.
    radius : float
        Radius r.
    center_of_mass : array_like, shape (n,), optional
        ``X_G`` relative to C in the body frame (default 0).
    gravity : array_like, shape (n,), optional
        Gravity g in space; None (default) means no gravity. A g not parallel to ν is an
        incline.
    normal : array_like, shape (n,), optional
        Upward unit normal ν of the plane (default ``e_n``).
    orientation : bool, default True
        Integrate R (needed for the orientation output; always integrated with the centre).
    track_center : bool, default True
        Integrate the centre (needed for the centre, the contact path, and the energy on an
        incline).

    Notes
    -----
    State fields: ``"Omega"`` (body angular velocity), ``"Gamma"`` (``Rᵀν``), ``"G"`` (``Rᵀg``,
    only for a tilted gravity), ``"R"``, ``"center"`` (as requested).

    Invariants: ``energy`` ``T − U`` (``T = −½ tr(Ω B_K Ω)``, ``U = M⟨g, q_C + R X_G⟩``),
    ``gamma_norm`` ``|Γ|``, ``orthogonality``.

    Examples
    --------
    A ball whose centre of mass is off its centre, rolling under gravity:

    >>> import numpy as np, lieint
    >>> ball = lieint.RollingBall(
    ...     np.diag([0.10, 0.15, 0.20]), mass=1.0, radius=1.0, center_of_mass=[0.0, 0.1, -0.2], gravity=[0, 0, -9.81]
    ... )
    >>> y0 = ball.initial_state(angular_velocity=[0.3, 1.0, 2.0])
    >>> sol = lieint.integrate(ball, y0, (0.0, 5.0), h=0.005, method="rkmk4")
    >>> list(sol.states)
    ['Omega', 'Gamma', 'R', 'center']
    >>> bool(sol.drift("energy") < 1e-10 and sol.drift("gamma_norm") < 1e-13)
    True
    """

    autonomous = True
    structure = frozenset({"rolling_ball"})

    def __init__(
        self,
        mass_tensor: ArrayLike,
        mass: float,
        radius: float,
        center_of_mass: ArrayLike | None = None,
        gravity: ArrayLike | None = None,
        normal: ArrayLike | None = None,
        *,
        orientation: bool = True,
        track_center: bool = True,
    ):
        self.B_C, self.mass, self.radius, self.center_of_mass, self.normal = check_ball(
            mass_tensor, mass, radius, center_of_mass, normal
        )
        n = self.n = self.B_C.shape[0]
        self.gravity = None if gravity is None else check_vector(gravity, "gravity", n)
        for flag, label in ((orientation, "orientation"), (track_center, "track_center")):
            if not isinstance(flag, (bool, np.bool_)):
                raise TypeError(f"`{label}` must be True or False; got {flag!r}.")
        self.orientation, self.track_center = bool(orientation), bool(track_center)
        # Gravity along ν needs no field of its own: G = c Γ with c = ⟨g, ν⟩.
        self._tilted = self.gravity is not None and np.linalg.norm(
            self.gravity - (self.gravity @ self.normal) * self.normal
        ) > 1e-14 * np.linalg.norm(self.gravity)
        self._g_normal = 0.0 if self.gravity is None else float(self.gravity @ self.normal)
        self._offset = bool(np.any(self.center_of_mass != 0))
        self.fields = {"Omega": (n, n), "Gamma": (n,)}
        if self._tilted:
            self.fields["G"] = (n,)
        self._pose_fields(n, self.orientation)
        pose = SE(n) if self.track_center else SO(n)
        self.group = ProductGroup(pose, VectorSpace((n, n), antisymmetric=True))

    # -- physics -----------------------------------------------------------------------
    def contact_mass_tensor(self, Gamma: np.ndarray) -> np.ndarray:
        """The mass tensor about the contact, ``B_K = B_C + M (X_G κᵀ + κ X_Gᵀ) + M κκᵀ``, ``κ = rΓ``.

        Parameters
        ----------
        Gamma : ndarray, shape (..., n)
            ``Γ = Rᵀν``.

        Returns
        -------
        ndarray, shape (..., n, n)
            ``B_K``.
        """
        k = self.radius * Gamma
        M = self.mass
        BK = self.B_C + M * k[..., :, None] * k[..., None, :]
        if self._offset:
            XG = self.center_of_mass
            BK = BK + M * (XG[:, None] * k[..., None, :] + k[..., :, None] * XG[None, :])
        return BK

    def body_gravity(self, y: State) -> np.ndarray | None:
        """``G = Rᵀg`` (None without gravity).

        Parameters
        ----------
        y : dict of ndarray
            States (any leading shape).

        Returns
        -------
        ndarray or None
            G, shape ``(..., n)``.
        """
        if self.gravity is None:
            return None
        return y["G"] if self._tilted else self._g_normal * y["Gamma"]

    def angular_acceleration(self, y: State) -> np.ndarray:
        """``Ω̇`` from equation (*) in the body frame (Lyapunov solve in the eigenbasis of B_K).

        Parameters
        ----------
        y : dict of ndarray
            States (any leading shape).

        Returns
        -------
        ndarray, shape (..., n, n)
            ``Ω̇``.
        """
        Om, Gam = y["Omega"], y["Gamma"]
        k = self.radius * Gam
        BK = self.contact_mass_tensor(Gam)
        Om2 = Om @ Om
        Om2k = (Om2 @ k[..., None])[..., 0]
        G = self.body_gravity(y)
        force = Om2k if G is None else G + Om2k
        lever = k + self.center_of_mass if self._offset else k
        C = BK @ Om2 - Om2 @ BK - self.mass * wedge(lever, force)
        return solve_lyapunov(BK, C)

    def kinetic_energy(self, y: State) -> np.ndarray:
        """``T = −½ tr(Ω B_K Ω) = ½⟨Ω, B_K Ω⟩``.

        Parameters
        ----------
        y : dict of ndarray
            States (any leading shape).

        Returns
        -------
        ndarray
            T per state.
        """
        Om = y["Omega"]
        return 0.5 * inner(Om, self.contact_mass_tensor(y["Gamma"]) @ Om)

    def energy(self, y: State) -> np.ndarray:
        """``H = T − U``, ``U = M⟨g, q_C + R X_G⟩ = M(⟨g, p⟩ + ⟨G, X_G⟩)``.

        Parameters
        ----------
        y : dict of ndarray
            States (any leading shape).

        Returns
        -------
        ndarray
            H per state.
        """
        T = self.kinetic_energy(y)
        if self.gravity is None:
            return T
        G = self.body_gravity(y)
        U = self.mass * (G @ self.center_of_mass)
        if self._tilted:
            U = U + self.mass * (y["center"] @ self.gravity)
        else:  # ⟨g, p⟩ = c⟨ν, p⟩ = c r on the plane
            U = U + self.mass * self._g_normal * self.radius
        return T - U

    def compiled(self) -> PiecesForm | None:
        """The compiled engine's form (:class:`lieint.fast.forms.PiecesForm`) for n ≥ 3.

        The rolling ball's pieces in :mod:`lieint.fast.balls`; parameters n, the offsets of R, the centre and G, M, r,
        the gravity mode (0 none, 1 along ν with ``G = ⟨g, ν⟩Γ``, 2 tilted: G a field),
        ``⟨g, ν⟩``, ``|g|``, ``B_C``, ``X_G``, ν and g (the energy); the vector factor carries ``δΩ`` (n²);
        for n = 3 also the form of its ensembles in SIMD lanes (:class:`lieint.fast.forms.RollingBall3Form`).

        Returns
        -------
        PiecesForm or None
            The form, or None (n = 2, or a subclass with other dynamics).
        """
        if self.n < 3 or not self.dynamics_as(RollingBall, _DYNAMICS):
            return None
        gravity = self.gravity
        # every number of the declaration (comparing them is cheaper than building its parameters)
        key = (tuple(self.fields), self.track_center, self.mass, self.radius, self._tilted, self._g_normal)
        key += (None if gravity is None else gravity.tobytes(), self.B_C.tobytes(), self.center_of_mass.tobytes())
        key += (self.normal.tobytes(),)

        def build():
            offset = self.field_offsets()
            mode = 0 if gravity is None else (2 if self._tilted else 1)
            gnorm = 0.0 if gravity is None else float(np.linalg.norm(gravity))
            head = [self.n, offset.get("R", -1), offset.get("center", -1), offset.get("G", -1)]
            head += [self.mass, self.radius, mode, self._g_normal, gnorm]
            g = np.zeros(self.n) if gravity is None else gravity
            params = np.concatenate([head, self.B_C.ravel(), self.center_of_mass, self.normal, g])
            lanes = None
            if self.n == 3:  # ensembles of the 3D ball run in SIMD lanes
                lanes = RollingBall3Form(
                    self.B_C, self.mass, self.radius, self.center_of_mass, self.normal, mode, self._g_normal, gnorm,
                    "R" in self.fields, self.track_center,
                )  # fmt: skip
            return PiecesForm(
                BUILTIN_PIECES.rolling_ball, params, self.n, self.track_center, self.n * self.n, self.fields,
                lanes=lanes,
            )  # fmt: skip

        return self._declared_once(key, build)

    # -- the LieGroupSystem contract ---------------------------------------------------
    def generator(self, t: float | np.ndarray, y: State) -> np.ndarray | tuple[np.ndarray, ...]:
        return (self._twist(y["Omega"], y["Gamma"]), self.angular_acceleration(y))

    def act(self, g: np.ndarray | tuple[np.ndarray, ...], y: State) -> State:
        pose, dOm = g
        Q, v = self._split(pose)
        Qt = np.swapaxes(Q, -1, -2)
        out = {"Omega": y["Omega"] + dOm, "Gamma": (Qt @ y["Gamma"][..., None])[..., 0]}
        if self._tilted:
            out["G"] = (Qt @ y["G"][..., None])[..., 0]
        self._move_pose(out, y, Q, v)
        return out

    def infinitesimal_action(self, xi: np.ndarray | tuple[np.ndarray, ...], y: State) -> State:
        pose, dOm = xi
        Om, V = self._split(pose)
        out = {"Omega": dOm, "Gamma": -(Om @ y["Gamma"][..., None])[..., 0]}
        if self._tilted:
            out["G"] = -(Om @ y["G"][..., None])[..., 0]
        self._pose_rate(out, y, Om, V)
        return out

    def project(self, y: State) -> State:
        out = dict(y)
        out["Omega"] = skew_part(y["Omega"])
        out["Gamma"] = y["Gamma"] / np.linalg.norm(y["Gamma"], axis=-1, keepdims=True)
        if self._tilted:
            out["G"] = y["G"] * (np.linalg.norm(self.gravity) / np.linalg.norm(y["G"], axis=-1, keepdims=True))
        self._project_pose(out, y)
        return out

    @property
    def invariants(self) -> dict[str, Invariant]:
        declared = {"gamma_norm": Invariant(lambda t, y: np.linalg.norm(y["Gamma"], axis=-1), "integral", "|Γ|")}
        if not self._tilted or self.track_center:
            declared["energy"] = Invariant(lambda t, y: self.energy(y), "integral", "H = T − U")
        if "R" in self.fields:
            declared.update(pose_invariants(None))
        return declared

    @property
    def outputs(self) -> dict[str, Output]:
        n = self.n
        out = dict(super().outputs)
        out["angular_velocity"] = Output(lambda t, y: y["Omega"], (n, n), "body angular velocity Ω", "bivector")
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
            The ball's centre (default ``rν``, touching the plane at the origin).
        velocity : array_like, shape (..., n), optional
            The centre's space velocity, checked against the rolling constraint
            ``q̇_C = ω k = r R Ω Rᵀ ν``.

        Returns
        -------
        dict of ndarray
            ``{"Omega", "Gamma"}``, ``"G"`` for a tilted gravity and, as tracked, ``"R"``, ``"center"``.
        """
        Om, Rm, p = rolling_initial_kinematics(self, R, Omega, angular_velocity, center, velocity)
        Rt = np.swapaxes(Rm, -1, -2)
        state = {"Omega": Om, "Gamma": Rt @ self.normal}
        if self._tilted:
            state["G"] = Rt @ self.gravity
        return self._add_pose(state, Rm, p)

    def validate_state(self, y: Mapping[str, np.ndarray], name: str = "y0") -> State:
        out = super().validate_state(y, name)
        out["Omega"] = check_skew(out["Omega"], f"{name}['Omega']")
        return self._validate_pose(out, name)

    # -- numeric parameters (lieint.sensitivity) ------------------------------------------
    def parameter_values(self) -> dict[str, np.ndarray]:
        """The numeric parameters a run can be differentiated by (:func:`lieint.sensitivity`).

        Returns
        -------
        dict of ndarray
            ``mass_tensor``, ``mass``, ``radius``, ``center_of_mass`` and, on an incline, ``gravity``.
        """
        out = {
            "mass_tensor": self.B_C.copy(),
            "mass": np.array(self.mass),
            "radius": np.array(self.radius),
            "center_of_mass": self.center_of_mass.copy(),
        }
        if self._tilted:
            out["gravity"] = self.gravity.copy()
        return out

    def parameter_refusals(self) -> dict[str, str]:
        """Numeric arguments not offered as parameters, with why.

        Returns
        -------
        dict of str
            ``normal``, and a gravity along it or none (a tilt would add the state field G).
        """
        out = {"normal": NORMAL_REFUSAL}
        if not self._tilted:
            out["gravity"] = (
                "this ball's gravity is along the plane's normal (or absent), so its state has no field G = Rᵀg, "
                "which a tilt of g would add; build the ball with a tilted gravity to differentiate with respect to it"
            )
        return out

    def _assign_parameter(self, name: str, value: np.ndarray) -> None:
        if name == "mass_tensor":
            self.B_C = value
        elif name == "mass":
            self.mass = value
        elif name == "radius":
            self.radius = value
        elif name == "center_of_mass":
            self.center_of_mass, self._offset = value, True
        else:
            self.gravity = value

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(n={self.n}, mass={self.mass:g}, radius={self.radius:g}, "
            f"center_of_mass={describe(self.center_of_mass)}, gravity="
            f"{None if self.gravity is None else describe(self.gravity)}, normal={describe(self.normal)}, "
            f"fields={list(self.fields)})"
        )


def rolling_initial_kinematics(ball, R, Omega, angular_velocity, center, velocity):
    """Validated, broadcast ``(Ω, R, centre)`` of a ball's initial state.

    The centre (default ``rν``, touching the plane at the origin) must be at height r; a
    given centre ``velocity`` must satisfy the rolling constraint ``q̇_C = ω k = r R Ω Rᵀ ν``.
    """
    n = ball.n
    if (Omega is None) == (angular_velocity is None):
        raise ValueError("Give exactly one of `Omega` or `angular_velocity` to `initial_state`.")
    if angular_velocity is not None:
        if n != 3:
            raise ValueError(f"`angular_velocity` (a vector w with Ω = ŵ) needs n = 3; this ball has n = {n}.")
        Om = hat(check_vector(angular_velocity, "angular_velocity", 3, batch=True))
    else:
        Om = as_bivector_array(Omega, "Omega")
        if Om.shape[-2:] != (n, n):
            raise ValueError(f"`Omega` must have shape (..., {n}, {n}); got shape {Om.shape}.")
        Om = check_skew(Om, "Omega")
    Rm = np.eye(n) if R is None else as_rotation_array(R, "R")
    if Rm.shape[-2:] != (n, n):
        raise ValueError(f"`R` must have shape (..., {n}, {n}); got shape {Rm.shape}.")
    check_rotation(Rm, "R")
    r, nu = ball.radius, ball.normal
    p = r * nu if center is None else check_vector(center, "center", n, batch=True)
    height = p @ nu
    if np.max(np.abs(height - r)) > 1e-9 * r:
        raise ValueError(
            "`center` violates the rolling constraint: the centre must be at height r = "
            f"{r:g} above the plane (⟨center, ν⟩ = r); got heights {describe(np.asarray(height))}."
        )
    batch = np.broadcast_shapes(Om.shape[:-2], Rm.shape[:-2], p.shape[:-1])
    Om = np.broadcast_to(Om, batch + (n, n)).copy()
    Rm = np.broadcast_to(Rm, batch + (n, n)).copy()
    if velocity is not None:
        vel = check_vector(velocity, "velocity", n, batch=True)
        expected = r * (Rm @ Om @ np.swapaxes(Rm, -1, -2) @ nu)
        if np.max(np.abs(vel - expected)) > 1e-9 * max(1.0, np.max(np.abs(expected))):
            raise ValueError(
                "`velocity` violates the rolling constraint q̇_C = ω k (no sliding): with this Ω and R "
                f"the centre moves with {describe(expected)}; got {describe(vel)}."
            )
    return Om, Rm, np.broadcast_to(p, batch + (n,)).copy()
