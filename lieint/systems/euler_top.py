"""The n-dimensional Euler top: a rigid body with a fixed point, no forces (docs/theory.md §2)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .._validation import (
    as_bivector_array,
    as_float_array,
    as_rotation_array,
    check_rotation,
    check_skew,
    check_square_trailing,
    describe,
)
from ..fast.forms import BUILTIN_PIECES, PiecesForm, Top3Form, TopNForm
from ..groups.bivectors import hat, skew_part, vee
from ..groups.so import SO, project_to_so
from .base import Invariant, LieGroupSystem, Output, State
from .euler_top_exact import euler_top_angular_velocity
from .invariants import manakov_integrals, manakov_labels
from .mass import check_mass_tensor, is_mass_distribution, moments_tensor
from .rigid import (
    ComplexStepInertia,
    InertiaOperator,
    casimir_invariant,
    momentum_outputs,
    orientation_output,
    pose_invariants,
)

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

__all__ = ["EulerTop", "check_mass_tensor"]

#: what the compiled declaration of :class:`EulerTop` stands for (a subclass overriding any of
#: these has other dynamics)
_DYNAMICS = (
    "generator",
    "act",
    "act_near_identity",
    "infinitesimal_action",
    "vector_field",
    "project",
    "angular_velocity",
)


class EulerTop(LieGroupSystem):
    """The free rigid body with a fixed point in any dimension n ≥ 2.

    State ``{"A": (..., n, n), "R": (..., n, n)}``: body angular momentum bivector A and
    orientation R ∈ SO(n). Equations (Euler–Poisson)::

        Ȧ = [A, Ω],   Ṙ = R Ω,   A = −(BΩ + ΩB),

    with Ω recovered in the eigenbasis of B by ``Ω_ij = −A_ij / (b_i + b_j)``. SO(n) acts on
    the right, ``Q · (A, R) = (QᵀAQ, RQ)``, with generator ``ξ = Ω(A)``.

    Parameters
    ----------
    B : array_like, shape (n, n)
        Body mass tensor ``∫ m X Xᵀ``: symmetric with ``b_i + b_j > 0`` for its eigenvalues
        b (i ≠ j), which the equations need (the inertia operator invertible, the kinetic
        energy positive). A body's B is positive semi-definite with at most one zero
        eigenvalue; B need not be (see Notes).
    orientation : bool, default True
        Integrate R as well. Without it the state is A alone (cheaper), and the invariants
        that need R (``momentum``, ``orthogonality``) are not available.

    Notes
    -----
    **Any positive principal moments.** Euler's equations ``I ẇ = (I w) × w`` need only
    positive moments ``I_k = b_i + b_j``; a mass distribution also has ``B = ∫ m X Xᵀ ⪰ 0``,
    i.e. the triangle inequality ``I_k ≤ I_i + I_j``. This top accepts what the equations
    accept, for example Hairer & Vilmart's "water" body (0.345, 0.653, 1.0) or the bodies
    (3, 3, 9) and (3, 5, 9), for which ``b₃ = (I₁ + I₂ − I₃)/2 < 0``: no mass distribution
    has them (:attr:`has_mass_distribution` is False), and systems that need one — the heavy
    top's potential, the rolling balls, atoms, free bodies in space — refuse them. For such a
    B, ``manakov`` is still a set of integrals (Manakov's Lax pair holds for any symmetric
    B), the exact solution (n = 3) and every method apply unchanged.

    Structure tag ``"free_top"`` (``inertia`` is its :class:`~lieint.systems.rigid.InertiaOperator`).
    Outputs: ``angular_momentum`` (A), ``angular_velocity`` (Ω), ``orientation`` (R).
    Invariants: ``energy``: ``T = ¼ tr(ΩA) = −½ tr(ΩBΩ)``. ``casimirs``: the rotation "angles" of A,
    ``θ₁ ≥ θ₂ ≥ …`` (eigenvalues ``±iθ_k``), i.e. the spectrum. ``manakov``: coefficients
    of ``tr((A − λB²)^k)`` in λ (see :func:`~lieint.systems.invariants.manakov_integrals`).
    ``momentum``: space momentum ``a = R A Rᵀ``. ``orthogonality``: ``‖RᵀR − I‖_F``.

    Examples
    --------
    >>> import numpy as np, lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> y0 = top.initial_state(angular_velocity=[0.01, 1.0, 0.01])
    >>> sol = lieint.integrate(top, y0, t_span=(0.0, 1.0), h=0.01, method="rkmk4")
    >>> bool(sol.drift("casimirs") < 1e-13)
    True
    """

    autonomous = True
    structure = frozenset({"free_top"})
    #: R moves only itself and nothing reads it (lets the rotor form skip computing it)
    orientation_is_passive = True

    def __init__(self, B: ArrayLike, *, orientation: bool = True):
        self.inertia = InertiaOperator(B, "B", mass_distribution=False)
        self.B, self.b, self.P = self.inertia.B, self.inertia.b, self.inertia.P
        self.n = self.inertia.n
        self.group = SO(self.n)
        if not isinstance(orientation, (bool, np.bool_)):
            raise TypeError(f"`orientation` must be True or False; got {orientation!r}.")
        self.orientation = bool(orientation)
        self.fields = {"A": (self.n, self.n)}
        if self.orientation:
            self.fields["R"] = (self.n, self.n)
        self._diagonal = self.inertia.diagonal
        self._minus_inv_pair = self.inertia.minus_inv_pair
        self._B2 = self.inertia.B2

    @classmethod
    def from_principal_moments(cls, moments: ArrayLike, *, orientation: bool = True) -> EulerTop:
        """3D top from its principal moments of inertia ``I₁, I₂, I₃`` (n = 3 only).

        ``B = diag(b)`` with ``b_i = (I_j + I_k − I_i)/2``. Any positive moments: those of a
        mass distribution satisfy ``I_i ≤ I_j + I_k`` (equality: a flat plate); those that
        break it (``b_i < 0``) make a valid free top that no body realises
        (:attr:`has_mass_distribution` is False; see the class Notes).

        Parameters
        ----------
        moments : array_like, shape (3,)
            Positive principal moments.
        orientation : bool, default True
            Integrate R as well.

        Returns
        -------
        EulerTop
            The top, principal axes along the coordinate axes.

        Examples
        --------
        >>> import lieint
        >>> water = lieint.EulerTop.from_principal_moments([0.345, 0.653, 1.0])  # Hairer & Vilmart
        >>> water.b.round(3).tolist(), water.has_mass_distribution
        ([0.654, 0.346, -0.001], False)
        """
        return cls(moments_tensor(moments, "moments", mass_distribution=False), orientation=orientation)

    # -- physics -----------------------------------------------------------------------
    @property
    def has_mass_distribution(self) -> bool:
        """Whether some mass distribution has this B (B ⪰ 0; n = 3: ``I_k ≤ I_i + I_j``).

        False for tops that only the equations admit (class Notes); the motion is still the
        free top's.
        """
        return is_mass_distribution(self.b)

    @property
    def principal_moments(self) -> np.ndarray:
        """n = 3: ``I = tr(B) − b`` in the order of the eigenvalues ``b``."""
        return self.inertia.principal_moments

    def momentum(self, Omega: np.ndarray) -> np.ndarray:
        """Body angular momentum ``A = −(BΩ + ΩB)``.

        Parameters
        ----------
        Omega : ndarray, shape (..., n, n)
            Body angular velocity bivectors.

        Returns
        -------
        ndarray, shape (..., n, n)
            A.
        """
        return self.inertia.momentum(Omega)

    def angular_velocity(self, A: np.ndarray) -> np.ndarray:
        """Inertia operator: Ω with ``A = −(BΩ + ΩB)``, via ``Ω_ij = −A_ij/(b_i + b_j)``.

        Parameters
        ----------
        A : ndarray, shape (..., n, n)
            Body angular momentum bivectors.

        Returns
        -------
        ndarray, shape (..., n, n)
            Ω, exactly skew.
        """
        return self.inertia.angular_velocity(A)

    def energy(self, A: np.ndarray) -> np.ndarray:
        """Kinetic energy ``T = ¼ tr(ΩA) = −¼ ⟨Ω, A⟩``.

        Parameters
        ----------
        A : ndarray, shape (..., n, n)
            Body angular momentum bivectors.

        Returns
        -------
        ndarray, shape (...)
            T, positive for A ≠ 0.
        """
        return self.inertia.energy(A)

    # -- the LieGroupSystem contract ---------------------------------------------------
    def generator(self, t: float | np.ndarray, y: State) -> np.ndarray:
        return self.angular_velocity(y["A"])

    def commuting_generator(self, t: float | np.ndarray, y: State, xi: np.ndarray | None = None) -> np.ndarray:
        """The part of the generator that commutes with A: ``λA`` with ``λ = ⟨Ω, A⟩ / ⟨A, A⟩``.

        The generator of ``A' = [A, Ω]`` is defined only up to the centraliser of A: ``Ω − λA``
        moves A exactly as Ω does, for any λ. With this λ (``= −4T/|A|²``, a ratio of the energy
        and the Casimir, so constant along the flow) ``Ω − λA`` is the representative of least
        norm in ``Ω + span{A}``, and the rest, ``λA``, has an exact flow that commutes with the
        whole motion: it turns the attitude about the momentum axis, ``R ↦ R exp(tλA)`` (in
        space, ``exp(tλm) R`` with ``m = R A Rᵀ``), and leaves A alone. Near a steady rotation
        ``Ω ≈ λA``: what remains for a Lie-group method to integrate is small there, however fast
        the body spins (see :mod:`lieint.methods.energy_projection`, which uses it).

        Parameters
        ----------
        t : float or ndarray
            The time (the free top is autonomous: unused).
        y : dict
            The state.
        xi : ndarray, optional
            The generator at ``(t, y)`` when the caller has it (else it is evaluated).

        Returns
        -------
        ndarray, shape (..., n, n)
            ``λA`` (zero where A is zero).
        """
        A = y["A"]
        Omega = self.generator(t, y) if xi is None else xi
        norm2 = np.sum(A * A, axis=(-2, -1), keepdims=True)
        lam = np.sum(Omega * A, axis=(-2, -1), keepdims=True) / np.where(norm2 > 0, norm2, 1.0)
        return lam * A

    def act(self, g: np.ndarray, y: State) -> State:
        gt = np.swapaxes(g, -1, -2)
        out = {"A": skew_part(gt @ y["A"] @ g)}
        if self.orientation:
            out["R"] = y["R"] @ g
        return out

    def act_near_identity(self, K: np.ndarray, y: State) -> State:
        """``act(I + K, y)`` computed from ``K = g − I`` without forming g.

        ``(I + K)ᵀ A (I + K) = A + (P − Pᵀ + Kᵀ P)`` with ``P = A K`` (A skew, so
        ``Kᵀ A = −Pᵀ``), and ``R (I + K) = R + R K``. For an increment near the identity the
        correction is small and computed to its own relative precision, while rounding
        ``I + K`` first would cost ε/2 in g's diagonal — an error that repeats from step to
        step when the step keeps a combination of that diagonal (the Moser–Veselov step keeps
        ``tr(B g)``) and then moves the energy in one direction.

        Parameters
        ----------
        K : ndarray, shape (..., n, n)
            ``g − I`` for the group element g.
        y : dict
            The state.

        Returns
        -------
        dict
            ``ρ(I + K, y)``; A is made exactly skew, as in :meth:`act`.
        """
        A = y["A"]
        P = A @ K
        out = {"A": A + skew_part(P - np.swapaxes(P, -1, -2) + np.swapaxes(K, -1, -2) @ P)}
        if self.orientation:
            out["R"] = y["R"] + y["R"] @ K
        return out

    def relative_element(self, y0: State, y1: State) -> np.ndarray | None:
        """``g = R₀ᵀ R₁`` (the attitude is moved by ``R ↦ R g``); None without attitude.

        Parameters
        ----------
        y0, y1 : dict of ndarray
            The states at the two ends of a step.

        Returns
        -------
        ndarray or None
            ``R₀ᵀ R₁``, or None when the top does not carry R.
        """
        if not self.orientation:
            return None
        return np.swapaxes(y0["R"], -1, -2) @ y1["R"]

    def infinitesimal_action(self, xi: np.ndarray, y: State) -> State:
        A = y["A"]
        out = {"A": A @ xi - xi @ A}
        if self.orientation:
            out["R"] = y["R"] @ xi
        return out

    def project(self, y: State) -> State:
        out = {"A": skew_part(y["A"])}
        if self.orientation:
            out["R"] = project_to_so(y["R"])
        return out

    @property
    def invariants(self) -> dict[str, Invariant]:
        declared = {
            "energy": Invariant(lambda t, y: self.energy(y["A"]), "integral", "kinetic energy T = ¼ tr(ΩA)"),
            "casimirs": casimir_invariant("A"),
            "manakov": Invariant(
                lambda t, y: manakov_integrals(y["A"], self._B2), "integral", "Manakov integrals tr((A − λB²)^k)"
            ),
        }
        if self.orientation:
            declared.update(pose_invariants("A"))
        return declared

    @property
    def outputs(self) -> dict[str, Output]:
        n = self.n
        out = dict(super().outputs)
        out.update(momentum_outputs(n, lambda y: self.angular_velocity(y["A"])))
        if self.orientation:
            out["orientation"] = orientation_output(n)
        return out

    def compiled(self) -> Top3Form | TopNForm | None:
        """The compiled engine's form (:mod:`lieint.fast.forms`): for n = 3 the principal moments
        and frame (:class:`~lieint.fast.forms.Top3Form`), for n ≥ 4 the eigenvalues b and
        eigenbasis P of B (:class:`~lieint.fast.forms.TopNForm`), each with the top's compiled
        pieces (``generic``: the 3D top's Cayley coordinates run there); None for n = 2 (so(2) is
        abelian: nothing to compile).

        The declaration stands for the Euler top's equations: a subclass that overrides the
        generator, the action or the projection integrates other dynamics and declares None
        (the generic path then runs what it defines) — on the class or set on the instance.

        Returns
        -------
        dict or None
            The declaration (read-only), or None.
        """
        cls, own = type(self), getattr(self, "__dict__", {})
        if any(getattr(cls, name) is not getattr(EulerTop, name) or name in own for name in _DYNAMICS):
            return None
        if self.n < 3:
            return None
        # built once per inertia tensor and orientation flag (a single call's set-up is a few
        # tens of microseconds; this is a tenth of it)
        key = (self.inertia, self.orientation)
        cached = own.get("_compiled_declaration")
        if cached is not None and cached[0][0] is key[0] and cached[0][1] == key[1]:
            return cached[1]
        decl = self._declaration()
        own["_compiled_declaration"] = (key, decl)
        return decl

    def _declaration(self):
        """:meth:`compiled`'s form of this top (n ≥ 3): the engine treats it as read-only."""
        head = [self.n, self.field_offsets().get("R", -1), float(self.inertia.diagonal)]
        params = np.concatenate([head, self.inertia.kernel_params])
        generic = PiecesForm(BUILTIN_PIECES.euler_top, params, self.n, False, 0, self.fields)
        if self.n == 3:
            return Top3Form(self.principal_moments, self.P, self.orientation, generic)
        return TopNForm(self.b, self.P, self.orientation, generic)

    @property
    def manakov_labels(self) -> list[tuple[int, int]]:
        """``(k, j)`` of each entry of the ``manakov`` invariant: coefficient of λʲ in ``tr((A − λB²)^k)``."""
        return manakov_labels(self.n)

    # -- states ------------------------------------------------------------------------
    def initial_state(
        self,
        *,
        Omega: ArrayLike | None = None,
        A: ArrayLike | None = None,
        R: ArrayLike | Rotation | None = None,
        angular_velocity: ArrayLike | None = None,
    ) -> State:
        """Build a state from physical inputs, broadcasting leading batch dimensions.

        Give exactly one of ``Omega``, ``A`` or (n = 3) ``angular_velocity``.

        Parameters
        ----------
        Omega : array_like, shape (..., n, n), optional
            Body angular velocity bivector (a skew matrix, or clifford bivectors).
        A : array_like, shape (..., n, n), optional
            Body angular momentum bivector.
        R : array_like, shape (..., n, n), or scipy Rotation, optional
            Orientation in SO(n), body to space (default: the identity); a
            :class:`scipy.spatial.transform.Rotation` (one or a stack) for n = 3.
        angular_velocity : array_like, shape (..., 3), optional
            n = 3: the body angular velocity vector w, ``Ω = ŵ``.

        Returns
        -------
        dict of ndarray
            ``{"A": (*batch, n, n), "R": (*batch, n, n)}`` (without R when ``orientation=False``).

        Examples
        --------
        >>> import lieint
        >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
        >>> y0 = top.initial_state(angular_velocity=[[0.0, 1.0, 0.1], [0.5, 0.0, 1.0]])  # two bodies
        >>> y0["A"].shape, y0["R"].shape
        ((2, 3, 3), (2, 3, 3))
        """
        given = {k: v for k, v in (("Omega", Omega), ("A", A), ("angular_velocity", angular_velocity)) if v is not None}
        if len(given) != 1:
            raise ValueError(
                "Give exactly one of `Omega`, `A` or `angular_velocity` to `initial_state`; "
                f"got {sorted(given) or 'none'}."
            )
        ((key, value),) = given.items()
        n = self.n
        # Ω and A may be clifford bivectors (converted to skew matrices); w is a vector
        arr = as_float_array(value, key) if key == "angular_velocity" else as_bivector_array(value, key)
        if key == "angular_velocity":
            if n != 3:
                raise ValueError(f"`angular_velocity` (a vector w with Ω = ŵ) needs n = 3; this top has n = {n}.")
            if arr.shape[-1:] != (3,):
                raise ValueError(f"`angular_velocity` must have shape (..., 3); got shape {arr.shape}.")
            Am = self.momentum(hat(arr))
        else:
            check_square_trailing(arr, key, n)
            arr = check_skew(arr, key)
            Am = self.momentum(arr) if key == "Omega" else arr
        state = {"A": Am}
        if self.orientation:
            if R is None:
                Rm = np.broadcast_to(np.eye(n), Am.shape).copy()
            else:
                Rm = as_rotation_array(R, "R")
                check_square_trailing(Rm, "R", n)
                check_rotation(Rm, "R")
            batch = _broadcast_batch(Am.shape[:-2], Rm.shape[:-2], "R", key)
            state = {"A": np.broadcast_to(Am, batch + (n, n)).copy(), "R": np.broadcast_to(Rm, batch + (n, n)).copy()}
        elif R is not None:
            raise ValueError("`R` was given but this EulerTop was built with orientation=False.")
        return state

    def validate_state(self, y: Mapping[str, np.ndarray], name: str = "y0") -> State:
        out = super().validate_state(y, name)
        out["A"] = check_skew(out["A"], f"{name}['A']")
        if self.orientation:
            check_rotation(out["R"], f"{name}['R']", atol=1e-9)
        return out

    # -- exact solution ----------------------------------------------------------------
    def exact_solution(self, t: ArrayLike, y0: State) -> State:
        """Exact body momentum ``A(t)`` for n = 3 (Jacobi elliptic functions) and the attitude R(t).

        Parameters
        ----------
        t : array_like, shape (m,)
            Times since the initial state.
        y0 : dict
            Initial state (any batch shape).

        Returns
        -------
        dict
            ``{"A": (m, *batch, 3, 3), "Omega": (m, *batch, 3, 3)}`` and, when the top carries
            its orientation, ``"R": (m, *batch, 3, 3)``: ``R(t) = R(0) P Q̃(t) Pᵀ`` with the body
            increment Q̃ of the principal frame from an elliptic integral of the third kind
            (:func:`~lieint.systems.euler_top_attitude.euler_top_rotation`, after Celledoni,
            Fassò, Säfström & Zanna 2008).
        """
        if self.n != 3:
            raise ValueError(f"The exact solution is implemented for n = 3; this top has n = {self.n}.")
        A0 = self.validate_state(y0, "y0")["A"]
        t = np.atleast_1d(as_float_array(t, "t"))
        batch = A0.shape[:-2]
        P = self.P
        # Principal frame: Ã = PᵀAP = −Π̂, w = Π/I (I_k = b_i + b_j) by correctly rounded divisions,
        # as the exact_flow step forms it (multiplying by the rounded reciprocals errs the same way
        # for every state)
        I = self.principal_moments
        w0 = -vee(P.T @ A0 @ P) / I
        flat = w0.reshape(-1, 3)
        w = np.stack([euler_top_angular_velocity(I, wi, t) for wi in flat], axis=1)
        Om_principal = hat(w).reshape((t.size,) + batch + (3, 3))
        Om = Om_principal if self._diagonal else P @ Om_principal @ P.T
        out = {"A": self.momentum(Om), "Omega": Om}
        if self.orientation:
            from .euler_top_attitude import euler_top_rotation

            Q = np.stack([euler_top_rotation(I, wi, t) for wi in flat], axis=1)  # (m, members, 3, 3)
            Q = Q.reshape((t.size,) + batch + (3, 3))
            if not self._diagonal:
                Q = P @ Q @ P.T
            R0 = self.validate_state(y0, "y0")["R"]
            out["R"] = R0 @ Q
        return out

    # -- numeric parameters (lieint.sensitivity) ------------------------------------------
    def parameter_values(self) -> dict[str, np.ndarray]:
        """The numeric parameters a run can be differentiated by (:func:`lieint.sensitivity`).

        Returns
        -------
        dict of ndarray
            ``{"B": B}``, the mass tensor.
        """
        return {"B": self.B.copy()}

    def _assign_parameter(self, name: str, value: np.ndarray) -> None:
        self.inertia = ComplexStepInertia(value)
        self.B, self.b, self.P = self.inertia.B, self.inertia.b, self.inertia.P
        self._diagonal = self.inertia.diagonal
        self._minus_inv_pair = getattr(self.inertia, "minus_inv_pair", None)
        self._B2 = self.inertia.B2

    def __repr__(self) -> str:
        return f"EulerTop(n={self.n}, b={describe(self.b)}, orientation={self.orientation})"


def _broadcast_batch(shape_a, shape_b, name_b, name_a) -> tuple[int, ...]:
    try:
        return np.broadcast_shapes(shape_a, shape_b)
    except ValueError:
        raise ValueError(f"Batch shapes of `{name_a}` {shape_a} and `{name_b}` {shape_b} do not broadcast.") from None
