"""A rigid body in projective geometric algebra: the pose a motor, momenta and forces lines.

Following Dorst & De Keninck ("May the Forque Be with You") and De Keninck ("Look, Ma, No
Matrices!"), in the PGA Cl(3,0,1) of :mod:`lieint.ga.pga`:

* the pose is a unit motor M (body → space, ``X_space = M X_body M̃``);
* the body velocity is the twist bivector ``B = ω − Σ v_i e0i`` with ``Ṁ = ½ M B``;
* the momentum is a line: the total momentum ``M v`` through the centre of mass plus the
  angular momentum about it (a line at infinity). It is stored in space orientation as seen
  from the reference point c (the centre of mass, or the pivot): ``P_c = T̃_c P T_c``. Since
  ``ċ ∥ M v``, it changes only by the applied forces seen from c: ``Ṗ_c = Σ T̃_c F T_c``. (About
  the fixed origin instead, a falling body's moment ``c × M v`` grows without bound and the
  angular momentum about its centre is lost in the cancellation);
* a force f applied at the point x is the *forque* ``F = x ∨ f`` (the line of action, carrying
  its moment about every point): gravity acts at the centre of mass, a spring at the body point
  it is attached to, with ``f = −k (|x − a| − ℓ₀) (x − a)/|x − a|`` towards its anchor a.

The body momentum ``S̃ P_c S`` (S the rotor of M) gives the body twist through the inertia: ``A`` (the angular part
about the reference point, ``A = −(BΩ + ΩB)`` as everywhere in lieint) and ``M_tot v``.

The group is the motor group × the momentum lines (a vector space): a Lie-group method moves
``(M, P) ↦ (M e^{u/2}, P + δ)``, with the algebra se(3) shared with :class:`lieint.groups.SE`
(dexp⁻¹, dcay⁻¹, the spectral radius of ad) and the motor exponential of :mod:`lieint.ga.pga`.
The exact projection onto the group is the motor normalisation ``M/√(M M̃)`` (dual numbers), and
the Cayley map's motor is the normalised outer exponential ``1 + B/2 + (B/2)∧(B/2)/2``.

With a fixed point the body's reference point is the pivot, pinned at the space origin: the
twist has no linear part, the reaction force cancels the linear part of every forque, and the
body is the heavy top (with springs, if any).
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

import numpy as np

from .._validation import as_float_array, check_finite_positive, check_rotation, check_vector, describe
from ..groups.base import LieGroup
from ..groups.bivectors import hat, vee
from ..groups.se import SE
from ..groups.vector import ProductGroup, VectorSpace
from ..systems.base import Invariant, LieGroupSystem, Output, State
from ..systems.euler_top import EulerTop
from ..systems.mass import check_mass_tensor
from .algebra import algebra
from .exponential import matrix_to_rotor
from .pga import PGA
from .spin import rotor_matrix

__all__ = ["MotorGroup", "MotorRigidBody", "springs_array"]


def _momentum_about_origin(y) -> np.ndarray:
    """The momentum line moved back from the reference point c to the origin: ``T_c P T̃_c``."""
    T = PGA.translator(PGA.translation(y["motor"]))
    return PGA.sandwich(T, y["momentum"])[..., PGA.BIVECTOR]


class MotorGroup(LieGroup):
    """SE(3) as unit motors of Cl(3,0,1): elements ``(..., 16)``, algebra se(3) ``(..., 4, 4)``.

    ``exp(ξ) = e^{B(ξ)/2}`` with B the twist bivector of ξ; ``cay(ξ)`` the normalised outer
    exponential. The algebra and its maps are :class:`lieint.groups.SE`'s.
    """

    def __init__(self):
        self.se = SE(3)
        self.dim = 6
        self.name = "motors"

    # the entries (0,1), (0,2), (1,2), (0,3), (1,3), (2,3) of a flattened 4 × 4 twist matrix, the
    # blades e12, e13, e23, e01, e02, e03 they go to, and the signs of B = ω − Σ v_i e0i
    _TWIST_ENTRIES = np.array([1, 2, 6, 3, 7, 11])
    _TWIST_BLADES = np.array([PGA.E12, PGA.E13, PGA.E23, PGA.E01, PGA.E02, PGA.E03])
    _TWIST_SIGNS = np.array([1.0, 1.0, 1.0, -1.0, -1.0, -1.0])

    def bivector(self, X: np.ndarray, scale: float = 1.0) -> np.ndarray:
        """``scale ·`` the twist bivector ``B = ω − Σ v_i e0i`` of se(3) matrices
        (:meth:`PGA.twist_bivector <lieint.ga.pga._PGA.twist_bivector>`, in one gather)."""
        flat = X.reshape(X.shape[:-2] + (16,))
        out = np.zeros(flat.shape)
        out[..., self._TWIST_BLADES] = flat[..., self._TWIST_ENTRIES] * (scale * self._TWIST_SIGNS)
        return out

    def identity(self, batch_shape=()):
        M = np.zeros((*batch_shape, 16))
        M[..., 0] = 1.0
        return M

    def multiply(self, g, h):
        return PGA.product(g, h)

    def inverse(self, g):
        return PGA.reverse(g)

    def exp(self, X):
        return PGA.exp(self.bivector(X, 0.5))

    def cay(self, X):
        b = self.bivector(X, 0.5)
        out = b.copy()
        out[..., 0] = 1.0
        out[..., PGA.E0123] = 0.5 * PGA.product(b, b)[..., PGA.E0123]  # ½ b ∧ b
        return PGA.normalize(out)

    def matrix(self, M: np.ndarray) -> np.ndarray:
        """The pose matrix ``[[R, c], [0, 1]]`` of motors."""
        out = np.zeros(M.shape[:-1] + (4, 4))
        out[..., :3, :3] = rotor_matrix(algebra(3), PGA.rotor_part(M))
        out[..., :3, 3] = PGA.translation(M)
        out[..., 3, 3] = 1.0
        return out

    def log(self, g):
        return self.se.log(self.matrix(g))

    def project(self, g):
        return PGA.normalize(g)

    def dexpinv(self, u, v, degree=None):
        return self.se.dexpinv(u, v, degree)

    def dcayinv(self, X, v):
        return self.se.dcayinv(X, v)

    def ad_spectral_radius(self, X):
        return self.se.ad_spectral_radius(X)

    def ad_radius_upper_bound(self, X):
        return self.se.ad_radius_upper_bound(X)

    def __repr__(self) -> str:
        return "MotorGroup()"


def springs_array(springs) -> np.ndarray:
    """Springs as rows ``(body point (3), anchor (3), stiffness k, rest length ℓ₀)``.

    Accepts an array ``(k, 8)`` (rows as above; a row of 7 has ``ℓ₀ = 0``) or mappings with the
    keys ``body_point``, ``anchor``, ``stiffness`` and optionally ``rest_length``.
    """
    if springs is None:
        return np.zeros((0, 8))
    items = list(springs) if not isinstance(springs, np.ndarray) else springs
    if len(items) and isinstance(items[0], Mapping):
        rows = []
        for i, s in enumerate(items):
            missing = {"body_point", "anchor", "stiffness"} - set(s)
            if missing:
                raise ValueError(
                    f"`springs[{i}]` needs the keys body_point, anchor, stiffness; missing {sorted(missing)}."
                )
            rows.append(
                [*check_vector(s["body_point"], f"springs[{i}].body_point", 3)]
                + [*check_vector(s["anchor"], f"springs[{i}].anchor", 3)]
                + [float(s["stiffness"]), float(s.get("rest_length", 0.0))]
            )
        items = rows
    arr = as_float_array(items, "springs") if len(items) else np.zeros((0, 8))
    if arr.ndim != 2 or arr.shape[1] not in (7, 8):
        raise ValueError(
            "`springs` must be rows (body point x, y, z, anchor x, y, z, stiffness[, rest length]); "
            f"got an array of shape {arr.shape}."
        )
    if arr.shape[1] == 7:
        arr = np.concatenate([arr, np.zeros((arr.shape[0], 1))], axis=1)
    if np.any(arr[:, 6] < 0) or np.any(arr[:, 7] < 0):
        raise ValueError(f"`springs`: stiffness and rest length must be >= 0; got {describe(arr[:, 6:])}.")
    return arr


class MotorRigidBody(LieGroupSystem):
    """A rigid body in 3D with its pose a PGA motor, stepped on the motor group.

    State ``{"motor": (..., 16), "momentum": (..., 16)}``: the motor M and the momentum line
    ``P_c`` seen from the reference point (coefficients in clifford's pga layout; see
    :mod:`lieint.ga.motor`).

    Parameters
    ----------
    mass_tensor : array_like, shape (3, 3)
        ``B = ∫ m X Xᵀ`` about the centre of mass (free body) or about the pivot (``fixed_point``).
    mass : float
        Total mass M > 0.
    gravity : array_like, shape (3,), optional
        Uniform gravity g, acting at the centre of mass.
    springs : array_like or list of dict, optional
        Linear springs from body points to space anchors (:func:`springs_array`).
    fixed_point : bool, default False
        Pin the body's reference point (the pivot) at the space origin: the heavy top.
    center_of_mass : array_like, shape (3,), optional
        With ``fixed_point``: the centre of mass in the body frame, relative to the pivot
        (default 0). Without it the reference point is the centre of mass.

    Notes
    -----
    Outputs: ``R`` (rotation of the motor), ``center`` (the centre of mass in space),
    ``velocity_line`` (the body twist bivector, kind "line"), ``angular_velocity``.
    Invariants: ``energy`` (kinetic + gravity + springs), ``motor_defect`` ``‖M M̃ − 1‖``;
    without forces ``momentum`` (the line ``T_c P_c T̃_c`` about the origin); with a fixed point and
    gravity only,
    ``vertical_momentum`` ``⟨L, ĝ⟩``.

    Examples
    --------
    >>> import numpy as np, lieint
    >>> body = lieint.ga.MotorRigidBody(np.diag([1.0, 2.0, 3.0]), 2.0, gravity=[0, 0, -9.81],
    ...                                 springs=[[0.5, 0, 0, 0.5, 0, 1.0, 40.0, 0.2]])
    >>> y0 = body.initial_state(angular_velocity=[0.3, 1.0, 0.2])
    >>> sol = lieint.integrate(body, y0, t_span=(0.0, 1.0), h=0.01, method="rkmk4")
    >>> bool(sol.drift("motor_defect") < 1e-14)
    True
    """

    autonomous = True
    structure = frozenset({"motor_rigid_body"})
    field_kinds = MappingProxyType({"motor": "motor", "momentum": "line"})

    def __init__(
        self, mass_tensor, mass, gravity=None, *, springs=None, fixed_point: bool = False, center_of_mass=None
    ):
        check_mass_tensor(mass_tensor, "mass_tensor")  # a body in space: B ⪰ 0
        self.top = EulerTop(mass_tensor, orientation=False)
        if self.top.n != 3:
            raise ValueError(f"`mass_tensor` must be 3 × 3 (PGA Cl(3,0,1) is 3D); got n = {self.top.n}.")
        self.inertia = self.top.inertia
        self.B = self.top.B
        self.n = 3
        self.mass = check_finite_positive(mass, "mass")
        self.gravity = None if gravity is None else check_vector(gravity, "gravity", 3)
        self.springs = springs_array(springs)
        if not isinstance(fixed_point, (bool, np.bool_)):
            raise TypeError(f"`fixed_point` must be True or False; got {fixed_point!r}.")
        self.fixed_point = bool(fixed_point)
        if center_of_mass is not None and not self.fixed_point:
            raise ValueError(
                "`center_of_mass` is for a body with a fixed point (relative to the pivot); a free body's "
                "reference point is its centre of mass."
            )
        self.center_of_mass = (
            np.zeros(3) if center_of_mass is None else check_vector(center_of_mass, "center_of_mass", 3)
        )
        self.group = ProductGroup(MotorGroup(), VectorSpace((16,)))
        self.fields = {"motor": (16,), "momentum": (16,)}

    # -- kinematics -------------------------------------------------------------------------------
    def pose(self, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(R, c)`` of motors: rotation and the image of the body's reference point."""
        return rotor_matrix(algebra(3), PGA.rotor_part(M)), PGA.translation(M)

    def body_points(self, M: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Space positions ``M X M̃`` of body points x ``(k, 3)``: shape ``(..., k, 3)``."""
        X = PGA.point(x)[..., PGA.POINT]  # (k, 4)
        return PGA.point_coordinates_of_trivector(PGA.even_sandwich(M[..., None, PGA.EVEN], X, 3))

    # S̃ on the even blades of a motor M = T_c S: its rotor part, reversed (1, −e12, −e13, −e23)
    _ROTOR_REVERSED = np.array([1.0, 0.0, 0.0, 0.0, -1.0, -1.0, -1.0, 0.0])

    def body_momentum(self, y: State) -> tuple[np.ndarray, np.ndarray]:
        """``(A, p)``: the body angular momentum bivector about the reference point and the body
        linear momentum, from ``S̃ P_c S``."""
        S_reversed = y["motor"][..., PGA.EVEN] * self._ROTOR_REVERSED
        lines = PGA.even_sandwich(S_reversed, y["momentum"][..., PGA.BIVECTOR], 2)
        L, p = PGA.line_parts_of_bivector(lines)
        return -hat(L), p

    def twist(self, y: State) -> tuple[np.ndarray, np.ndarray]:
        """Body twist ``(Ω, v)``."""
        A, p = self.body_momentum(y)
        Om = self.inertia.angular_velocity(A)
        v = np.zeros_like(p) if self.fixed_point else p / self.mass
        return Om, v

    def forque(self, y: State) -> np.ndarray:
        """``Σ F`` seen from the reference point: the lines of action of gravity and the springs
        (their linear part cancelled by the pivot's reaction with a fixed point)."""
        M = y["motor"]
        batch = M.shape[:-1]
        moment = np.zeros(batch + (3,))
        force = np.zeros(batch + (3,))
        # the reference point, about which moments are taken (the origin with a fixed point)
        ref = np.zeros(batch + (3,)) if self.fixed_point else PGA.translation(M) if len(self.springs) else None
        if self.gravity is not None:
            f = np.broadcast_to(self.mass * self.gravity, batch + (3,))
            if self.fixed_point:  # about the centre of mass itself gravity has no moment
                moment = moment + np.cross(self.center(M), f)
            force = force + f
        if len(self.springs):
            sp = self.springs
            x = self.body_points(M, sp[:, :3])  # (..., k, 3)
            d = x - sp[:, 3:6]
            length = np.linalg.norm(d, axis=-1, keepdims=True)
            safe = np.where(length > 0, length, 1.0)
            f = -sp[:, 6:7] * (length - sp[:, 7:8]) * d / safe
            moment = moment + np.sum(np.cross(x - ref[..., None, :], f), axis=-2)
            force = force + np.sum(f, axis=-2)
        if self.fixed_point:
            force = np.zeros_like(force)
        return PGA.line(moment, force)

    def center(self, M: np.ndarray) -> np.ndarray:
        """The centre of mass in space."""
        if self.fixed_point:
            return self.body_points(M, self.center_of_mass[None, :])[..., 0, :]
        return PGA.translation(M)

    # -- the LieGroupSystem contract ------------------------------------------------------------
    def generator(self, t: float | np.ndarray, y: State) -> np.ndarray | tuple[np.ndarray, ...]:
        Om, v = self.twist(y)
        xi = np.zeros(Om.shape[:-2] + (4, 4))
        xi[..., :3, :3] = Om
        xi[..., :3, 3] = v
        return (xi, self.forque(y))

    def act(self, g, y: State) -> State:
        Mg, delta = g
        return {"motor": PGA.product(y["motor"], Mg), "momentum": y["momentum"] + delta}

    def infinitesimal_action(self, xi, y: State) -> State:
        X, F = xi
        B = self.group.factors[0].bivector(X)
        return {"motor": 0.5 * PGA.product(y["motor"], B), "momentum": F}

    def project(self, y: State) -> State:
        return {"motor": PGA.normalize(y["motor"]), "momentum": y["momentum"]}

    # -- physics ------------------------------------------------------------------------------
    def energy(self, y: State) -> np.ndarray:
        """Kinetic energy, minus ``M⟨g, x_G⟩``, plus ``½ k (|x − a| − ℓ₀)²`` per spring."""
        A, p = self.body_momentum(y)
        E = self.top.energy(A)
        if not self.fixed_point:
            E = E + 0.5 * np.sum(p * p, axis=-1) / self.mass
        M = y["motor"]
        if self.gravity is not None:
            E = E - self.mass * (self.center(M) @ self.gravity)
        if len(self.springs):
            sp = self.springs
            length = np.linalg.norm(self.body_points(M, sp[:, :3]) - sp[:, 3:6], axis=-1)
            E = E + np.sum(0.5 * sp[:, 6] * (length - sp[:, 7]) ** 2, axis=-1)
        return E

    @property
    def invariants(self) -> dict[str, Invariant]:
        declared = {
            "energy": Invariant(lambda t, y: self.energy(y), "integral", "kinetic + gravity + springs"),
            "motor_defect": Invariant(lambda t, y: PGA.defect(y["motor"]), "defect", "‖M M̃ − 1‖ (motor off SE(3))"),
        }
        if self.gravity is None and not len(self.springs):
            declared["momentum"] = Invariant(_momentum_about_origin, "integral", "momentum line about the origin")
        elif self.fixed_point and not len(self.springs):
            up = self.gravity / np.linalg.norm(self.gravity)
            declared["vertical_momentum"] = Invariant(
                lambda t, y: PGA.line_parts(y["momentum"])[0] @ up, "integral", "⟨L, ĝ⟩ about the pivot"
            )
        return declared

    @property
    def outputs(self) -> dict[str, Output]:
        out = dict(super().outputs)
        out["R"] = Output(lambda t, y: self.pose(y["motor"])[0], (3, 3), "orientation R (body to space)", "rotation")
        out["orientation"] = out["R"]
        out["center"] = Output(lambda t, y: self.center(y["motor"]), (3,), "centre of mass in space", "point")

        def velocity_line(t, y):
            Om, v = self.twist(y)
            return PGA.twist_bivector(Om, v)

        out["velocity_line"] = Output(velocity_line, (16,), "body twist bivector ω − v·e0", "line")
        out["angular_velocity"] = Output(lambda t, y: self.twist(y)[0], (3, 3), "body angular velocity Ω", "bivector")
        return out

    # -- states -------------------------------------------------------------------------------
    def initial_state(self, *, R=None, Omega=None, A=None, angular_velocity=None, center=None, velocity=None) -> State:
        """State from :meth:`lieint.FreeBody.initial_state`'s keywords: orientation R, one of
        ``Omega``/``A``/``angular_velocity`` (body frame), ``center`` (the centre of mass) and
        ``velocity`` (of the centre of mass). With a fixed point, ``center`` and ``velocity``
        are fixed by the pivot and must be left out."""
        if self.fixed_point and (center is not None or velocity is not None):
            raise ValueError(
                "`center` and `velocity` are fixed by the pivot of a body with a fixed point; leave them out."
            )
        s = EulerTop(self.B, orientation=True).initial_state(Omega=Omega, A=A, R=R, angular_velocity=angular_velocity)
        A0, R0 = s["A"], s["R"]
        c = np.zeros(3) if center is None else check_vector(center, "center", 3, batch=True)
        v = np.zeros(3) if velocity is None else check_vector(velocity, "velocity", 3, batch=True)
        batch = np.broadcast_shapes(A0.shape[:-2], c.shape[:-1], v.shape[:-1])
        A0 = np.broadcast_to(A0, batch + (3, 3))
        R0 = np.broadcast_to(R0, batch + (3, 3))
        c = np.broadcast_to(c, batch + (3,))
        v = np.broadcast_to(v, batch + (3,))
        M = PGA.motor(matrix_to_rotor(R0, as_multivector=False), c)
        # the momentum line seen from the reference point: moment R L_body (A = −hat(L_body))
        L = (R0 @ (-vee(A0))[..., None])[..., 0]
        p = np.zeros(batch + (3,)) if self.fixed_point else self.mass * v
        return {"motor": M, "momentum": PGA.line(L, p)}

    def validate_state(self, y: Mapping[str, np.ndarray], name: str = "y0") -> State:
        out = super().validate_state(y, name)
        defect = np.max(PGA.defect(out["motor"]), initial=0.0)
        if not defect <= 1e-10:
            raise ValueError(f"`{name}['motor']` must be a unit motor (M M̃ = 1); got ‖M M̃ − 1‖ = {defect:.3g}.")
        R, _ = self.pose(out["motor"])
        check_rotation(R, f"{name}['motor'] (its rotation)", atol=1e-9)
        return out

    def __repr__(self) -> str:
        g = None if self.gravity is None else describe(self.gravity)
        return (
            f"MotorRigidBody(mass={self.mass:g}, gravity={g}, springs={len(self.springs)}, "
            f"fixed_point={self.fixed_point})"
        )
