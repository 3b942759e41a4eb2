"""A free rigid body in space: pose on SE(n), rotation as the Euler top (docs/theory.md §5)."""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .._validation import check_finite_positive, check_rotation, check_vector, describe
from ..fast.forms import BUILTIN_PIECES, PiecesForm
from ..groups.so import SO
from ..groups.vector import ProductGroup, VectorSpace
from .base import Invariant, LieGroupSystem, Output, State
from .euler_top import EulerTop
from .mass import check_mass_tensor
from .rigid import casimir_invariant, momentum_outputs, orientation_output, pose_invariants

__all__ = ["FreeBody"]

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

#: what the compiled declaration stands for (see :meth:`LieGroupSystem.dynamics_as`)
_DYNAMICS = ("generator", "act", "infinitesimal_action", "vector_field", "project")
_TOP = ("generator", "act", "infinitesimal_action", "project", "angular_velocity")


class FreeBody(LieGroupSystem):
    """A free rigid body: centre of mass in uniform motion or free fall, rotation about it.

    The pose ``(R, q_G) ∈ SE(n)`` is stored as ``"R"`` and ``"center"``, with the velocity
    ``"velocity"`` of the centre of mass and the body momentum ``"A"`` about it::

        Ȧ = [A, Ω],   Ṙ = RΩ,   q̇_G = v,   v̇ = g.

    The group is ``SO(n) × Rⁿ × Rⁿ``: SO(n) moves (A, R) as for the Euler top, the vector
    factors translate the centre and the velocity. The translation is integrated in the space
    frame, which makes uniform motion and free fall exact for every method of order ≥ 2.

    Parameters
    ----------
    mass_tensor : array_like, shape (n, n)
        Mass tensor about the centre of mass.
    mass : float
        Total mass M.
    gravity : array_like, shape (n,), optional
        Uniform gravity g (None: no force, uniform motion).
    orientation : bool, default True
        Integrate R (the rotation dynamics needs only A).

    Notes
    -----
    Invariants: ``energy`` ``T_rot + ½M|v|² − M⟨g, q_G⟩``, ``casimirs``, ``momentum``
    (``R A Rᵀ``), ``linear_momentum`` ``M v`` (without gravity), ``orthogonality``.

    Examples
    --------
    A tumbling body thrown up: the centre follows the parabola exactly, the rotation is the
    free top's.

    >>> import numpy as np, lieint
    >>> body = lieint.FreeBody(np.diag([0.3, 0.2, 0.1]), 2.0, gravity=[0.0, 0.0, -9.81])
    >>> y0 = body.initial_state(angular_velocity=[0.1, 2.0, 0.3], velocity=[1.0, 0.0, 5.0])
    >>> sol = lieint.integrate(body, y0, (0.0, 1.0), h=0.01, method="rkmk4")
    >>> sol.states["center"][-1].round(12).tolist()  # (v t, 0, 5 t − g t²/2) at t = 1
    [1.0, 0.0, 0.095]
    >>> bool(sol.drift("energy") < 1e-12 and sol.drift("casimirs") < 1e-13)
    True
    """

    autonomous = True
    structure = frozenset({"free_body"})
    #: R moves only itself and nothing reads it (lets the rotor form skip computing it)
    orientation_is_passive = True

    def __init__(
        self, mass_tensor: ArrayLike, mass: float, gravity: ArrayLike | None = None, *, orientation: bool = True
    ):
        check_mass_tensor(mass_tensor, "mass_tensor")  # a body in space: B ⪰ 0
        self.top = EulerTop(mass_tensor, orientation=orientation)
        self.inertia = self.top.inertia
        self.n = n = self.top.n
        self.B = self.top.B
        self.mass = check_finite_positive(mass, "mass")
        self.gravity = None if gravity is None else check_vector(gravity, "gravity", n)
        self.orientation = self.top.orientation
        self.fields = dict(self.top.fields) | {"center": (n,), "velocity": (n,)}
        self.group = ProductGroup(SO(n), VectorSpace((n,)), VectorSpace((n,)))

    def generator(self, t: float | np.ndarray, y: State) -> np.ndarray | tuple[np.ndarray, ...]:
        Om = self.top.angular_velocity(y["A"])
        v = y["velocity"]
        acc = np.zeros_like(v) if self.gravity is None else np.broadcast_to(self.gravity, v.shape)
        return (Om, v, acc)

    def act(self, g: np.ndarray | tuple[np.ndarray, ...], y: State) -> State:
        Q, dp, dv = g
        out = self.top.act(Q, y)
        out["center"] = y["center"] + dp
        out["velocity"] = y["velocity"] + dv
        return out

    def infinitesimal_action(self, xi: np.ndarray | tuple[np.ndarray, ...], y: State) -> State:
        Om, v, acc = xi
        out = self.top.infinitesimal_action(Om, y)
        out["center"] = v
        out["velocity"] = acc
        return out

    def project(self, y: State) -> State:
        out = dict(y) | self.top.project(y)
        return out

    def compiled(self) -> PiecesForm | None:
        """The compiled engine's form (:class:`lieint.fast.forms.PiecesForm`) for n ≥ 3.

        The free body's pieces in :mod:`lieint.fast.bodies`; parameters n, the offsets of R and
        of the centre, whether B is diagonal, the eigenbasis P of B, ``−1/(b_i + b_j)``, g and the mass
        (the energy).

        Returns
        -------
        PiecesForm or None
            The form, or None (n = 2, or a subclass with other dynamics).
        """
        if self.n < 3 or not self.dynamics_as(FreeBody, _DYNAMICS) or not self.top.dynamics_as(EulerTop, _TOP):
            return None
        inertia, n, gravity = self.inertia, self.n, self.gravity
        # every number of the declaration (comparing them is cheaper than building its parameters)
        key = (tuple(self.fields), inertia.diagonal, inertia.kernel_params.tobytes(), self.mass)
        key += (None if gravity is None else gravity.tobytes(),)

        def build():
            offset = self.field_offsets()
            g = np.zeros(n) if gravity is None else gravity
            head = [n, offset.get("R", -1), float(inertia.diagonal)]
            params = np.concatenate([head, inertia.kernel_params, [offset["center"]], g, [self.mass]])
            return PiecesForm(BUILTIN_PIECES.free_body, params, n, False, 2 * n, self.fields)

        return self._declared_once(key, build)

    def energy(self, y: State) -> np.ndarray:
        """Total energy ``T_rot + ½M|v|² − M⟨g, q_G⟩``.

        Parameters
        ----------
        y : dict of ndarray
            States (any leading shape).

        Returns
        -------
        ndarray
            The energy per state.
        """
        v = y["velocity"]
        E = self.top.energy(y["A"]) + 0.5 * self.mass * np.sum(v * v, axis=-1)
        if self.gravity is not None:
            E = E - self.mass * (y["center"] @ self.gravity)
        return E

    @property
    def invariants(self) -> dict[str, Invariant]:
        declared = {
            "energy": Invariant(lambda t, y: self.energy(y), "integral", "rotational + translational − potential"),
            "casimirs": casimir_invariant("A"),
        }
        if self.gravity is None:
            declared["linear_momentum"] = Invariant(lambda t, y: self.mass * y["velocity"], "integral", "M v")
        if self.orientation:
            declared.update(pose_invariants("A"))
        return declared

    @property
    def outputs(self) -> dict[str, Output]:
        n = self.n
        out = dict(super().outputs)
        out.update(momentum_outputs(n, lambda y: self.top.angular_velocity(y["A"])))
        if self.orientation:
            out["orientation"] = orientation_output(n)
        return out

    def initial_state(
        self,
        *,
        R: ArrayLike | Rotation | None = None,
        Omega: ArrayLike | None = None,
        A: ArrayLike | None = None,
        angular_velocity: ArrayLike | None = None,
        center: ArrayLike | None = None,
        velocity: ArrayLike | None = None,
    ) -> State:
        """State from the pose, one of ``Omega``/``A``/``angular_velocity``, and the velocity.

        Leading batch dimensions broadcast.

        Parameters
        ----------
        R : array_like, shape (..., n, n), or scipy Rotation, optional
            Orientation, body to space (default: the identity).
        Omega : array_like, shape (..., n, n), optional
            Body angular velocity bivector.
        A : array_like, shape (..., n, n), optional
            Body angular momentum bivector about the centre of mass.
        angular_velocity : array_like, shape (..., 3), optional
            n = 3: the body angular velocity vector w.
        center : array_like, shape (..., n), optional
            The centre of mass in space (default: the origin).
        velocity : array_like, shape (..., n), optional
            Its velocity (default: at rest).

        Returns
        -------
        dict of ndarray
            ``{"A", "R", "center", "velocity"}`` (without R when ``orientation=False``).
        """
        n = self.n
        top = EulerTop(self.B, orientation=True)
        s = top.initial_state(Omega=Omega, A=A, R=R, angular_velocity=angular_velocity)
        p = np.zeros(n) if center is None else check_vector(center, "center", n, batch=True)
        v = np.zeros(n) if velocity is None else check_vector(velocity, "velocity", n, batch=True)
        batch = np.broadcast_shapes(s["A"].shape[:-2], p.shape[:-1], v.shape[:-1])
        out = {"A": np.broadcast_to(s["A"], batch + (n, n)).copy()}
        if self.orientation:
            out["R"] = np.broadcast_to(s["R"], batch + (n, n)).copy()
        out["center"] = np.broadcast_to(p, batch + (n,)).copy()
        out["velocity"] = np.broadcast_to(v, batch + (n,)).copy()
        return out

    def validate_state(self, y: Mapping[str, np.ndarray], name: str = "y0") -> State:
        out = super().validate_state(y, name)
        out["A"] = self.top.validate_state({k: out[k] for k in self.top.fields}, name)["A"]
        if self.orientation:
            check_rotation(out["R"], f"{name}['R']", atol=1e-9)
        return out

    # -- numeric parameters (lieint.sensitivity) ------------------------------------------
    def parameter_values(self) -> dict[str, np.ndarray]:
        """The numeric parameters a run can be differentiated by (:func:`lieint.sensitivity`).

        Returns
        -------
        dict of ndarray
            ``mass_tensor``, ``mass`` and ``gravity`` (zero when none was given).
        """
        g = np.zeros(self.n) if self.gravity is None else self.gravity.copy()
        return {"mass_tensor": self.B.copy(), "mass": np.array(self.mass), "gravity": g}

    def _assign_parameter(self, name: str, value: np.ndarray) -> None:
        if name == "mass_tensor":
            self.top = copy.copy(self.top)
            self.top._assign_parameter("B", value)
            self.inertia, self.B = self.top.inertia, self.top.B
        elif name == "mass":
            self.mass = value
        else:
            self.gravity = value

    def __repr__(self) -> str:
        g = None if self.gravity is None else describe(self.gravity)
        return f"FreeBody(n={self.n}, mass={self.mass:g}, gravity={g}, fields={list(self.fields)})"
