"""The tangent map of the numerical flow: exact derivatives of a method's discrete map.

* :mod:`lieint.tangent.coordinates` — how a perturbation of the state is written (rotations
  on the right, ``R exp(δ̂)``; momenta additively in the dual algebra);
* :mod:`lieint.tangent.flow` — a method stepping the state together with k tangent vectors
  (the complex step), and :func:`tangent_flow`, the Jacobian ``∂y(T)/∂y₀`` of a run.
"""

from .coordinates import TangentChart, chart_of
from .flow import TangentFlow, TangentStepper, step_schedule, tangent_flow

__all__ = [
    "TangentChart",
    "TangentFlow",
    "TangentStepper",
    "chart_of",
    "step_schedule",
    "tangent_flow",
]
