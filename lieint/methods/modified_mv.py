"""Moser–Veselov with modified moments of inertia: orders 4 … 10 at the cost of one MV step (n = 3).

The discrete Moser–Veselov map of the 3D top lies on the exact invariant tori; its error is a
reparametrisation that depends only on the invariants. McLachlan & Zanna (2005) and Hairer &
Vilmart (2006) remove it order by order: one MV step with the *modified* principal moments

    1/Ĩ_k = S/I_k + D,   S = 1 + Σ s_{ij} xⁱ yʲ,   D = Σ d_{ij} xⁱ yʲ   (i + j ≥ 1),
    x = h² |Π|²/2,   y = h² H = h² Σ Π_k²/(2 I_k),

is a method of order 2q + 2 when the series are kept to degree q (Hairer & Vilmart's DMV2r,
r = q + 1). The coefficients are rational functions of the moments (Hairer & Vilmart 2006,
J. Phys. A 39, 13225–13235: backward error analysis of the MV map, whose modified equation is
the rigid body's up to a change of time and a rotation about Π, both functions of H and
``|Π|``; the degrees 1 … 4 as published with the authors' DMV10 code), listed in
:func:`modified_coefficients`. They are checked here independently of that code: the local
error of each degree, in 50-digit arithmetic against the Taylor series of the exact flow, falls
like ``h^{2q+3}`` in both the momentum and the attitude for five ratios ``y/x`` — as many as
the five coefficients of degree 4 in each series (``tests/methods/test_modified_mv.py``).

What the step keeps. Since x and y depend only on ``|Π|`` and H, and one MV step with
constant moments Ĩ keeps ``|Π|`` and ``H̃ = S·H + D·|Π|²/2`` — hence H — the modified moments
are the same at every step: the method keeps the energy, the Casimir ``|Π|``, the space
momentum ``RΠ`` (the step is the group action ``(A, R) ↦ (ωᵀAω, Rω)``), R on SO(3), and it is
symmetric. Its momentum map ``Π ↦ Π₁`` is a Poisson map. It is **not symplectic** for the
full system (Π, R) (Hairer & Vilmart 2006, Table 2 and Theorem 4.3): each state is moved by the
MV map of a body that depends on the state (through H and ``|Π|``), which is no longer the map
of one discrete Lagrangian. The defect ``MᵀJM − J`` of its Jacobian M in canonical coordinates
is about the size of its local error (body (0.6, 0.8, 1), h = 0.3: 2.9e-3 at order 4, 4.3e-8
at order 10; ``tests/methods/test_modified_mv.py``). Only plain ``moser_veselov`` (S = 1, D = 0) is
symplectic.

In lieint's conventions (``A = −(BΩ + ΩB)``, the right action) the step is the
``moser_veselov`` step with the mass tensor ``B̃ = P diag(b̃) Pᵀ``, ``b̃_i = (Ĩ_j + Ĩ_k − Ĩ_i)/2``,
in the principal frame P of the body; it is solved in the principal frame, for a whole batch at
once (each member with its own b̃).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

from ..groups.bivectors import hat, vee
from .base import Method, MethodSpec, StepResult
from .moser_veselov import act_near_identity, require_free_top, solve_generator
from .registry import register

__all__ = ["ModifiedMoserVeselov", "modified_coefficients", "modified_moments"]

#: the orders offered: degree q = (order − 2)/2 of the series, 1 … 4
ORDERS = (4, 6, 8, 10)


def modified_coefficients(moments) -> tuple[list[list], list[list]]:
    """The coefficients ``s``, ``d`` of the modified moments, by degree 1 … 4 of the series.

    Entry ``[q − 1][j]`` multiplies ``x^{q−j} y^j``, ``x = h²|Π|²/2``, ``y = h²H``. Degree q
    raises the order to ``2q + 2``.

    Parameters
    ----------
    moments : sequence of three numbers
        The principal moments ``I₁, I₂, I₃``. Floats (numpy scalars too) give floats; the
        formulas are plain arithmetic, so ``fractions.Fraction`` gives exact rationals and
        ``mpmath.mpf`` extended precision.

    Returns
    -------
    s, d : list of lists
        ``s[q − 1]``, ``d[q − 1]``: the q + 1 coefficients of degree q.
    """
    I1, I2, I3 = (float(v) if isinstance(v, (int, np.floating, np.integer)) else v for v in moments)
    det = I1 * I2 * I3
    i1 = 1 / I1 + 1 / I2 + 1 / I3
    i2 = 1 / I1**2 + 1 / I2**2 + 1 / I3**2
    i3 = 1 / I1**3 + 1 / I2**3 + 1 / I3**3
    i4 = 1 / I1**4 + 1 / I2**4 + 1 / I3**4
    s1, s2, s3, s4 = (I1**p + I2**p + I3**p for p in (1, 2, 3, 4))

    def pair(a, b):
        return (I1**a + I2**a) / I3**b + (I2**a + I3**a) / I1**b + (I3**a + I1**a) / I2**b

    si, si12, si21, si13, si31, si22 = pair(1, 1), pair(1, 2), pair(2, 1), pair(1, 3), pair(3, 1), pair(2, 2)
    s = [
        [s1 / (6 * det), -i1 / 3],
        [(s2 / det - i1) / (30 * det), (1 - si) / (30 * det), (3 * s1 / det + 2 * i2) / 60],
        [
            (4 * det + 17 * s3 - 15 * det * si) / (2520 * det**3),
            (9 * s1 + 10 * det * i2 - 6 * si21) / (420 * det**2),
            ((6 * si12 - 100 * i1) * det + 53 * s2) / (2520 * det**2),
            (15 - det * i3 - 2 * si) / (630 * det),
        ],
        [
            (62 * s4 - 94 * det * si21 + 66 * det**2 * i2 + 81 * det * s1) / (45360 * det**4),
            (-77 * si31 + 75 * det * si12 + 214 * s2 - 240 * det * i1) / (22680 * det**3),
            (26 * det * si22 + 55 * s3 + 204 * det - 50 * det**2 * i3 - 59 * det * si) / (7560 * det**3),
            (137 * det * i2 - det * si13 + 3 * s1 - 69 * si21) / (11340 * det**2),
            (2 * det**2 * i4 + 5 * det * si12 - 171 * det * i1 + 159 * s2) / (45360 * det**2),
        ],
    ]
    d = [
        [-1 / (3 * det), s1 / (6 * det)],
        [-s1 / det**2 / 60, i1 / det / 10 - s2 / det**2 / 60, -(9 + si) / det / 60],
        [
            (34 * det * i1 - 19 * s2) / (2520 * det**3),
            (s3 + 2 * det * si - 85 * det) / (1260 * det**3),
            (47 * s1 + 13 * si21 - 38 * det * i2) / (2520 * det**2),
            (9 * det * i1 + det * si12 - 11 * s2) / (1260 * det**2),
        ],
        [
            (60 * si * det - 61 * s3 - 247 * det) / (45360 * det**4),
            (54 * det * s1 - s4 + 218 * det * si21 - 426 * det**2 * i2) / (45360 * det**4),
            (125 * det * i1 - 5 * si31 - 130 * s2 + 4 * det * si12) / (7560 * det**3),
            (67 * s3 - 735 * det - 15 * det * si22 + 87 * det * si + 34 * det**2 * i3) / (22680 * det**3),
            (165 * s1 - det * si13 - 9 * si21 - 145 * det * i2) / (45360 * det**2),
        ],
    ]
    return s, d


def modified_moments(moments, Pi: np.ndarray, h: float, degree: int) -> np.ndarray:
    """The modified principal moments ``Ĩ`` for body momenta Π (principal frame).

    Parameters
    ----------
    moments : array_like, shape (3,)
        The principal moments I.
    Pi : ndarray, shape (..., 3)
        Body angular momenta in the principal frame (any batch shape).
    h : float
        The step.
    degree : int
        The degree q of the series (1 … 4: order 2q + 2).

    Returns
    -------
    ndarray, shape (..., 3)
    """
    I = np.asarray(moments, dtype=float)
    Pi = np.asarray(Pi, dtype=float)
    x = 0.5 * h * h * np.sum(Pi * Pi, axis=-1)
    y = 0.5 * h * h * np.sum(Pi * Pi / I, axis=-1)
    s, d = modified_coefficients(I)
    S, D = np.ones_like(x), np.zeros_like(x)
    for q in range(degree):
        powers = [x ** (q + 1 - j) * y**j for j in range(q + 2)]
        S = S + sum(c * p for c, p in zip(s[q], powers, strict=True))
        D = D + sum(c * p for c, p in zip(d[q], powers, strict=True))
    return 1.0 / (S[..., None] / I + D[..., None])


@dataclass(frozen=True)
class ModifiedMoserVeselov(Method):
    """Moser–Veselov with modified moments of inertia (see the module docstring): order 4 … 10.

    Hairer & Vilmart's DMV2r, r = order/2: symmetric; keeps energy, ``|Π|``, space momentum and
    R on SO(3); Poisson for the momentum, **not symplectic** for (Π, R).

    Examples
    --------
    >>> import lieint
    >>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    >>> y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    >>> sol = lieint.integrate(top, y0, (0.0, 5.0), h=0.05, method="moser_veselov6")
    >>> bool(abs(sol.states["A"][-1] - top.exact_solution([5.0], y0)["A"][-1]).max() < 1e-9)
    True
    """

    name: str
    order: int

    group_action = True

    def __post_init__(self):
        if self.order not in ORDERS:
            raise ValueError(
                f"`order` of the modified Moser–Veselov method must be one of {ORDERS}; got {self.order!r}."
            )

    def check_system(self, system) -> None:
        require_free_top(self.name, system)
        if system.inertia.n != 3:
            raise ValueError(
                f"`method` {self.name!r} (modified moments of inertia) needs a 3D top; got n = {system.inertia.n}; "
                "moser_veselov_composed4/6 raise the order in any n."
            )

    def step(self, system, t: float, y: dict, h: float, state=None) -> StepResult:
        inertia = system.inertia
        P, moments = inertia.P, inertia.principal_moments
        A = y["A"]
        # the principal frame: Ã = PᵀAP = −Π̂, where the modified mass tensor is diagonal
        At = A if inertia.diagonal else np.swapaxes(P, -1, -2) @ A @ P
        Pi = -vee(At)
        Im = modified_moments(moments, Pi, h, (self.order - 2) // 2)  # (..., 3), one body per member
        b = 0.5 * (np.sum(Im, axis=-1, keepdims=True) - 2.0 * Im)
        B = b[..., :, None] * np.eye(3)  # (..., 3, 3) diagonal
        # the first-order guess X₀ = hΩ̃, Ω̃ = Ĩ⁻¹-weighted: ŵ with w = Π/Ĩ (A = −Π̂, Ω = ŵ)
        X0 = hat(h * Pi / Im)
        # the step from K = ω − I, as moser_veselov: keeps the energy error a random walk
        K, iterations = solve_generator(B, At, h, X0)
        if not inertia.diagonal:
            K = P @ K @ P.T
        return StepResult(act_near_identity(system, K, y), None, iterations, None)


def _build(order: int, coordinates: str | None = None) -> ModifiedMoserVeselov:
    return ModifiedMoserVeselov(f"moser_veselov{order}", order)


for _order in ORDERS:
    register(
        MethodSpec(
            f"moser_veselov{_order}",
            "moser-veselov",
            _order,
            partial(_build, _order),
            description=(
                f"Moser–Veselov with modified moments of inertia (n = 3; Hairer–Vilmart DMV{_order}), order {_order} "
                "at the cost of MV: keeps energy and |Π|, Poisson for Π, not symplectic"
            ),
        )
    )
