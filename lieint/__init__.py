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

Layers (each imports only from those above it): ``groups`` (SO(n), SE(n), products) →
``methods`` (the stepper contract, tableaux, RKMK, RK, scipy, the registry) and ``systems``
(the system contract and the bodies) → ``control`` and ``driver`` (grids, step-size control,
the one driving loop, :class:`Solution`) → front ends (``ivp.integrate``, ``scenes``, ``runs``,
``study``, ``cli``).
"""

from . import analysis, rotations, tangent
from ._version import __version__
from .analysis.chaos import lyapunov, megno
from .analysis.sections import poincare
from .driver import Stats
from .groups import SE, SO, DexpinvRangeError
from .ivp import LieStepWarning, integrate
from .methods import get_method, method_names
from .runs import run
from .solution import Solution
from .sweeps import sweep
from .systems import ChaplyginBall, EulerTop, FreeBody, HeavyTop, LieGroupSystem, RollingBall
from .systems.atoms import AtomsBody
from .systems.euler_top_exact import euler_top_flip_times
from .systems.particles import CentralForceParticle, ConstantForceParticle, SurfaceParticle
from .systems.prescribed import PrescribedRotation
from .tangent import sensitivity, tangent_flow, trust_horizon

__all__ = [
    "SE",
    "SO",
    "AtomsBody",
    "CentralForceParticle",
    "ChaplyginBall",
    "ConstantForceParticle",
    "DexpinvRangeError",
    "EulerTop",
    "FreeBody",
    "HeavyTop",
    "LieGroupSystem",
    "LieStepWarning",
    "PrescribedRotation",
    "RollingBall",
    "Solution",
    "Stats",
    "SurfaceParticle",
    "__version__",
    "analysis",
    "euler_top_flip_times",
    "get_method",
    "integrate",
    "lyapunov",
    "megno",
    "method_names",
    "poincare",
    "rotations",
    "run",
    "sensitivity",
    "sweep",
    "tangent",
    "tangent_flow",
    "trust_horizon",
]
