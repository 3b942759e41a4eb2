"""The tangent map of the numerical flow: exact derivatives of a method's discrete map.

* :mod:`lieint.tangent.coordinates` — how a perturbation of the state is written (rotations
  on the right, ``R exp(δ̂)``; momenta additively in the dual algebra);
* :mod:`lieint.tangent.flow` — a method stepping the state together with k tangent vectors
  (the complex step), and :func:`tangent_flow`, the Jacobian ``∂y(T)/∂y₀`` of a run;
* :mod:`lieint.tangent.horizon` — :func:`trust_horizon`, a run's global error estimated by
  local errors (step doubling) carried by the tangent map, and when it exceeds a tolerance;
* :mod:`lieint.tangent.sensitivity` — :func:`sensitivity`, ``∂y(T)/∂θ`` for the system's
  numeric parameters (the complex step through the parameters).
"""

from .coordinates import TangentChart, chart_of
from .flow import TangentFlow, TangentStepper, step_schedule, tangent_flow
from .horizon import TrustHorizon, trust_horizon
from .sensitivity import Sensitivity, sensitivity

__all__ = [
    "Sensitivity",
    "TangentChart",
    "TangentFlow",
    "TangentStepper",
    "TrustHorizon",
    "chart_of",
    "sensitivity",
    "step_schedule",
    "tangent_flow",
    "trust_horizon",
]
