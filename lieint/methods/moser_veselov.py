"""The discrete Moser–Veselov top in any dimension n (Moser & Veselov 1991; docs/theory.md §11).

The discrete Lagrangian ``L(R_k, R_{k+1}) = −(1/h) tr(R_k B R_{k+1}ᵀ)`` (the kinetic energy
``½ tr(Ṙ B Ṙᵀ)`` with ``Ṙ ≈ (R_{k+1} − R_k)/h``) gives, for the body increment
``ω_k = R_kᵀ R_{k+1} ∈ SO(n)``::

    h A_k = B ω_kᵀ − ω_k B,                  (solved for ω_k near I + hΩ_k)
    A_{k+1} = ω_kᵀ A_k ω_k,   R_{k+1} = R_k ω_k.

The map is symplectic, integrable, and keeps the energy, the Casimirs (spectrum of A), the
space momentum and the Manakov integrals ``tr((A − λB²)^k)`` of the *continuous* top: its orbit
lies on the exact invariant tori, a reparametrisation of the exact flow. It has order 2.

The implicit equation is solved by Newton's method on the Cayley parameter ``ω = cay(X)``,
``X ∈ so(n)``, with the exact Jacobian ``d cay_X(δ) = ½ (I − X/2)⁻¹ δ (I + cay(X))`` in
bivector coordinates (a ``d × d`` system, ``d = n(n − 1)/2``), from the first-order guess
``X₀ = hΩ(A_k)``. The iteration stops when the Newton update is below round-off
(``‖δX‖ ≤ 4ε‖X‖``) or stops decreasing once below ``1e-10‖X‖``; it converges quadratically
(3 iterations for ``h‖Ω‖ ≈ 0.05``) and raises ``RuntimeError`` when the residual is not at
round-off after 40.

Round-off. The step is computed from ``K = ω − I = cay(X) − I = (I − X/2)⁻¹ X`` and never
forms ``ω`` itself: the equation is ``h A_k = B Kᵀ − K B`` and the update
``A_{k+1} = A_k + (P − Pᵀ + Kᵀ P)``, ``P = A_k K``, ``R_{k+1} = R_k + R_k K``
(:meth:`lieint.EulerTop.act_near_identity`). Rounding ``ω``'s diagonal ``1 − O(h²)`` to
doubles costs an error of ε/2 in it, and the step keeps some combinations of that diagonal
exactly (``tr(Bω)``; for a flat body, ``b₃ = 0``, the entry ``ω₃₃`` itself): their rounding
error is then the same at every step, a non-orthogonality of ω of fixed sign over hundreds
of steps that moves the energy by up to 1e-16 a step in one direction. ``K`` carries its
small diagonal to relative precision, so its defect ``K + Kᵀ + KᵀK`` is of order ε‖K‖
and the energy error is a random walk (3D top with moments 1, 2, 3, h = 0.05: the energy
error from the defect falls from 2e-16 to 3e-18 a step, its persistent part from 3e-17 to
1e-19).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache, partial

import numpy as np

from .base import Method, MethodSpec, StepResult
from .registry import AUTO, register

__all__ = [
    "MoserVeselov",
    "MoserVeselovComposition",
    "act_near_identity",
    "moser_veselov_generator",
    "moser_veselov_increment",
    "require_free_top",
    "solve_generator",
]

_EPS = np.finfo(float).eps
_MAX_NEWTON = 40


def require_free_top(method_name: str, system) -> None:
    """Raise ``ValueError`` naming the method unless ``system`` is a free top (structure ``free_top``)."""
    if "free_top" not in getattr(system, "structure", frozenset()) or not hasattr(system, "inertia"):
        raise ValueError(
            f"`method` {method_name!r} applies to the free rigid body (a system with structure 'free_top', "
            f"e.g. lieint.EulerTop); got {type(system).__name__} with structure "
            f"{sorted(getattr(system, 'structure', ()))}."
        )


def _cay_minus_identity(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``K = cay(X) − I = (I − X/2)⁻¹ X`` and ``W = (I − X/2)⁻¹``.

    ``cay(X) − I = W(I + X/2) − W(I − X/2) = W X``: computed so, K's small entries keep their
    relative precision (``cay(X)`` itself would round its diagonal ``1 − O(‖X‖²)`` to ε/2).
    """
    W = np.linalg.inv(np.eye(X.shape[-1]) - 0.5 * X)
    return W @ X, W


@cache
def _pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs ``i < j`` (row-major, as :func:`lieint.groups.bivectors.bivector_coordinates`)."""
    return np.triu_indices(n, k=1)


def _coords(X: np.ndarray) -> np.ndarray:
    i, j = _pairs(X.shape[-1])
    return X[..., i, j]


def _skew(c: np.ndarray, n: int) -> np.ndarray:
    i, j = _pairs(n)
    out = np.zeros(c.shape[:-1] + (n, n), dtype=c.dtype)  # complex kept (lieint.tangent)
    out[..., i, j] = c
    out[..., j, i] = -c
    return out


@cache
def _basis(n: int) -> np.ndarray:
    """The basis ``e_i ∧ e_j`` (i < j) of so(n) in coordinate order."""
    return _skew(np.eye(n * (n - 1) // 2), n)


def moser_veselov_increment(inertia, A: np.ndarray, h: float) -> tuple[np.ndarray, int]:
    """Solve ``h A = B ωᵀ − ω B`` for ``ω ∈ SO(n)`` near ``I + hΩ(A)`` (batched over A's leading axes).

    Parameters
    ----------
    inertia : InertiaOperator
        The body's mass tensor B and inertia operator (:class:`lieint.systems.rigid.InertiaOperator`).
    A : ndarray, shape (..., n, n)
        Body angular momentum bivectors.
    h : float
        The step.

    Returns
    -------
    omega : ndarray, shape (..., n, n)
        The body increment ``I + K`` (:func:`moser_veselov_generator`), orthogonal to round-off.
    iterations : int
        Newton iterations spent.
    """
    K, iterations = moser_veselov_generator(inertia, A, h)
    return np.eye(A.shape[-1]) + K, iterations


def moser_veselov_generator(inertia, A: np.ndarray, h: float) -> tuple[np.ndarray, int]:
    """``K = ω − I`` for the increment ω of :func:`moser_veselov_increment`, without forming ω.

    Solves ``h A = B Kᵀ − K B`` (the Moser–Veselov equation, since ``B Iᵀ − I B = 0``) for
    ``K = cay(X) − I = (I − X/2)⁻¹ X``. Applying the step from K
    (:meth:`lieint.EulerTop.act_near_identity`) keeps K's diagonal, of order ``h²‖Ω‖²``, to
    relative precision; rounding ``I + K`` would make an error of ε/2 in ω's diagonal that
    repeats from step to step (see the module docstring) and biases the energy.

    Parameters
    ----------
    inertia : InertiaOperator
        The body's mass tensor B and inertia operator.
    A : ndarray, shape (..., n, n)
        Body angular momentum bivectors.
    h : float
        The step.

    Returns
    -------
    K : ndarray, shape (..., n, n)
        ``ω − I``; ``K + Kᵀ + KᵀK = 0`` to round-off of ‖K‖.
    iterations : int
        Newton iterations spent.
    """
    return solve_generator(inertia.B, A, h, h * inertia.angular_velocity(A))


def solve_generator(B: np.ndarray, A: np.ndarray, h: float, X0: np.ndarray) -> tuple[np.ndarray, int]:
    """Newton's method for ``h A = B Kᵀ − K B``, ``K = cay(X) − I``, from the guess ``X = X0``.

    The core of :func:`moser_veselov_generator`, with the mass tensor given as an array so that
    it may differ from member to member of a batch (the modified moments of
    :mod:`lieint.methods.modified_mv` depend on each member's invariants).

    Parameters
    ----------
    B : ndarray, shape (n, n) or (..., n, n)
        Mass tensors, broadcasting against A's leading axes.
    A : ndarray, shape (..., n, n)
        Body angular momentum bivectors.
    h : float
        The step.
    X0 : ndarray, shape (..., n, n)
        The first guess of the Cayley parameter (``hΩ(A)``: first order in h).

    Returns
    -------
    K : ndarray, shape (..., n, n)
        ``ω − I``.
    iterations : int
        Newton iterations spent (the batch's members share them).
    """
    n = A.shape[-1]
    B_stages = B[..., None, :, :]  # against the d basis directions of the Jacobian
    E = _basis(n)  # (d, n, n)
    eye = np.eye(n)
    rhs = h * A
    X = X0
    scale = max(float(np.max(np.abs(rhs))), np.finfo(float).tiny)
    last = np.inf
    it = 0
    residual = np.inf
    with np.errstate(all="ignore"):  # a diverging iteration is reported below, not as warnings
        try:
            while it < _MAX_NEWTON:
                it += 1
                K, W = _cay_minus_identity(X)
                F = B @ np.swapaxes(K, -1, -2) - K @ B - rhs
                # d cay_X(E_k) = ½ W E_k (I + cay X) = ½ W E_k (2I + K); dF = B dωᵀ − dω B
                domega = 0.5 * W[..., None, :, :] @ E @ (2.0 * eye + K)[..., None, :, :]
                dF = B_stages @ np.swapaxes(domega, -1, -2) - domega @ B_stages  # (..., d, n, n)
                J = np.swapaxes(_coords(dF), -1, -2)  # (..., d, d): column k = dF(E_k)
                delta = np.linalg.solve(J, -_coords(F)[..., None])[..., 0]
                X = X + _skew(delta, n)
                size = float(np.max(np.abs(delta)))
                if not np.isfinite(size):
                    break
                xsize = max(float(np.max(np.abs(X))), np.finfo(float).tiny)
                # converged: the update is round-off, or it stopped shrinking near round-off
                if size <= 4.0 * _EPS * xsize or (size >= last and size <= 1e-10 * xsize):
                    break
                last = size
            K, _ = _cay_minus_identity(X)
            residual = float(np.max(np.abs(B @ np.swapaxes(K, -1, -2) - K @ B - rhs)))
        except np.linalg.LinAlgError:
            pass
    if not residual <= 1e3 * _EPS * max(scale, float(np.max(np.abs(B)))):
        raise RuntimeError(
            f"Moser–Veselov step h = {h:g}: Newton did not reach round-off after {it} iterations "
            f"(residual {residual:.3g}); take a smaller `h`."
        )
    return K, it


def act_near_identity(system, K: np.ndarray, y: dict) -> dict:
    """The state moved by the increment ``I + K``: ``system.act_near_identity`` when it has one."""
    move = getattr(system, "act_near_identity", None)
    if move is not None:
        return move(K, y)
    return system.act(np.eye(K.shape[-1]) + K, y)


@dataclass(frozen=True)
class MoserVeselov(Method):
    """The discrete Moser–Veselov top (see the module docstring): order 2, symplectic, integrable.

    Keeps energy, Casimirs, space momentum and the Manakov integrals of the free top to
    round-off (the step is a group action ``(A, R) ↦ (ωᵀAω, Rω)``), in any n.

    Examples
    --------
    >>> import numpy as np, lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    >>> sol = lieint.integrate(top, y0, (0.0, 10.0), h=0.1, method="moser_veselov")
    >>> bool(np.max(sol.drift("energy")) < 1e-13)
    True
    """

    name: str = "moser_veselov"
    order: int = 2

    group_action = True

    def check_system(self, system) -> None:
        require_free_top(self.name, system)

    def step(self, system, t: float, y: dict, h: float, state=None) -> StepResult:
        K, iterations = moser_veselov_generator(system.inertia, y["A"], h)
        return StepResult(act_near_identity(system, K, y), None, iterations, None)

    def compiled(self):
        """The compiled engine's form: the map with its Newton solve in machine code, for the
        3D top (:mod:`lieint.fast.top3_mv`) and the n-D top (:mod:`lieint.fast.topn_mv`)."""
        return _compiled_map(self, MoserVeselov, (1.0,))


@dataclass(frozen=True)
class MoserVeselovComposition(Method):
    """Moser–Veselov steps composed to order 4 or 6.

    The Moser–Veselov map is symmetric (its step with −h from ``(A_{k+1}, R_{k+1})`` is solved by
    ``ω_kᵀ`` and returns ``(A_k, R_k)``), so the symmetric compositions of
    :func:`~lieint.methods.composition.composition_coefficients` raise its order: ``"yoshida"``
    takes 3 (order 4) and 7 (order 6) Moser–Veselov steps per step. (Order 8 is not offered:
    its 21 substeps reach ``1.1 h`` in size, and the Moser–Veselov equation has no solution
    near the identity once ``h‖Ω‖`` approaches 1 for a flat body.) Each substep is a
    Moser–Veselov step, so everything it keeps — energy, Casimirs, Manakov integrals, space
    momentum, symplecticity — the composition keeps, in any n.

    These are compositions (any n), not the modified-moment Moser–Veselov methods of
    McLachlan & Zanna (2005) and Hairer & Vilmart (2006) (``moser_veselov4/6/8/10``, n = 3),
    which reach the higher orders at the cost of one Moser–Veselov step but, their moments
    depending on the state, are Poisson maps for the momentum and not symplectic for the whole
    state (:mod:`lieint.methods.modified_mv`); the compositions are symplectic.
    """

    name: str
    order: int
    composition: str = "yoshida"

    group_action = True

    def __post_init__(self):
        from .composition import composition_coefficients

        composition_coefficients(self.order, self.composition)

    @property
    def coefficients(self) -> np.ndarray:
        from .composition import composition_coefficients

        return composition_coefficients(self.order, self.composition)

    def check_system(self, system) -> None:
        require_free_top(self.name, system)

    def step(self, system, t: float, y: dict, h: float, state=None) -> StepResult:
        nfev = 0
        for c in self.coefficients:
            K, iterations = moser_veselov_generator(system.inertia, y["A"], c * h)
            y, nfev = act_near_identity(system, K, y), nfev + iterations
        return StepResult(y, None, nfev, None)

    def compiled(self):
        """The compiled engine's form: the composition's Moser–Veselov substeps in machine code,
        for the 3D top (:mod:`lieint.fast.top3_mv`) and the n-D top (:mod:`lieint.fast.topn_mv`)."""
        return _compiled_map(self, MoserVeselovComposition, tuple(float(c) for c in self.coefficients))


#: where the Moser–Veselov maps have compiled stage code: system form (class name) -> the
#: module of the map's stage functions for it (the modified moments: the 3D top only)
COMPILED_MAPS = {"Top3Form": "lieint.fast.top3_mv", "TopNForm": "lieint.fast.topn_mv"}


def _compiled_map(method, cls, substeps, degree: int = 0, coefficients=None):
    """The :class:`~lieint.fast.forms.MapForm` of a Moser–Veselov method that steps as ``cls``
    defines it (a subclass that changes the step integrates something else: None)."""
    if not method.steps_as(cls, ("step", "check_system")):
        return None
    from ..fast.forms import MapForm

    return MapForm("moser_veselov", COMPILED_MAPS, substeps, degree, coefficients)


def _build(coordinates: str | None = None) -> MoserVeselov:
    return MoserVeselov()


def _build_composition(order: int, coordinates: str | None = None, composition=AUTO) -> MoserVeselovComposition:
    composition = "yoshida" if composition is AUTO else composition
    name = f"moser_veselov_composed{order}" + ("" if composition == "yoshida" else f"[{composition}]")
    return MoserVeselovComposition(name, order, composition)


register(
    MethodSpec(
        "moser_veselov",
        "moser-veselov",
        2,
        _build,
        description="discrete Moser–Veselov top (any n): symplectic, keeps energy, Casimirs, Manakov integrals",
    )
)
for _order in (4, 6):
    register(
        MethodSpec(
            f"moser_veselov_composed{_order}",
            "moser-veselov",
            _order,
            partial(_build_composition, _order),
            description=f"Moser–Veselov steps in a symmetric composition of order {_order} (keeps what MV keeps)",
            options=("composition",),
        )
    )
