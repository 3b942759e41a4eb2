"""lieint — structure-preserving integrators for rigid bodies in any dimension.

Configurations live on SO(n) and SE(n); angular velocities and momenta are bivectors
(skew matrices). Lie-group methods (Lie–Euler, Runge–Kutta–Munthe-Kaas) step the body-frame
equations while keeping the invariants of the group action to round-off.

>>> import lieint
>>> top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
>>> y0 = top.initial_state(angular_velocity=[0.01, 1.0, 0.01])
>>> sol = lieint.integrate(top, y0, t_span=(0.0, 10.0), h=0.01, method="rkmk4", project=True)
>>> sol.states["A"].shape
(1001, 3, 3)
"""

from .groups import SE, SO, DexpinvRangeError
from .integrate import LieStepWarning, integrate
from .methods import ButcherTableau, ClassicalRK, LieMethod, ScipyMethod, get_method, methods
from .runs import run
from .solution import Solution
from .systems import ChaplyginBall, EulerTop, FreeBody, HeavyTop, LieGroupSystem, RollingBall

__version__ = "0.1.0"

__all__ = [
    "SE",
    "SO",
    "ButcherTableau",
    "ChaplyginBall",
    "ClassicalRK",
    "DexpinvRangeError",
    "EulerTop",
    "FreeBody",
    "HeavyTop",
    "LieGroupSystem",
    "LieMethod",
    "LieStepWarning",
    "RollingBall",
    "ScipyMethod",
    "Solution",
    "__version__",
    "get_method",
    "integrate",
    "methods",
    "run",
]
