"""Mechanical systems: a state, a group action on it, a generator, invariants."""

from .base import LieGroupSystem, State
from .chaplygin import ChaplyginBall
from .euler_top import EulerTop
from .euler_top_exact import euler_top_angular_velocity
from .free_body import FreeBody
from .heavy_top import HeavyTop
from .mass import check_mass_tensor
from .prescribed import PrescribedRotation
from .rolling_ball import RollingBall

__all__ = [
    "ChaplyginBall",
    "EulerTop",
    "FreeBody",
    "HeavyTop",
    "LieGroupSystem",
    "PrescribedRotation",
    "RollingBall",
    "State",
    "check_mass_tensor",
    "euler_top_angular_velocity",
]
