"""The heavy top: a rigid body with a fixed point under constant gravity (docs/theory.md §3)."""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .._validation import check_finite_positive, check_rotation, check_skew, check_vector, describe
from ..fast.forms import BUILTIN_PIECES, HeavyTop3Form, PiecesForm
from ..groups.bivectors import skew_part, vee, wedge
from ..groups.se import SE, se_join, se_split
from ..groups.so import project_to_so
from .base import Invariant, LieGroupSystem, Output, State
from .euler_top import EulerTop
from .invariants import skew_spectrum
from .mass import check_mass_tensor, moments_tensor
from .rigid import momentum_outputs, orientation_output, pose_invariants

__all__ = ["HeavyTop"]

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

#: what the compiled declaration stands for (see :meth:`LieGroupSystem.dynamics_as`)
_DYNAMICS = ("generator", "act", "infinitesimal_action", "vector_field", "project")
_TOP = ("angular_velocity",)


class HeavyTop(LieGroupSystem):
    """A rigid body with a fixed point and centre of mass ``X_G`` under gravity g, any n ≥ 2.

    State ``{"A", "Gamma", "R"}``: body momentum bivector A, body gravity ``Γ = Rᵀg`` and
    orientation R. Equations::

        Ȧ = [A, Ω] + M X_G ∧ Γ,   Γ̇ = −ΩΓ,   Ṙ = RΩ,   A = −(BΩ + ΩB).

    SE(n) acts on the right, ``(Q, v) · (A, Γ, R) = (Qᵀ(A + v ∧ Γ)Q, QᵀΓ, RQ)``, with generator
    ``(Ω(A), M X_G)``: a Lie-group method keeps ``|Γ|`` and the Casimirs to round-off.

    Parameters
    ----------
    mass_tensor : array_like, shape (n, n)
        Body mass tensor ``B = ∫ m X Xᵀ`` about the fixed point.
    mass : float
        Total mass M > 0.
    center_of_mass : array_like, shape (n,)
        Centre of mass ``X_G`` in the body frame, relative to the fixed point.
    gravity : array_like, shape (n,)
        Gravity g in space (e.g. ``(0, 0, −9.81)``).
    orientation : bool, default True
        Integrate R too; without it the state is (A, Γ), which is all the dynamics needs.

    Notes
    -----
    Structure tag ``"heavy_top"`` (``inertia``, ``mass``, ``center_of_mass``, ``gravity``).
    Outputs: ``angular_momentum``, ``angular_velocity``, ``gamma`` (Γ), ``orientation``.
    Invariants: ``energy`` ``T − U`` with ``U = M⟨Γ, X_G⟩``; ``casimirs``: n = 3 ``⟨Π, Γ⟩`` (``A = −Π̂``),
    n ≥ 4 the rotation angles of ``P_Γ A P_Γ`` (A restricted to ``Γ^⊥``, which ``v ∧ Γ`` cannot
    change); ``gamma_norm`` ``|Γ|``; ``orthogonality``. Named constructors add the extra
    integral of their case (``spin`` for Lagrange, ``kovalevskaya``).

    Examples
    --------
    >>> import lieint
    >>> top = lieint.HeavyTop.lagrange(1.0, 0.5, mass=1.0, length=0.2)  # a fast symmetric top
    >>> y0 = top.initial_state(angular_velocity=[0.1, 0.0, 20.0])
    >>> sol = lieint.integrate(top, y0, (0.0, 2.0), h=0.001, method="rkmk4")
    >>> bool(sol.drift("casimirs") < 1e-12 and sol.drift("spin") < 1e-12 and sol.drift("energy") < 1e-12)
    True
    """

    autonomous = True
    structure = frozenset({"heavy_top"})
    #: R moves only itself and nothing reads it (lets the rotor form skip computing it)
    orientation_is_passive = True

    def __init__(
        self,
        mass_tensor: ArrayLike,
        mass: float,
        center_of_mass: ArrayLike,
        gravity: ArrayLike,
        *,
        orientation: bool = True,
    ):
        check_mass_tensor(mass_tensor, "mass_tensor")  # the potential needs a body: B ⪰ 0
        self.top = EulerTop(mass_tensor, orientation=False)
        self.inertia = self.top.inertia
        self.B, self.n = self.top.B, self.top.n
        n = self.n
        self.mass = check_finite_positive(mass, "mass")
        self.center_of_mass = check_vector(center_of_mass, "center_of_mass", n)
        if gravity is None:
            raise ValueError("`gravity` must be a vector of dimension n; a top without gravity is lieint.EulerTop.")
        self.gravity = check_vector(gravity, "gravity", n)
        if not isinstance(orientation, (bool, np.bool_)):
            raise TypeError(f"`orientation` must be True or False; got {orientation!r}.")
        self.orientation = bool(orientation)
        self.group = SE(n)
        self.fields = {"A": (n, n), "Gamma": (n,)}
        if self.orientation:
            self.fields["R"] = (n, n)
        self._MXG = self.mass * self.center_of_mass
        self._extra: dict = {}

    # -- named cases (n = 3) -----------------------------------------------------------
    @classmethod
    def lagrange(
        cls, I1: float, I3: float, mass: float, length: float, g: float = 9.81, *, orientation: bool = True
    ) -> HeavyTop:
        """Lagrange top: symmetric ``I₁ = I₂``, centre of mass on the axis, ``X_G = (0, 0, ℓ)``.

        Extra first integral ``spin``: the body angular velocity ``w₃`` about the axis.

        Parameters
        ----------
        I1 : float
            Equatorial principal moment ``I₁ = I₂`` about the fixed point.
        I3 : float
            Axial moment (a body needs ``I₃ ≤ 2 I₁``).
        mass : float
            Total mass M.
        length : float
            Distance ℓ from the fixed point to the centre of mass along the axis.
        g : float, default 9.81
            Gravity's magnitude (pointing along −e₃ in space).
        orientation : bool, default True
            Integrate R too.

        Returns
        -------
        HeavyTop
            The top, with the invariant ``spin``.
        """
        top = cls._principal([I1, I1, I3], mass, [0.0, 0.0, length], g, orientation=orientation)
        top._extra["spin"] = Invariant(
            lambda t, y: vee(top.top.angular_velocity(y["A"]))[..., 2], "integral", "spin w₃ about the axis"
        )
        return top

    @classmethod
    def kovalevskaya(
        cls, I3: float, mass: float, length: float, g: float = 9.81, *, orientation: bool = True
    ) -> HeavyTop:
        """Kovalevskaya top: ``I₁ = I₂ = 2 I₃``, centre of mass in the equatorial plane, ``X_G = (ℓ, 0, 0)``.

        Extra first integral ``kovalevskaya``: ``(p² − q² + c Γ₁)² + (2pq + c Γ₂)²`` with
        ``w = (p, q, r)`` and ``c = M ℓ / I₃`` (Γ = Rᵀg points down).

        Parameters
        ----------
        I3 : float
            Axial principal moment (the equatorial ones are ``2 I₃``).
        mass : float
            Total mass M.
        length : float
            Distance ℓ from the fixed point to the centre of mass, along e₁.
        g : float, default 9.81
            Gravity's magnitude (pointing along −e₃ in space).
        orientation : bool, default True
            Integrate R too.

        Returns
        -------
        HeavyTop
            The top, with the invariant ``kovalevskaya``.
        """
        top = cls._principal([2 * I3, 2 * I3, I3], mass, [length, 0.0, 0.0], g, orientation=orientation)
        c = mass * length / I3

        def kovalevskaya(t, y):
            w = vee(top.top.angular_velocity(y["A"]))
            p, q = w[..., 0], w[..., 1]
            G = y["Gamma"]
            return (p * p - q * q + c * G[..., 0]) ** 2 + (2 * p * q + c * G[..., 1]) ** 2

        top._extra["kovalevskaya"] = Invariant(kovalevskaya, "integral", "Kovalevskaya's integral")
        return top

    @classmethod
    def _principal(cls, moments, mass, center, g, **kw) -> HeavyTop:
        g = check_finite_positive(g, "g")
        B = moments_tensor(moments, "moments")  # a body: the triangle inequality
        return cls(B, mass, center, [0.0, 0.0, -g], **kw)

    # -- the LieGroupSystem contract ---------------------------------------------------
    def generator(self, t: float | np.ndarray, y: State) -> np.ndarray:
        Om = self.top.angular_velocity(y["A"])
        return se_join(Om, np.broadcast_to(self._MXG, Om.shape[:-1]), algebra=True)

    def act(self, g: np.ndarray, y: State) -> State:
        Q, v = se_split(g)
        Qt = np.swapaxes(Q, -1, -2)
        Gam = y["Gamma"]
        out = {"A": Qt @ (y["A"] + wedge(v, Gam)) @ Q, "Gamma": (Qt @ Gam[..., None])[..., 0]}
        if self.orientation:
            out["R"] = y["R"] @ Q
        return out

    def infinitesimal_action(self, xi: np.ndarray, y: State) -> State:
        Om, V = se_split(xi)
        A, Gam = y["A"], y["Gamma"]
        out = {"A": A @ Om - Om @ A + wedge(V, Gam), "Gamma": -(Om @ Gam[..., None])[..., 0]}
        if self.orientation:
            out["R"] = y["R"] @ Om
        return out

    def project(self, y: State) -> State:
        Gam = y["Gamma"]
        scale = np.linalg.norm(self.gravity) / np.linalg.norm(Gam, axis=-1, keepdims=True)
        out = {"A": skew_part(y["A"]), "Gamma": Gam * scale}
        if self.orientation:
            out["R"] = project_to_so(y["R"])
        return out

    def compiled(self) -> PiecesForm | None:
        """The compiled engine's form (:class:`lieint.fast.forms.PiecesForm`) for n ≥ 3.

        The heavy top's pieces in :mod:`lieint.fast.bodies`; parameters n, the offset of R,
        whether B is diagonal, the eigenbasis P of B, ``−1/(b_i + b_j)``, ``M X_G`` and ``|g|``;
        for n = 3 also the form of its ensembles in SIMD lanes (:class:`lieint.fast.forms.HeavyTop3Form`).

        Returns
        -------
        PiecesForm or None
            The form, or None (n = 2, or a subclass with other dynamics).
        """
        if self.n < 3 or not self.dynamics_as(HeavyTop, _DYNAMICS) or not self.top.dynamics_as(EulerTop, _TOP):
            return None
        inertia, n, gravity = self.inertia, self.n, self.gravity
        # every number of the declaration (comparing them is cheaper than building its parameters)
        key = (tuple(self.fields), inertia.diagonal, inertia.kernel_params.tobytes(), self._MXG.tobytes())
        key += (gravity.tobytes(),)

        def build():
            head = [n, self.field_offsets().get("R", -1), float(inertia.diagonal)]
            g = math.sqrt(float(gravity @ gravity))  # np.linalg.norm's numbers, without its wrapper
            params = np.concatenate([head, inertia.kernel_params, self._MXG, [g]])
            lanes = None
            if n == 3:  # ensembles of the 3D heavy top run in SIMD lanes
                top = self.top
                lanes = HeavyTop3Form(top.principal_moments, top.P, self._MXG, g, self.orientation)
            return PiecesForm(BUILTIN_PIECES.heavy_top, params, n, True, 0, self.fields, lanes=lanes)

        return self._declared_once(key, build)

    # -- physics -----------------------------------------------------------------------
    def energy(self, A: np.ndarray, Gamma: np.ndarray) -> np.ndarray:
        """``H = T − U``: ``T = ¼ tr(ΩA)``, ``U = M⟨Γ, X_G⟩``.

        Parameters
        ----------
        A : ndarray, shape (..., n, n)
            Body angular momentum bivectors.
        Gamma : ndarray, shape (..., n)
            Body gravity ``Γ = Rᵀg``.

        Returns
        -------
        ndarray, shape (...)
            H.
        """
        return self.top.energy(A) - Gamma @ self._MXG

    def casimirs(self, A: np.ndarray, Gamma: np.ndarray) -> np.ndarray:
        """The Casimirs: n = 3 ``⟨Π, Γ⟩``; n ≥ 4 the rotation angles of ``P_Γ A P_Γ``.

        Parameters
        ----------
        A : ndarray, shape (..., n, n)
            Body angular momentum bivectors (``A = −Π̂`` for n = 3).
        Gamma : ndarray, shape (..., n)
            Body gravity ``Γ = Rᵀg``.

        Returns
        -------
        ndarray, shape (..., k)
            n = 3: ``k = 1``; n ≥ 4: ``k = ⌊(n − 1)/2⌋`` angles.
        """
        if self.n == 3:
            return np.sum(-vee(A) * Gamma, axis=-1, keepdims=True)
        u = Gamma / np.linalg.norm(Gamma, axis=-1, keepdims=True)
        P = np.eye(self.n) - u[..., :, None] * u[..., None, :]
        return skew_spectrum(P @ A @ P)[..., : (self.n - 1) // 2]

    @property
    def invariants(self) -> dict[str, Invariant]:
        declared = {
            "energy": Invariant(lambda t, y: self.energy(y["A"], y["Gamma"]), "integral", "H = T − U"),
            "casimirs": Invariant(lambda t, y: self.casimirs(y["A"], y["Gamma"]), "integral", "Casimirs of se(n)*"),
            "gamma_norm": Invariant(lambda t, y: np.linalg.norm(y["Gamma"], axis=-1), "integral", "|Γ|"),
        }
        if self.orientation:
            declared.update(pose_invariants(None))
        declared.update(self._extra)
        return declared

    @property
    def outputs(self) -> dict[str, Output]:
        n = self.n
        out = dict(super().outputs)
        out.update(momentum_outputs(n, lambda y: self.top.angular_velocity(y["A"])))
        out["gamma"] = Output(lambda t, y: y["Gamma"], (n,), "body gravity Γ = Rᵀg", "vector")
        if self.orientation:
            out["orientation"] = orientation_output(n)
        return out

    # -- states ------------------------------------------------------------------------
    def initial_state(
        self,
        *,
        R: ArrayLike | Rotation | None = None,
        Omega: ArrayLike | None = None,
        A: ArrayLike | None = None,
        angular_velocity: ArrayLike | None = None,
    ) -> State:
        """State from the orientation R and one of ``Omega``, ``A`` or (n = 3) ``angular_velocity``.

        ``Γ = Rᵀ g``. Leading batch dimensions broadcast.

        Parameters
        ----------
        R : array_like, shape (..., n, n), or scipy Rotation, optional
            Orientation, body to space (default: the identity).
        Omega : array_like, shape (..., n, n), optional
            Body angular velocity bivector.
        A : array_like, shape (..., n, n), optional
            Body angular momentum bivector.
        angular_velocity : array_like, shape (..., 3), optional
            n = 3: the body angular velocity vector w.

        Returns
        -------
        dict of ndarray
            ``{"A", "Gamma", "R"}`` (without R when ``orientation=False``).
        """
        top = EulerTop(self.B, orientation=True)
        s = top.initial_state(Omega=Omega, A=A, R=R, angular_velocity=angular_velocity)
        Rm = s["R"]
        out = {"A": s["A"], "Gamma": np.swapaxes(Rm, -1, -2) @ self.gravity}
        if self.orientation:
            out["R"] = Rm
        return out

    def validate_state(self, y: Mapping[str, np.ndarray], name: str = "y0") -> State:
        out = super().validate_state(y, name)  # every field a finite float array of its shape
        out["A"] = check_skew(out["A"], f"{name}['A']")  # the top's check of its momentum
        if self.orientation:
            check_rotation(out["R"], f"{name}['R']", atol=1e-9)
        return out

    # -- numeric parameters (lieint.sensitivity) ------------------------------------------
    def parameter_values(self) -> dict[str, np.ndarray]:
        """The numeric parameters a run can be differentiated by (:func:`lieint.sensitivity`).

        Returns
        -------
        dict of ndarray
            ``mass_tensor``, ``mass``, ``center_of_mass`` and ``gravity``.
        """
        return {
            "mass_tensor": self.B.copy(),
            "mass": np.array(self.mass),
            "center_of_mass": self.center_of_mass.copy(),
            "gravity": self.gravity.copy(),
        }

    def _assign_parameter(self, name: str, value: np.ndarray) -> None:
        if name == "mass_tensor":
            self.top = copy.copy(self.top)
            self.top._assign_parameter("B", value)
            self.inertia, self.B = self.top.inertia, self.top.B
        elif name == "mass":
            self.mass = value
        elif name == "center_of_mass":
            self.center_of_mass = value
        else:
            self.gravity = value
        self._MXG = self.mass * self.center_of_mass

    def _parameter_state_change(self, name: str, direction: np.ndarray, y: State) -> State:
        if name != "gravity":
            return {}
        if "R" not in y:
            raise ValueError(
                "`parameters` names 'gravity', which enters the heavy top only through its state Γ = Rᵀg; without "
                "the attitude R in the state (orientation=False) Γ cannot follow g. Build the top with "
                "orientation=True, or differentiate with respect to Gamma (lieint.tangent_flow)."
            )
        return {"Gamma": (np.swapaxes(y["R"], -1, -2) @ direction[:, None])[..., 0]}

    def __repr__(self) -> str:
        return (
            f"HeavyTop(n={self.n}, b={describe(self.top.b)}, mass={self.mass:g}, "
            f"center_of_mass={describe(self.center_of_mass)}, gravity={describe(self.gravity)})"
        )
