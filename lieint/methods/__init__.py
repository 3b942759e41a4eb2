"""Integrators as data: tableaux, RKMK (Lie–Euler included), classical RK, scipy adapter."""

from . import tableaux
from .classical import ClassicalRK
from .lie import COORDINATES, LieMethod
from .registry import get_method, methods
from .scipy_ivp import SCIPY_SOLVERS, ScipyMethod
from .tableau import ButcherTableau

__all__ = [
    "COORDINATES",
    "SCIPY_SOLVERS",
    "ButcherTableau",
    "ClassicalRK",
    "LieMethod",
    "ScipyMethod",
    "get_method",
    "methods",
    "tableaux",
]
