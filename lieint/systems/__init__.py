"""Mechanical systems: a state, a group action on it, a generator, invariants."""

from .atoms import AtomsBody
from .base import LieGroupSystem, State
from .chaplygin import ChaplyginBall
from .euler_top import EulerTop
from .euler_top_exact import euler_top_angular_velocity
from .free_body import FreeBody
from .heavy_top import HeavyTop
from .mass import check_mass_tensor
from .particles import CentralForceParticle, ConstantForceParticle, RadialPotential, SurfaceParticle
from .prescribed import PrescribedRotation
from .rolling_ball import RollingBall
from .surfaces import Ellipsoid, Sphere, Surface, SurfaceOfRevolution

__all__ = [
    "AtomsBody",
    "CentralForceParticle",
    "ChaplyginBall",
    "ConstantForceParticle",
    "Ellipsoid",
    "EulerTop",
    "FreeBody",
    "HeavyTop",
    "LieGroupSystem",
    "PrescribedRotation",
    "RadialPotential",
    "RollingBall",
    "Sphere",
    "State",
    "Surface",
    "SurfaceOfRevolution",
    "SurfaceParticle",
    "check_mass_tensor",
    "euler_top_angular_velocity",
]
