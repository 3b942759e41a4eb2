"""The library of explicit Runge–Kutta tableaux and embedded pairs (data only).

Each entry states its order and stage count; :class:`ButcherTableau` and :class:`EmbeddedPair`
check the order conditions when the module is imported, so a typo here fails loudly. The pairs
carry their first-same-as-last (FSAL) stage as an extra row (node 1, row = the weights).
"""

from __future__ import annotations

from fractions import Fraction as F

from . import dop853
from .tableau import ButcherTableau, EmbeddedPair

__all__ = [
    "BOGACKI_SHAMPINE32",
    "BUTCHER6",
    "DORMAND_PRINCE54",
    "DORMAND_PRINCE853",
    "EULER",
    "HEUN",
    "KUTTA3",
    "PAIRS",
    "RK4",
    "TABLEAUX",
]


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


def _fsal_pair(
    name: str, A, b, c, b_hat, order: int, embedded_order: int, b_hat_low=None, low_order=None
) -> EmbeddedPair:
    """Append the FSAL stage (row = b, node 1) to an s-stage tableau and pair it with b̂ (and b̂₃)."""
    A = [list(map(float, row)) for row in A]
    s = len(b)
    rows = [row + [0.0] * (s + 1 - len(row)) for row in A] + [list(map(float, b)) + [0.0]]
    tab = ButcherTableau(name, A=rows, b=[*map(float, b), 0.0], c=[*map(float, c), 1.0], order=order)
    low = None if b_hat_low is None else [*map(float, b_hat_low)]
    return EmbeddedPair(tab, [*map(float, b_hat)], embedded_order, low, low_order)


#: Bogacki & Shampine's 3(2) pair (Appl. Math. Lett. 2 (1989) 321–325): 3 stages + FSAL.
BOGACKI_SHAMPINE32 = _fsal_pair(
    "Bogacki-Shampine 3(2)",
    A=[[0, 0, 0], [F(1, 2), 0, 0], [0, F(3, 4), 0]],
    b=[F(2, 9), F(1, 3), F(4, 9)],
    c=[0, F(1, 2), F(3, 4)],
    b_hat=[F(7, 24), F(1, 4), F(1, 3), F(1, 8)],
    order=3,
    embedded_order=2,
)

#: Dormand & Prince's 5(4) pair (J. Comput. Appl. Math. 6 (1980) 19–26): 6 stages + FSAL.
DORMAND_PRINCE54 = _fsal_pair(
    "Dormand-Prince 5(4)",
    A=[
        [0, 0, 0, 0, 0, 0],
        [F(1, 5), 0, 0, 0, 0, 0],
        [F(3, 40), F(9, 40), 0, 0, 0, 0],
        [F(44, 45), F(-56, 15), F(32, 9), 0, 0, 0],
        [F(19372, 6561), F(-25360, 2187), F(64448, 6561), F(-212, 729), 0, 0],
        [F(9017, 3168), F(-355, 33), F(46732, 5247), F(49, 176), F(-5103, 18656), 0],
    ],
    b=[F(35, 384), 0, F(500, 1113), F(125, 192), F(-2187, 6784), F(11, 84)],
    c=[0, F(1, 5), F(3, 10), F(4, 5), F(8, 9), 1],
    b_hat=[F(5179, 57600), 0, F(7571, 16695), F(393, 640), F(-92097, 339200), F(187, 2100), F(1, 40)],
    order=5,
    embedded_order=4,
)


def _dop853() -> EmbeddedPair:
    s = dop853.STAGES
    A = [[dop853.A_ROWS.get(i, {}).get(j, 0.0) for j in range(s)] for i in range(s)]
    b = [dop853.A_ROWS[s].get(j, 0.0) for j in range(s)]
    b_hat = [b[j] + dop853.E5.get(j, 0.0) for j in range(s)] + [0.0]
    b3 = [dop853.B3_HAT.get(j, 0.0) for j in range(s)] + [0.0]
    return _fsal_pair("Dormand-Prince 8(5)", A, b, dop853.C[:s], b_hat, 8, 5, b_hat_low=b3, low_order=3)


#: Dormand & Prince's 8(5,3) pair of DOP853 (Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.10):
#: 12 stages + FSAL, with the 5th- and 3rd-order estimators combined as DOP853 does.
DORMAND_PRINCE853 = _dop853()

#: name → embedded pair, for tests that run over every pair.
PAIRS = {p.tableau.name: p for p in (BOGACKI_SHAMPINE32, DORMAND_PRINCE54, DORMAND_PRINCE853)}
