"""The rotor form of any rigid-body system: the orientation carried on Spin(n), not SO(n).

A system whose group has an SO(n) factor moving its orientation by ``R ↦ R Q`` (the Euler
top, the heavy top, the free body, the rolling and the Chaplygin balls, and any system built
the same way) gets its rotor form by :class:`RotorForm`: the state field ``"R"`` is replaced by
``"rotor"`` (the ``2ⁿ`` coefficients of S ∈ Spin(n) ⊂ Cl(n), with R the rotation ``x ↦ S x S̃``),
and the group by :class:`SpinCover`, whose elements pair the system's own group element with
the rotor of its SO(n) part. The generator, the algebra, dexp⁻¹ and dcay⁻¹ are shared, so a
Lie-group method takes exactly the same stages on both forms; only R is replaced by

    S ↦ S e^{ω/2}      (the double cover of R ↦ R exp(X), ω the bivector of X),

with ``e^{ω/2}`` exact to round-off for every bivector (:func:`lieint.ga.exp`) and the Cayley
map's rotor the normalised outer exponential ``Π_k (1 + θ_k P_k/2)/√(1 + θ_k²/4)`` over the
planes ``P_k`` of ω. The exact projection onto the group is the rotor normalisation
``S (S̃S)^{-1/2}``.

Which fields a system moves with R (the rolling ball's centre moves by ``p + R v``) need not be
declared: the rotor form hands the system a state in which ``"R"`` is computed from the rotor
when it is read. A system declaring ``orientation_is_passive = True`` (R moves only itself and
nothing reads it) is handed a stand-in instead, which saves that conversion in every stage.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..groups.base import LieGroup
from ..groups.se import SE
from ..groups.so import SO
from ..groups.vector import ProductGroup
from ..systems.base import Invariant, LieGroupSystem, Output, State
from .algebra import GA, algebra, resolve
from .exponential import _rotation_of_rotor3, matrix_to_rotor, rotor_exp_of_skew, simple_planes, so_exp_with_rotor

__all__ = ["RotorForm", "SpinCover", "rotor_cay_of_skew", "rotor_form"]


def rotor_cay_of_skew(X: np.ndarray) -> np.ndarray:
    """Rotor of the Cayley transform ``cay(X) = (I − X/2)⁻¹(I + X/2)``.

    On each invariant plane of X (angle θ_k) the Cayley transform rotates by ``2 atan(θ_k/2)``;
    its rotor is the normalised outer exponential of ω/2: ``Π_k (1 + (θ_k/2) P_k)/√(1 + θ_k²/4)``.
    """
    X = np.asarray(X, dtype=float)
    n = X.shape[-1]
    ga = algebra(n)
    if n <= 3:
        b = 0.5 * ga.bivector(X)
        out = b.copy()
        out[..., 0] = 1.0
        return out / np.sqrt(1.0 + np.sum(b * b, axis=-1, keepdims=True))
    from .exponential import _plane_bivectors

    theta, u, v = simple_planes(X)
    factors = 0.5 * theta[..., None] * _plane_bivectors(ga, u, v)
    factors[..., 0] = 1.0
    factors = factors / np.sqrt(1.0 + 0.25 * theta**2)[..., None]
    out = factors[..., 0, :]
    for k in range(1, factors.shape[-2]):
        out = ga.product(out, factors[..., k, :])
    return out


def _rotation_part(group: LieGroup, n: int):
    """``X ↦`` the so(n) part of an algebra element of ``group`` (None: no SO(n) factor)."""
    if isinstance(group, SO) and group.n == n:
        return lambda X: X
    if isinstance(group, SE) and group.n == n:
        return lambda X: X[..., :n, :n]
    if isinstance(group, ProductGroup):
        for i, factor in enumerate(group.factors):
            part = _rotation_part(factor, n)
            if part is not None:
                return lambda X, i=i, part=part: part(X[i])
    return None


class SpinCover(LieGroup):
    """A group with its SO(n) factor also carried as rotors: elements ``(g, S)``.

    ``g`` is an element of the base group (it moves every field but the orientation), S the
    rotor of its SO(n) part. Algebra elements are those of the base group; dexp⁻¹, dcay⁻¹,
    linear combinations and the spectral radius of ad are the base group's.

    Parameters
    ----------
    base : LieGroup
        SO(n), SE(n) or a product group with one of them as a factor.
    n : int
        The dimension of the rotations (2 ≤ n ≤ 8).
    """

    def __init__(self, base: LieGroup, n: int):
        part = _rotation_part(base, n)
        if part is None:
            raise ValueError(f"`base` must have an SO({n}) or SE({n}) factor to carry rotors; got {base!r}.")
        self.base, self.n, self.ga = base, n, algebra(n)
        self.rotation_part = part
        so = [i for i, f in enumerate(getattr(base, "factors", ())) if isinstance(f, SO) and f.n == n]
        self._so_factor = so[0] if so else None
        self.dim = base.dim
        self.name = f"{base.name} (rotors)"

    # the group law: componentwise
    def identity(self, batch_shape=()):
        S = np.zeros((*batch_shape, self.ga.size))
        S[..., 0] = 1.0
        return (self.base.identity(batch_shape), S)

    def multiply(self, g, h):
        return (self.base.multiply(g[0], h[0]), self.ga.product(g[1], h[1]))

    def inverse(self, g):
        return (self.base.inverse(g[0]), self.ga.reverse(g[1]))

    def log(self, g):
        return self.base.log(g[0])

    def project(self, g):
        return (self.base.project(g[0]), self.ga.normalize(g[1]))

    # coordinate maps: the base's, with the rotor of the rotation part
    def exp(self, X):
        base = self.base
        if self.n > 3:  # scipy's expm of a small matrix is cheaper than building Q from the planes
            return (base.exp(X), rotor_exp_of_skew(self.rotation_part(X), 0.5))
        if isinstance(base, SO):  # rotation and rotor from one closed form
            return so_exp_with_rotor(X)
        if isinstance(base, ProductGroup) and self._so_factor is not None:
            i = self._so_factor
            Q, S = so_exp_with_rotor(X[i])
            g = tuple(Q if j == i else f.exp(x) for j, (f, x) in enumerate(zip(base.factors, X, strict=True)))
            return (g, S)
        return (base.exp(X), rotor_exp_of_skew(self.rotation_part(X), 0.5))

    def cay(self, X):
        return (self.base.cay(X), rotor_cay_of_skew(self.rotation_part(X)))

    # the algebra is the base's
    def dexpinv(self, u, v, degree=None):
        return self.base.dexpinv(u, v, degree)

    def dcayinv(self, X, v):
        return self.base.dcayinv(X, v)

    def ad_spectral_radius(self, X):
        return self.base.ad_spectral_radius(X)

    def ad_radius_upper_bound(self, X):
        return self.base.ad_radius_upper_bound(X)

    def lincomb(self, weights, elements):
        return self.base.lincomb(weights, elements)

    def negate(self, X):
        return self.base.negate(X)

    def __repr__(self) -> str:
        return f"SpinCover({self.base!r}, n={self.n})"


def rotor_matrix(ga: GA, S: np.ndarray) -> np.ndarray:
    """R of rotors, with the closed form ``I + 2sK + 2K²`` (s scalar part, K the skew matrix of
    the bivector part) for n ≤ 3, where a rotor is ``s + bivector``; for n ≥ 4 the quadratic
    form in the even part (:meth:`GA.even_rotor_matrix`). Either way only the grades a rotor
    has are read."""
    if ga.n == 3 and S.ndim == 1:  # one body: the same closed form in floats
        s, _, _, _, k12, k13, k23, _ = S.tolist()
        return _rotation_of_rotor3(s, k12, k13, k23)
    if ga.n <= 3:
        K = ga.skew(S)
        return np.eye(ga.n) + 2.0 * S[..., 0, None, None] * K + 2.0 * (K @ K)
    return ga.even_rotor_matrix(S)


class _WithR(dict):
    """A state whose ``"R"`` is computed from its rotor when read (once)."""

    def __init__(self, y: Mapping, ga: GA):
        super().__init__(y)
        self._ga = ga

    def __missing__(self, key):
        if key != "R":
            raise KeyError(key)
        R = rotor_matrix(self._ga, dict.__getitem__(self, "rotor"))
        self["R"] = R
        return R


class RotorForm(LieGroupSystem):
    """The rotor form of a system that carries its orientation as ``"R"`` (see the module).

    Parameters
    ----------
    system : LieGroupSystem
        A system with the field ``"R"`` (build it with ``orientation=True``) moved by the
        SO(n) factor of its group, ``R ↦ R Q``; 2 ≤ n ≤ 8.

    Notes
    -----
    State: the system's fields with ``"R"`` replaced by ``"rotor"`` (``2ⁿ`` coefficients in
    clifford's blade order). Invariants: the system's (those reading R get ``R = S · S̃``), with
    ``orthogonality`` replaced by ``rotor_defect`` ``‖S̃S − 1‖``. Outputs: the system's
    (``orientation`` is R of the rotor). :meth:`initial_state` takes the system's keywords,
    plus ``rotor`` (clifford rotor(s) or coefficients) instead of ``R``.

    Examples
    --------
    >>> import lieint
    >>> from lieint.ga import RotorForm
    >>> top = RotorForm(lieint.HeavyTop.lagrange(1.0, 0.5, 1.0, 0.3))
    >>> y0 = top.initial_state(angular_velocity=[0.1, 0.2, 5.0])
    >>> sol = lieint.integrate(top, y0, t_span=(0.0, 1.0), h=0.01, method="rkmk4")
    >>> bool(sol.drift("rotor_defect") < 1e-14)
    True
    """

    def __init__(self, system: LieGroupSystem):
        if not isinstance(system, LieGroupSystem):
            raise TypeError(f"`system` must be a lieint system; got {type(system).__name__}.")
        if isinstance(system, RotorForm):
            raise TypeError("`system` is in rotor form already.")
        shape = system.fields.get("R")
        if shape is None or len(shape) != 2 or shape[0] != shape[1]:
            raise ValueError(
                f"`system` must carry its orientation as the field 'R' (build it with orientation=True); "
                f"{system!r} has the fields {list(system.fields)}."
            )
        self.system = system
        self.n = n = shape[0]
        self.ga = algebra(n)
        self.group = SpinCover(system.group, n)
        self.fields = {
            ("rotor" if k == "R" else k): ((self.ga.size,) if k == "R" else s) for k, s in system.fields.items()
        }
        self.autonomous = system.autonomous
        self.passive = bool(getattr(system, "orientation_is_passive", False))
        self._standins: dict = {}

    # -- states handed to the system ------------------------------------------------------------
    def with_R(self, y: Mapping) -> dict:
        """The system's state: ``"R"`` computed from the rotor when read."""
        return _WithR(y, self.ga)

    def _moving(self, y: Mapping) -> dict:
        """The state handed to act/infinitesimal_action: a stand-in R when nothing reads it."""
        if not self.passive:
            return _WithR(y, self.ga)
        batch = y["rotor"].shape[:-1]
        standin = self._standins.get(batch)
        if standin is None:  # one read-only identity per batch shape, made once
            standin = self._standins[batch] = np.broadcast_to(np.eye(self.n), batch + (self.n, self.n))
        out = dict(y)
        out["R"] = standin
        return out

    def _back(self, out: Mapping, rotor: np.ndarray) -> State:
        return {k: (rotor if k == "rotor" else out[k]) for k in self.fields}

    def rotation_matrix(self, rotor: np.ndarray) -> np.ndarray:
        """R ∈ SO(n) of rotors ``(..., 2ⁿ)``."""
        return rotor_matrix(self.ga, rotor)

    # -- the LieGroupSystem contract --------------------------------------------------------------
    def generator(self, t, y: State):
        return self.system.generator(t, _WithR(y, self.ga))

    def act(self, g, y: State) -> State:
        base_g, S = g
        out = self.system.act(base_g, self._moving(y))
        return self._back(out, self.ga.product(y["rotor"], S))

    def infinitesimal_action(self, xi, y: State) -> State:
        out = self.system.infinitesimal_action(xi, self._moving(y))
        omega = self.ga.bivector(self.group.rotation_part(xi))
        return self._back(out, self.ga.product(y["rotor"], 0.5 * omega))

    def project(self, y: State) -> State:
        out = self.system.project(self._moving(y))
        return self._back(out, self.ga.normalize(y["rotor"]))

    @property
    def structure(self) -> frozenset[str]:  # type: ignore[override]
        return frozenset({"rotor_form"})

    @property
    def field_kinds(self) -> Mapping[str, str]:  # type: ignore[override]
        kinds = dict(self.system.field_kinds)
        kinds["rotor"] = "rotor"
        return kinds

    @property
    def invariants(self) -> dict[str, Invariant]:
        ga = self.ga
        declared = {}
        for name, inv in self.system.invariants.items():
            if name == "orthogonality":
                continue  # R of a rotor is orthogonal; the rotor's own defect replaces it
            declared[name] = Invariant(lambda t, y, f=inv.function: f(t, _WithR(y, ga)), inv.kind, inv.description)

        def rotor_defect(t, y):
            S = y["rotor"]
            return np.linalg.norm(ga.product(ga.reverse(S), S) - ga.scalar(np.ones(S.shape[:-1])), axis=-1)

        declared["rotor_defect"] = Invariant(rotor_defect, "defect", "‖S̃S − 1‖ (rotor off Spin(n))")
        return declared

    @property
    def outputs(self) -> dict[str, Output]:
        out = dict(super().outputs)  # the fields, the rotor included
        for name, o in self.system.outputs.items():
            if name in self.system.fields:
                continue
            out[name] = Output(lambda t, y, f=o.function: f(t, _WithR(y, self.ga)), o.shape, o.description, o.kind)
        return out

    def compiled(self):
        return None  # the compiled kernels step matrices

    # -- states -------------------------------------------------------------------------------
    def initial_state(self, *, rotor=None, **keywords) -> State:
        """The system's ``initial_state(**keywords)`` with R turned into the rotor of nonnegative
        scalar part, or with the orientation given as ``rotor`` (clifford rotor(s), or
        coefficients ``(..., 2ⁿ)``) instead of ``R``."""
        if rotor is not None:
            if keywords.get("R") is not None:
                raise ValueError("Give the orientation as `R` or as `rotor`, not both.")
            S, _, _ = resolve(rotor, self.n, "rotor")
            self._check_unit(S, "rotor")
            keywords["R"] = rotor_matrix(self.ga, S)
        s = self.system.initial_state(**keywords)
        R = s["R"]
        if rotor is None:
            S = matrix_to_rotor(R, as_multivector=False)
        batch = R.shape[:-2]
        return {k: (np.broadcast_to(S, batch + S.shape[-1:]).copy() if k == "rotor" else s[k]) for k in self.fields}

    def from_matrix_state(self, y: Mapping[str, np.ndarray]) -> State:
        """The rotor form of a state of the system: R replaced by its rotor (nonnegative scalar part)."""
        S = matrix_to_rotor(np.asarray(y["R"], dtype=float), as_multivector=False)
        return {k: (S if k == "rotor" else np.asarray(y[k])) for k in self.fields}

    def _check_unit(self, S: np.ndarray, name: str) -> None:
        ga = self.ga
        defect = np.max(np.abs(ga.product(ga.reverse(S), S) - ga.scalar(np.ones(S.shape[:-1]))), initial=0.0)
        if not defect <= 1e-10:
            raise ValueError(f"`{name}` must be a unit rotor (S̃S = 1); got ‖S̃S − 1‖ = {defect:.3g}.")

    def validate_state(self, y: Mapping[str, np.ndarray], name: str = "y0") -> State:
        out = super().validate_state(y, name)  # keys, shapes, finiteness, one batch shape
        self._check_unit(out["rotor"], f"{name}['rotor']")
        inner = dict(out)
        del inner["rotor"]
        inner["R"] = rotor_matrix(self.ga, out["rotor"])
        checked = self.system.validate_state({k: inner[k] for k in self.system.fields}, name)
        return self._back(checked, out["rotor"])

    def __repr__(self) -> str:
        return f"RotorForm({self.system!r})"


def rotor_form(system: LieGroupSystem) -> RotorForm:
    """:class:`RotorForm` of ``system``."""
    return RotorForm(system)
