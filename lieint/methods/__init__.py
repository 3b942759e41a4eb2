"""Integrators as data: the stepper contract, tableaux, RKMK (Lie–Euler included), classical RK,
the scipy adapter, and the registry of method names.

Every module here registers its methods when imported; :func:`method_names` lists them and
:func:`get_method` builds one by name.
"""

from . import tableaux
from .base import Method, MethodSpec, StepResult
from .classical import ClassicalRK
from .registry import AUTO, get_method, method_names, method_specs, register
from .rkmk import COORDINATES, RKMK
from .scipy_ivp import SCIPY_SOLVERS, ScipyMethod
from .tableau import ButcherTableau, EmbeddedPair

__all__ = [
    "AUTO",
    "COORDINATES",
    "RKMK",
    "SCIPY_SOLVERS",
    "ButcherTableau",
    "ClassicalRK",
    "EmbeddedPair",
    "Method",
    "MethodSpec",
    "ScipyMethod",
    "StepResult",
    "get_method",
    "method_names",
    "method_specs",
    "register",
    "tableaux",
]
