"""Mechanical systems: a state, a group action on it, a generator, invariants."""

from .base import LieGroupSystem, State
from .euler_top import EulerTop, check_mass_tensor
from .euler_top_exact import euler_top_angular_velocity

__all__ = ["EulerTop", "LieGroupSystem", "State", "check_mass_tensor", "euler_top_angular_velocity"]
