"""Analyses of a system: counting toward integrability (docs/theory.md §7;
:func:`integrability_count`), the Frobenius test of a velocity constraint (docs/theory.md §9;
:func:`is_holonomic`) and chaos indicators of a motion (docs/theory.md §12; :func:`lyapunov`,
:func:`megno`) and Poincaré sections (:func:`poincare`)."""

from .chaos import LyapunovSpectrum, Megno, lyapunov, megno
from .holonomy import Distribution, HolonomyResult, constraint_of, is_holonomic, rolling_constraint
from .integrability import IntegrabilityCount, PhaseChart, integrability_count, phase_chart
from .numerics import NumericalRank, numerical_rank
from .sections import PoincareSection, poincare

__all__ = [
    "Distribution",
    "HolonomyResult",
    "IntegrabilityCount",
    "LyapunovSpectrum",
    "Megno",
    "NumericalRank",
    "PhaseChart",
    "PoincareSection",
    "constraint_of",
    "integrability_count",
    "is_holonomic",
    "lyapunov",
    "megno",
    "numerical_rank",
    "phase_chart",
    "poincare",
    "rolling_constraint",
]
