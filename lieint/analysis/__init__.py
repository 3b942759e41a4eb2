"""Analyses of a system: counting toward integrability (docs/theory.md §7;
:func:`integrability_count`) and the Frobenius test of a velocity constraint (docs/theory.md §9;
:func:`is_holonomic`)."""

from .holonomy import Distribution, HolonomyResult, constraint_of, is_holonomic, rolling_constraint
from .integrability import IntegrabilityCount, PhaseChart, integrability_count, phase_chart
from .numerics import NumericalRank, numerical_rank

__all__ = [
    "Distribution",
    "HolonomyResult",
    "IntegrabilityCount",
    "NumericalRank",
    "PhaseChart",
    "constraint_of",
    "integrability_count",
    "is_holonomic",
    "numerical_rank",
    "phase_chart",
    "rolling_constraint",
]
