"""The library of explicit Runge–Kutta tableaux (data only).

Each entry states its order and stage count; :class:`ButcherTableau` checks the order
conditions when the module is imported, so a typo here fails loudly.
"""

from __future__ import annotations

from fractions import Fraction as F

from .tableau import ButcherTableau

__all__ = ["BUTCHER6", "EULER", "HEUN", "KUTTA3", "RK4", "TABLEAUX"]


def _f(rows):
    return [[float(x) for x in row] for row in rows]


#: Forward Euler: 1 stage, order 1 (Lie–Euler as RKMK).
EULER = ButcherTableau("Euler", A=[[0.0]], b=[1.0], c=[0.0], order=1)

#: Heun's method (explicit trapezoidal rule): 2 stages, order 2.
HEUN = ButcherTableau("Heun", A=[[0, 0], [1, 0]], b=[0.5, 0.5], c=[0, 1], order=2)

#: Kutta's third-order method: 3 stages, order 3.
KUTTA3 = ButcherTableau(
    "Kutta 3",
    A=_f([[0, 0, 0], [F(1, 2), 0, 0], [-1, 2, 0]]),
    b=_f([[F(1, 6), F(2, 3), F(1, 6)]])[0],
    c=[0.0, 0.5, 1.0],
    order=3,
)

#: The classical fourth-order Runge–Kutta method: 4 stages, order 4.
RK4 = ButcherTableau(
    "classical RK4",
    A=[[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1, 0]],
    b=_f([[F(1, 6), F(1, 3), F(1, 3), F(1, 6)]])[0],
    c=[0.0, 0.5, 0.5, 1.0],
    order=4,
)

#: Butcher's sixth-order method with 7 stages (Butcher 1964; Hairer–Nørsett–Wanner,
#: *Solving ODEs I*, §II.5, Table 5.2 family).
BUTCHER6 = ButcherTableau(
    "Butcher 6 (7 stages)",
    A=_f(
        [
            [0, 0, 0, 0, 0, 0, 0],
            [F(1, 3), 0, 0, 0, 0, 0, 0],
            [0, F(2, 3), 0, 0, 0, 0, 0],
            [F(1, 12), F(1, 3), F(-1, 12), 0, 0, 0, 0],
            [F(-1, 16), F(9, 8), F(-3, 16), F(-3, 8), 0, 0, 0],
            [0, F(9, 8), F(-3, 8), F(-3, 4), F(1, 2), 0, 0],
            [F(9, 44), F(-9, 11), F(63, 44), F(18, 11), 0, F(-16, 11), 0],
        ]
    ),
    b=_f([[F(11, 120), 0, F(27, 40), F(27, 40), F(-4, 15), F(-4, 15), F(11, 120)]])[0],
    c=_f([[0, F(1, 3), F(2, 3), F(1, 3), F(1, 2), F(1, 2), 1]])[0],
    order=6,
)

#: name → tableau, for tests that run over every tableau.
TABLEAUX = {t.name: t for t in (EULER, HEUN, KUTTA3, RK4, BUTCHER6)}
