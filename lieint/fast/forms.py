"""What systems and methods declare to the compiled engine (plain Python: no numba at import).

A system's ``compiled()`` returns one of the *system forms* below — an object that says which
family of compiled stage functions steps it and with which numbers — and a method's
``compiled()`` one of the *method forms*. The engine (:mod:`lieint.fast.engine`) matches the
two; nothing here imports numba, so building a system or a method stays cheap and
``import lieint`` light.

System forms:

* :class:`Top3Form` — the 3D Euler top in its principal frame (``(Π, R P)``; the fastest
  stage code of the package, and SIMD lanes for ensembles);
* :class:`TopNForm` — the Euler top in n ≥ 4 dimensions in its principal frame;
* :class:`PiecesForm` — any system on ``SO(n)`` or ``SE(n)`` times ``Rᵐ`` that supplies compiled
  *pieces* (generator, action, vector field, projection: :mod:`lieint.fast.pieces`), the
  built-in heavy top, free body and balls among them (:data:`BUILTIN_PIECES`), and any system
  outside the package that declares its own; the 3D heavy top's and the 3D Chaplygin ball's also
  name :class:`HeavyTop3Form` and :class:`Chaplygin3Form`, their ensembles in SIMD lanes.

Method forms: :class:`RKMKForm` (explicit Runge–Kutta–Munthe-Kaas in exponential or Cayley
coordinates, fixed-step or an embedded pair), :class:`ExpProductForm` (products of exponentials
of frozen stage generators: the commutator-free and Crouch–Grossman methods),
:class:`ClassicalForm` (classical explicit RK on the embedding space) and :class:`MapForm` (a
method whose step is a map of its own — the Moser–Veselov family, the splittings — with stage
code for some system forms only).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = [
    "BUILTIN_PIECES",
    "Chaplygin3Form",
    "ClassicalForm",
    "ExpProductForm",
    "HeavyTop3Form",
    "LazyPieces",
    "MapForm",
    "PiecesForm",
    "PrescribedForm",
    "RKMKForm",
    "Top3Form",
    "TopNForm",
]


# -- method forms ------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class RKMKForm:
    """An explicit RKMK method: tableau ``(A, b, c)``, coordinates ("exp" with the dexp⁻¹ series
    truncated at ``degree``, or "cayley" with the exact dcay⁻¹) and, for an embedded pair, the
    embedded weights ``b_hat`` (DOP853's third-order ``b_low`` too) and the controller's error
    order q. ``keeps_energy``: the pair of an energy-keeping method
    (:mod:`lieint.methods.energy_projection`: the spin about the momentum flowed exactly, every
    step moved onto the initial energy), compiled as the family ``rkmk_energy`` of the 3D top,
    the n-D top and compiled pieces that declare an energy."""

    A: np.ndarray
    b: np.ndarray
    c: np.ndarray
    coordinates: str
    degree: int | None
    b_hat: np.ndarray | None = None
    b_low: np.ndarray | None = None
    error_order: int | None = None
    keeps_energy: bool = False

    family = "rkmk"

    @property
    def stages(self) -> int:
        return int(np.asarray(self.b).size)

    @property
    def pair(self) -> bool:
        return self.b_hat is not None


@dataclass(frozen=True, eq=False)
class ExpProductForm:
    """A method that steps by products of exponentials of linear combinations of its frozen stage
    generators (:class:`lieint.methods.commutator_free.CommutatorFree`: the commutator-free and
    Crouch–Grossman methods), on every system form RKMK runs on::

        Y_i = ρ(exp(h Σ_k W[e_i,J] ξ_k), … ρ(exp(h Σ_k W[e_i,1] ξ_k), y₀) …),  ξ_i = ξ(Y_i),
        y₁  = ρ(exp(h Σ_k W[e_J] ξ_k), … ρ(exp(h Σ_k W[e_1] ξ_k), y₀) …).

    ``weights`` (E, s) holds one row per exponential, stage after stage and then the step's;
    ``bounds`` (s + 2,) says which: stage i applies the rows ``bounds[i]:bounds[i + 1]`` in order,
    the step the rows ``bounds[s]:bounds[s + 1]``. A Crouch–Grossman method is the case of one
    nonzero weight per row. A step's increment (what dense output interpolates) is the list of
    the step's exponents ``h Σ_k W[e] ξ_k``, one after another: their product is the step's group
    element, logged when an interpolant is built (as on the numpy path)."""

    c: np.ndarray
    weights: np.ndarray
    bounds: np.ndarray

    family = "cf"
    coordinates = None
    pair = False

    @property
    def stages(self) -> int:
        return int(np.asarray(self.c).size)

    @property
    def outputs(self) -> int:
        """The step's exponentials (each contributes one exponent to the increment)."""
        return int(self.bounds[-1] - self.bounds[-2])


@dataclass(frozen=True, eq=False)
class ClassicalForm:
    """Classical explicit Runge–Kutta on the embedding space: tableau ``(A, b, c)``."""

    A: np.ndarray
    b: np.ndarray
    c: np.ndarray

    family = "rk"
    coordinates = None
    pair = False

    @property
    def stages(self) -> int:
        return int(np.asarray(self.b).size)


@dataclass(frozen=True, eq=False)
class MapForm:
    """A method whose step is a map of its own, not a tableau: the Moser–Veselov family, the
    splittings into exact rotations, the exact flow, the implicit midpoint.

    ``family`` names the map (``"moser_veselov"``, ``"splitting"``); ``modules`` maps the system forms the map
    has stage code for (by class name, ``"Top3Form"``) to the module holding it
    (``"lieint.fast.top3_mv"``) — a system form not listed has no compiled form of the map, and
    the run says so (:meth:`covers`). ``substeps`` are the fractions of h of the map's substeps (a symmetric
    composition; ``(1.0,)`` for one map a step); ``degree`` the degree of the modified moments'
    series (0: the plain map) and ``coefficients`` the function ``moments -> (s, d)`` giving
    their coefficients (:func:`lieint.methods.modified_mv.modified_coefficients`); ``planes``
    the coordinate planes ``(i, j)`` of a splitting's rotations in the order of its Strang step
    (principal frame of the 3D top). A map's stage module whose steps report no increment in the
    algebra says so (``INCREMENT = False``): dense output then works from the states, as the numpy
    path's does for such a step.
    """

    family: str
    modules: dict
    substeps: tuple = (1.0,)
    degree: int = 0
    coefficients: Any = None
    planes: tuple = ()

    coordinates = None
    pair = False

    @property
    def stages(self) -> int:
        """Generator solves per step (what a run reports as evaluations)."""
        return len(self.substeps)

    def covers(self, system_form) -> bool:
        """Whether the map has compiled stage code for ``system_form`` (a system form object)."""
        return type(system_form).__name__ in self.modules

    def module_for(self, system_form) -> str:
        """The module of the map's stage functions for ``system_form``."""
        return self.modules[type(system_form).__name__]


# -- system forms ------------------------------------------------------------------------------


@dataclass(frozen=True)
class LazyPieces:
    """Compiled pieces defined in a module of the compiled layer, named so that declaring them
    imports no numba (:attr:`resolve` imports the module on first use)."""

    module: str
    name: str

    def resolve(self):
        """The :class:`lieint.fast.pieces.CompiledPieces`."""
        return getattr(importlib.import_module(self.module), self.name)


class _BuiltinPieces:
    """The built-in systems' compiled pieces, by attribute (``BUILTIN_PIECES.heavy_top``)."""

    euler_top = LazyPieces("lieint.fast.bodies", "EULER_TOP")
    heavy_top = LazyPieces("lieint.fast.bodies", "HEAVY_TOP")
    free_body = LazyPieces("lieint.fast.bodies", "FREE_BODY")
    chaplygin = LazyPieces("lieint.fast.balls", "CHAPLYGIN")
    rolling_ball = LazyPieces("lieint.fast.balls", "ROLLING_BALL")


#: the compiled pieces of the built-in systems on SO(n)/SE(n) × Rᵐ
BUILTIN_PIECES = _BuiltinPieces()


@dataclass(frozen=True, eq=False)
class PiecesForm:
    """A system on ``SO(n)`` (``translation=False``) or ``SE(n)`` times ``Rᵐ`` (``abelian = m``)
    stepped through compiled pieces (a :class:`lieint.fast.pieces.CompiledPieces`, or a
    :class:`LazyPieces` naming one), with its parameters as one float vector and its state
    flattened field after field (``fields``: name → trailing shape, in the state's order).

    ``group`` names the group in messages (default ``"so(n)"``/``"se(n)"``)."""

    pieces: Any
    params: np.ndarray
    n: int
    translation: bool
    abelian: int
    fields: dict
    group: str = ""
    #: the same system as a form for ensembles in SIMD lanes (:class:`HeavyTop3Form`,
    #: :class:`Chaplygin3Form`, :class:`RollingBall3Form`), or None
    lanes: Any = field(default=None, repr=False)

    def __post_init__(self):
        if not self.group:
            object.__setattr__(self, "group", f"{'se' if self.translation else 'so'}({self.n})")


@dataclass(frozen=True, eq=False)
class Top3Form:
    """The 3D Euler top: principal moments, principal frame P (columns), whether the state
    carries the attitude R; ``generic`` is the same top as a :class:`PiecesForm` (its Cayley
    coordinates run there)."""

    moments: np.ndarray
    P: np.ndarray
    orientation: bool
    generic: PiecesForm | None = field(default=None, repr=False)


@dataclass(frozen=True, eq=False)
class HeavyTop3Form:
    """The 3D heavy top for ensembles in SIMD lanes (:mod:`lieint.fast.heavy_lanes`): the principal
    moments and frame P (columns) of its top, ``M X_G`` in the body frame, ``|g|``, whether the
    state carries the attitude R. Declared as :attr:`PiecesForm.lanes` of the heavy top's pieces,
    which step everything else (one body, adaptive steps, Cayley coordinates, classical RK)."""

    moments: np.ndarray
    P: np.ndarray
    MXG: np.ndarray
    gravity: float
    orientation: bool


@dataclass(frozen=True, eq=False)
class Chaplygin3Form:
    """The 3D Chaplygin ball for ensembles in SIMD lanes (:mod:`lieint.fast.chaplygin_lanes`):
    its mass tensor about the centre ``B_C``, ``M r²``, the radius r, the plane's normal ν, whether
    the state carries R and the centre. Declared as :attr:`PiecesForm.lanes` of the ball's pieces."""

    B_C: np.ndarray
    Mr2: float
    radius: float
    normal: np.ndarray
    orientation: bool
    center: bool


@dataclass(frozen=True, eq=False)
class RollingBall3Form:
    """The 3D rolling ball for ensembles in SIMD lanes (:mod:`lieint.fast.rolling_lanes`): its mass
    tensor about the centre ``B_C``, the mass M, the radius r, the centre of mass X_G, the plane's
    normal ν, the gravity mode (0 none, 1 along ν, 2 tilted: G a field), ``⟨g, ν⟩``, ``|g|``,
    whether the state carries R and the centre. Declared as :attr:`PiecesForm.lanes` of the ball's
    pieces."""

    B_C: np.ndarray
    mass: float
    radius: float
    center_of_mass: np.ndarray
    normal: np.ndarray
    mode: int
    g_normal: float
    g_norm: float
    orientation: bool
    center: bool


@dataclass(frozen=True, eq=False)
class PrescribedForm:
    """A rotation moved by prescribed body rates, ``Ṙ = R Ω(t)`` (:class:`lieint.PrescribedRotation`):
    the dimension n and ``rates(times) -> (m, n, n)``, Ω at an array of times (with the system's
    own checks and messages: sampled rates are refused outside their samples). The Magnus
    methods step it (:mod:`lieint.fast.magnus`)."""

    n: int
    rates: Any = field(repr=False)


@dataclass(frozen=True, eq=False)
class TopNForm:
    """The Euler top in n ≥ 4 dimensions: eigenvalues b and eigenbasis P of the mass tensor
    ``B = P diag(b) Pᵀ``, whether the state carries R; ``generic`` as :class:`Top3Form`'s."""

    b: np.ndarray
    P: np.ndarray
    orientation: bool
    generic: PiecesForm | None = field(default=None, repr=False)

    @property
    def n(self) -> int:
        return int(np.asarray(self.b).size)
