"""One particle in Rⁿ: central force, force of constant direction, constrained to a surface
(docs/theory.md §10).

The state is the position ``"q"`` and velocity ``"v"`` (batched over leading axes), moved by
the translations ``Rⁿ × Rⁿ`` with the generator ``(q̇, q̈) = (v, a(t, q, v))``: on this
abelian group a Lie-group method is the classical scheme. The symplectic methods
``"verlet"`` and ``"rattle"`` (:mod:`lieint.methods.symplectic`) step these systems by what
they declare in :attr:`structure`:

* ``"newtonian"``: ``q̈ = a(t, q)`` does not depend on v (:meth:`Particle.acceleration`);
* ``"surface_constrained"``: ``m q̈ = f(t, q) + λ ∇h(q)`` on ``h(q) = 1``
  (:class:`SurfaceParticle`).

Bivector invariants (docs/theory.md §10): a central force toward C keeps ``(q − C) ∧ q̇``; a force of
constant direction e keeps ``e ∧ q̇``; on a surface of revolution about ``(C, e)`` with a force
along e, ``(q − C) ∧ q̇ ∧ e`` (Clairaut; Newton, Principia I.55). Bivectors are skew matrices
(``u ∧ v = u vᵀ − v uᵀ``), trivectors their components (:mod:`lieint.systems.multivectors`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike

from .._validation import as_float_array, check_finite_positive, check_vector, describe
from ..groups.bivectors import wedge
from ..groups.vector import ProductGroup, VectorSpace
from .base import Invariant, LieGroupSystem, Output, State
from .multivectors import trivector
from .surfaces import Sphere, Surface, SurfaceOfRevolution, make_surface

__all__ = [
    "CentralForceParticle",
    "ConstantForceParticle",
    "Particle",
    "RadialPotential",
    "SurfaceParticle",
    "constant_force_particle",
    "surface_particle",
]


class Particle(LieGroupSystem):
    """A particle of mass m in Rⁿ (base class; see the module docstring).

    Subclasses give :meth:`acceleration` (and :meth:`potential_energy` for the energy).
    """

    autonomous = True
    structure = frozenset({"newtonian"})
    field_kinds = MappingProxyType({"q": "point", "v": "vector"})

    def __init__(self, mass: float, n: int):
        self.mass = check_finite_positive(mass, "mass")
        self.n = n
        self.fields = {"q": (n,), "v": (n,)}
        self.group = ProductGroup(VectorSpace((n,)), VectorSpace((n,)))

    # -- physics ---------------------------------------------------------------------
    def acceleration(self, t: float | np.ndarray, q: np.ndarray) -> np.ndarray:
        """``q̈ = f(q)/m`` (batched).

        Parameters
        ----------
        t : float or ndarray
            The time.
        q : ndarray, shape (..., n)
            Positions.

        Returns
        -------
        ndarray, shape (..., n)
            q̈.
        """
        raise NotImplementedError

    def potential_energy(self, q: np.ndarray) -> np.ndarray:
        """``V(q)`` with ``f = −∇V``.

        Parameters
        ----------
        q : ndarray, shape (..., n)
            Positions.

        Returns
        -------
        ndarray, shape (...)
            V(q).
        """
        raise NotImplementedError

    def energy(self, y: State) -> np.ndarray:
        """``½ m |q̇|² + V(q)``.

        Parameters
        ----------
        y : dict of ndarray
            States ``{"q", "v"}`` (any leading shape).

        Returns
        -------
        ndarray
            The energy per state.
        """
        v = y["v"]
        return 0.5 * self.mass * np.sum(v * v, axis=-1) + self.potential_energy(y["q"])

    # -- the LieGroupSystem contract ---------------------------------------------------
    def generator(self, t: float | np.ndarray, y: State) -> np.ndarray | tuple[np.ndarray, ...]:
        return (y["v"], self.acceleration(t, y["q"]))

    def act(self, g: np.ndarray | tuple[np.ndarray, ...], y: State) -> State:
        dq, dv = g
        return {"q": y["q"] + dq, "v": y["v"] + dv}

    def infinitesimal_action(self, xi: np.ndarray | tuple[np.ndarray, ...], y: State) -> State:
        return {"q": xi[0], "v": xi[1]}

    @property
    def invariants(self) -> dict[str, Invariant]:
        return {"energy": Invariant(lambda t, y: self.energy(y), "integral", "½ m |q̇|² + V(q)")}

    @property
    def outputs(self) -> dict[str, Output]:
        out = dict(super().outputs)
        out["momentum"] = Output(lambda t, y: self.mass * y["v"], (self.n,), "linear momentum m q̇", "vector")
        return out

    def initial_state(self, *, position: ArrayLike, velocity: ArrayLike | None = None) -> State:
        """State from the ``position`` q and ``velocity`` q̇ (default 0), batched alike.

        Parameters
        ----------
        position : array_like, shape (..., n)
            The position q.
        velocity : array_like, shape (..., n), optional
            The velocity q̇ (default: at rest).

        Returns
        -------
        dict of ndarray
            ``{"q", "v"}``, batched alike.
        """
        q = check_vector(position, "position", self.n, batch=True)
        v = np.zeros_like(q) if velocity is None else check_vector(velocity, "velocity", self.n, batch=True)
        batch = np.broadcast_shapes(q.shape[:-1], v.shape[:-1])
        return {"q": np.broadcast_to(q, batch + (self.n,)).copy(), "v": np.broadcast_to(v, batch + (self.n,)).copy()}


# -- central force ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class RadialPotential:
    """A potential ``V(r)`` of the distance r to the centre, with its derivative ``V'(r)``.

    Build one with :meth:`kepler`, :meth:`harmonic` or :meth:`power`, or from two callables.
    """

    value: Callable[[np.ndarray], np.ndarray]
    derivative: Callable[[np.ndarray], np.ndarray]
    description: str = "V(r)"

    @classmethod
    def kepler(cls, k: float = 1.0) -> RadialPotential:
        """``V(r) = −k / r`` (attraction k > 0)."""
        k = check_finite_positive(k, "strength")
        return cls(lambda r: -k / r, lambda r: k / r**2, f"-{k:g}/r")

    @classmethod
    def harmonic(cls, k: float = 1.0) -> RadialPotential:
        """``V(r) = ½ k r²``."""
        k = check_finite_positive(k, "strength")
        return cls(lambda r: 0.5 * k * r**2, lambda r: k * r, f"{k:g} r²/2")

    @classmethod
    def power(cls, k: float, exponent: float) -> RadialPotential:
        """``V(r) = k rᵖ / p`` (p ≠ 0; attraction for k > 0)."""
        p = float(exponent)
        if p == 0 or not np.isfinite(p):
            raise ValueError(f"`exponent` must be a finite nonzero number; got {exponent!r}.")
        k = float(k)
        return cls(lambda r: k * r**p / p, lambda r: k * r ** (p - 1), f"{k:g} r^{p:g}/{p:g}")


#: potentials a scene can name
POTENTIALS = ("kepler", "harmonic", "power")


class CentralForceParticle(Particle):
    """A particle under a central force toward C: ``m q̈ = −V'(r) (q − C)/r``, ``r = |q − C|``.

    Parameters
    ----------
    mass : float
        m > 0.
    centre : array_like, shape (n,)
        The centre C (its length sets n).
    potential : RadialPotential or {"kepler", "harmonic", "power"}
        ``V(r)``; a name uses ``strength`` k (and ``exponent`` p for "power").
    strength, exponent : float, optional
        Parameters of a named potential.

    Notes
    -----
    Invariants: ``energy`` ``½m|q̇|² + V(r)`` and ``angular_momentum``, the bivector
    ``m (q − C) ∧ q̇`` (docs/theory.md §10, any n).

    Examples
    --------
    >>> import lieint
    >>> kepler = lieint.CentralForceParticle(1.0, [0.0, 0.0, 0.0], "kepler")
    >>> y0 = kepler.initial_state(position=[1.0, 0.0, 0.0], velocity=[0.0, 1.2, 0.1])
    >>> sol = lieint.integrate(kepler, y0, (0.0, 10.0), h=0.01, method="verlet")
    >>> bool(sol.drift("angular_momentum") < 1e-13)
    True
    """

    def __init__(
        self,
        mass: float,
        centre: ArrayLike,
        potential: RadialPotential | str = "kepler",
        *,
        strength: float = 1.0,
        exponent: float | None = None,
    ):
        c = as_float_array(centre, "centre")
        if c.ndim != 1 or c.size < 2:
            raise ValueError(f"`centre` must be a vector of dimension n ≥ 2; got shape {c.shape}.")
        super().__init__(mass, c.size)
        self.centre = c
        self.potential = _radial_potential(potential, strength, exponent)

    def acceleration(self, t: float | np.ndarray, q: np.ndarray) -> np.ndarray:
        """``q̈ = −V'(r) (q − C)/(m r)``.

        Parameters
        ----------
        t : float or ndarray
            The time.
        q : ndarray, shape (..., n)
            Positions.

        Returns
        -------
        ndarray, shape (..., n)
            q̈.
        """
        d = q - self.centre
        r = np.linalg.norm(d, axis=-1, keepdims=True)
        return -(self.potential.derivative(r) / (self.mass * r)) * d

    def potential_energy(self, q: np.ndarray) -> np.ndarray:
        """``V(|q − C|)``.

        Parameters
        ----------
        q : ndarray, shape (..., n)
            Positions.

        Returns
        -------
        ndarray, shape (...)
            V(q).
        """
        return self.potential.value(np.linalg.norm(q - self.centre, axis=-1))

    @property
    def invariants(self) -> dict[str, Invariant]:
        declared = super().invariants
        declared["angular_momentum"] = Invariant(
            lambda t, y: self.mass * wedge(y["q"] - self.centre, y["v"]), "integral", "m (q − C) ∧ q̇"
        )
        return declared

    def __repr__(self) -> str:
        return (
            f"CentralForceParticle(n={self.n}, mass={self.mass:g}, centre={describe(self.centre)}, "
            f"potential={self.potential.description})"
        )


def _radial_potential(potential, strength, exponent) -> RadialPotential:
    if isinstance(potential, RadialPotential):
        return potential
    if potential == "kepler":
        return RadialPotential.kepler(strength)
    if potential == "harmonic":
        return RadialPotential.harmonic(strength)
    if potential == "power":
        if exponent is None:
            raise ValueError('`exponent` is needed for potential = "power" (V = k r^p / p).')
        return RadialPotential.power(strength, exponent)
    raise ValueError(f"`potential` must be a RadialPotential or one of {list(POTENTIALS)}; got {potential!r}.")


# -- force of constant direction ------------------------------------------------------------------


class ConstantForceParticle(Particle):
    """A particle under a constant force f (uniform gravity): ``m q̈ = f``.

    Parameters
    ----------
    mass : float
        m > 0.
    force : array_like, shape (n,)
        The force f ≠ 0; its direction is ``e = f/|f|``.

    Notes
    -----
    Invariants: ``energy`` ``½m|q̇|² − ⟨f, q⟩`` and ``force_bivector`` ``e ∧ q̇`` (docs/theory.md §10).

    Examples
    --------
    A throw under gravity: classical RK4 is exact on the parabola.

    >>> import lieint
    >>> stone = lieint.ConstantForceParticle(2.0, [0.0, 0.0, -19.62])
    >>> y0 = stone.initial_state(position=[0.0, 0.0, 0.0], velocity=[1.0, 0.0, 4.905])
    >>> sol = lieint.integrate(stone, y0, (0.0, 1.0), h=0.1, method="rk4")
    >>> sol.states["q"][-1].round(12).tolist()  # back on the ground after 1 s
    [1.0, 0.0, 0.0]
    """

    def __init__(self, mass: float, force: ArrayLike):
        f = as_float_array(force, "force")
        if f.ndim != 1 or f.size < 2 or not np.linalg.norm(f) > 0:
            raise ValueError(f"`force` must be a nonzero vector of dimension n ≥ 2; got {describe(f)}.")
        super().__init__(mass, f.size)
        self.force = f
        self.direction = f / np.linalg.norm(f)

    def acceleration(self, t: float | np.ndarray, q: np.ndarray) -> np.ndarray:
        """``q̈ = f/m``.

        Parameters
        ----------
        t : float or ndarray
            The time.
        q : ndarray, shape (..., n)
            Positions.

        Returns
        -------
        ndarray, shape (..., n)
            q̈, the same everywhere.
        """
        return np.broadcast_to(self.force / self.mass, np.shape(q)).copy()

    def potential_energy(self, q: np.ndarray) -> np.ndarray:
        """``V(q) = −⟨f, q⟩``.

        Parameters
        ----------
        q : ndarray, shape (..., n)
            Positions.

        Returns
        -------
        ndarray, shape (...)
            V(q).
        """
        return -(q @ self.force)

    @property
    def invariants(self) -> dict[str, Invariant]:
        declared = super().invariants
        declared["force_bivector"] = Invariant(lambda t, y: wedge(self.direction, y["v"]), "integral", "e ∧ q̇")
        return declared

    def __repr__(self) -> str:
        return f"ConstantForceParticle(n={self.n}, mass={self.mass:g}, force={describe(self.force)})"


def constant_force_particle(mass: float, force) -> ConstantForceParticle:
    """Catalog factory of :class:`ConstantForceParticle` (scenes name it "constant_force_particle")."""
    return ConstantForceParticle(mass, force)


# -- particle on a surface ------------------------------------------------------------------------


class SurfaceParticle(Particle):
    """A particle on the surface ``h(q) = 1`` under a constant force f (docs/theory.md §10).

    ``m q̈ = f + λ ∇h(q)``, with the multiplier λ from ``⟨∇h, q̈⟩ + q̇ᵀ ∇²h q̇ = 0``::

        λ = −(⟨∇h, f⟩ + m q̇ᵀ∇²h q̇) / |∇h|².

    The constrained method ``"rattle"`` keeps ``h(q) = 1`` and ``⟨∇h, q̇⟩ = 0`` to round-off;
    other methods step the equations above and keep them through ``project=True``.

    Parameters
    ----------
    mass : float
        m > 0.
    surface : Surface
        :class:`~lieint.systems.surfaces.Sphere`, :class:`~lieint.systems.surfaces.Ellipsoid`,
        :class:`~lieint.systems.surfaces.SurfaceOfRevolution` or any
        :class:`~lieint.systems.surfaces.Surface`.
    force : array_like, shape (n,), optional
        Constant force f (None: none).

    Notes
    -----
    Invariants: ``energy`` ``½m|q̇|² − ⟨f, q⟩``; the defects ``constraint`` ``h(q) − 1`` and
    ``tangency`` ``⟨∇h(q), q̇⟩``; on a surface of revolution (or a sphere) with f along its axis
    (or f = 0), ``clairaut`` ``(q − C) ∧ q̇ ∧ e`` (for n = 3 the one component, m-free: the
    angular momentum about the axis over m); on a sphere without force, ``angular_momentum``
    ``m (q − C) ∧ q̇``.

    Examples
    --------
    >>> import lieint
    >>> from lieint.systems.surfaces import SurfaceOfRevolution
    >>> egg = SurfaceOfRevolution([0.0, 0.0, 1.0, 0.3], axis=[0.0, 0.0, 1.0])
    >>> p = lieint.SurfaceParticle(1.0, egg, force=[0.0, 0.0, -1.0])
    >>> y0 = p.initial_state(position=egg.point([1.0, 0.0, 0.2]), velocity=[0.0, 0.8, 0.0])
    >>> sol = lieint.integrate(p, y0, (0.0, 5.0), h=0.01, method="rattle")
    >>> bool(sol.drift("constraint") < 1e-14 and sol.drift("clairaut") < 1e-13)
    True
    """

    structure = frozenset({"surface_constrained"})

    def __init__(self, mass: float, surface: Surface, force: ArrayLike | None = None):
        if not isinstance(surface, Surface):
            raise TypeError(
                f"`surface` must be a Surface (Sphere, Ellipsoid, SurfaceOfRevolution); got {type(surface).__name__} "
                "(scenes name it through the catalog factory `surface_particle`)."
            )
        super().__init__(mass, surface.n)
        self.surface = surface
        self.force = np.zeros(self.n) if force is None else check_vector(force, "force", self.n)
        self.axis = self._symmetry_axis()

    def _symmetry_axis(self) -> np.ndarray | None:
        """The axis e about which the surface and the force are symmetric (None if none)."""
        fnorm = np.linalg.norm(self.force)
        if isinstance(self.surface, SurfaceOfRevolution):
            e = self.surface.axis
            parallel = np.linalg.norm(self.force - (self.force @ e) * e) <= 1e-14 * max(fnorm, 1.0)
            return e if parallel else None
        if isinstance(self.surface, Sphere) and fnorm > 0:
            return self.force / fnorm
        return None

    def external_force(self, t: float | np.ndarray, q: np.ndarray) -> np.ndarray:
        """The applied force f (constant), broadcast to q's shape.

        Parameters
        ----------
        t : float or ndarray
            The time.
        q : ndarray, shape (..., n)
            Positions.

        Returns
        -------
        ndarray, shape (..., n)
            f.
        """
        return np.broadcast_to(self.force, np.shape(q))

    def multiplier(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """λ of the constraint force ``λ∇h`` (see the class docstring).

        Parameters
        ----------
        q, v : ndarray, shape (..., n)
            Position on the surface and tangent velocity.

        Returns
        -------
        ndarray, shape (...)
            λ.
        """
        g = self.surface.gradient(q)
        return -(g @ self.force + self.mass * self.surface.hessian_form(q, v)) / np.sum(g * g, axis=-1)

    def generator(self, t: float | np.ndarray, y: State) -> np.ndarray | tuple[np.ndarray, ...]:
        q, v = y["q"], y["v"]
        lam = self.multiplier(q, v)
        acc = (self.force + lam[..., None] * self.surface.gradient(q)) / self.mass
        return (v, acc)

    def potential_energy(self, q: np.ndarray) -> np.ndarray:
        """``V(q) = −⟨f, q⟩``.

        Parameters
        ----------
        q : ndarray, shape (..., n)
            Positions.

        Returns
        -------
        ndarray, shape (...)
            V(q).
        """
        return -(q @ self.force)

    def project(self, y: State) -> State:
        """q onto ``h = 1`` by Newton along ∇h (to round-off), then v onto the tangent space.

        Parameters
        ----------
        y : dict of ndarray
            A state ``{"q", "v"}`` near the surface.

        Returns
        -------
        dict of ndarray
            The state on the surface, with a tangent velocity.
        """
        q = y["q"]
        for _ in range(50):
            g = self.surface.gradient(q)
            r = self.surface.h(q) - 1.0
            q = q - (r / np.sum(g * g, axis=-1))[..., None] * g
            if np.all(np.abs(r) <= 1e-15):
                break
        g = self.surface.gradient(q)
        v = y["v"] - (np.sum(g * y["v"], axis=-1) / np.sum(g * g, axis=-1))[..., None] * g
        return {"q": q, "v": v}

    @property
    def invariants(self) -> dict[str, Invariant]:
        declared = {
            "energy": Invariant(lambda t, y: self.energy(y), "integral", "½ m |q̇|² − ⟨f, q⟩"),
            "constraint": Invariant(lambda t, y: self.surface.h(y["q"]) - 1.0, "defect", "h(q) − 1"),
            "tangency": Invariant(
                lambda t, y: np.sum(self.surface.gradient(y["q"]) * y["v"], axis=-1), "defect", "⟨∇h(q), q̇⟩"
            ),
        }
        C = self.surface.centre
        if self.axis is not None and self.n >= 3:
            e = self.axis
            declared["clairaut"] = Invariant(
                lambda t, y: trivector(y["q"] - C, y["v"], np.broadcast_to(e, np.shape(y["q"]))),
                "integral",
                "(q − C) ∧ q̇ ∧ e (Clairaut)",
            )
        if isinstance(self.surface, Sphere) and not np.any(self.force):
            declared["angular_momentum"] = Invariant(
                lambda t, y: self.mass * wedge(y["q"] - C, y["v"]), "integral", "m (q − C) ∧ q̇"
            )
        return declared

    def initial_state(self, *, position: ArrayLike, velocity: ArrayLike | None = None) -> State:
        """State from a ``position`` on the surface and a tangent ``velocity``, projected exactly.

        ``surface.point(direction)`` gives a point of the surface.

        Parameters
        ----------
        position : array_like, shape (..., n)
            A point with ``|h(q) − 1| ≤ 1e-9``.
        velocity : array_like, shape (..., n), optional
            A tangent velocity, ``|⟨∇h, q̇⟩| ≤ 1e-9 |∇h||q̇|`` (default: at rest).

        Returns
        -------
        dict of ndarray
            ``{"q", "v"}`` on the surface to round-off.
        """
        y = super().initial_state(position=position, velocity=velocity)
        off = np.abs(self.surface.h(y["q"]) - 1.0)
        if np.any(off > 1e-9):
            raise ValueError(
                f"`position` must lie on the surface (h(q) = 1); got h(q) − 1 = {describe(off)}. "
                "Use `surface.point(direction)` for a point of the surface."
            )
        g = self.surface.gradient(y["q"])
        normal = np.abs(np.sum(g * y["v"], axis=-1))
        scale = np.linalg.norm(g, axis=-1) * np.linalg.norm(y["v"], axis=-1)
        if np.any(normal > 1e-9 * np.maximum(scale, 1e-300)):
            raise ValueError(
                f"`velocity` must be tangent to the surface (⟨∇h, q̇⟩ = 0); got ⟨∇h, q̇⟩ = {describe(normal)}."
            )
        return self.project(y)

    def validate_state(self, y: Mapping[str, np.ndarray], name: str = "y0") -> State:
        out = super().validate_state(y, name)
        off = np.abs(self.surface.h(out["q"]) - 1.0)
        if np.any(off > 1e-6):
            raise ValueError(f"`{name}['q']` must lie on the surface h(q) = 1; got h(q) − 1 = {describe(off)}.")
        return out

    def __repr__(self) -> str:
        return f"SurfaceParticle(mass={self.mass:g}, surface={self.surface!r}, force={describe(self.force)})"


def surface_particle(
    mass: float,
    surface: str = "sphere",
    force=None,
    *,
    n: int | None = None,
    radius=None,
    semi_axes=None,
    profile=None,
    axis=None,
    centre=None,
) -> SurfaceParticle:
    """Catalog factory of :class:`SurfaceParticle` with the surface as data (what scenes give).

    ``surface`` names the kind ("sphere", "ellipsoid", "revolution"); the other keywords are
    those of :func:`~lieint.systems.surfaces.make_surface`. A sphere's dimension is taken from
    ``centre`` or ``force`` when ``n`` is not given.
    """
    if isinstance(surface, Surface):
        return SurfaceParticle(mass, surface, force)
    if n is None and surface == "sphere" and centre is None and force is not None:
        n = np.size(force)
    if n is not None:
        n = int(n)
    built = make_surface(surface, n=n, radius=radius, semi_axes=semi_axes, profile=profile, axis=axis, centre=centre)
    return SurfaceParticle(mass, built, force)
