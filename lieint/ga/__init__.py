"""Geometric algebra with ``clifford``: bivectors, rotors on Spin(n), wedge-built torques,
the rotor form of every rigid body, results as multivectors, and rigid bodies as PGA motors.

This is the only part of lieint that imports ``clifford`` (about 0.5 s once compiled);
``import lieint`` does not import it. Every function is batched over leading dimensions.
Cl(n) is handled for 2 ≤ n ≤ 8: a multivector has ``2ⁿ`` coefficients and a geometric
product costs ``4ⁿ`` multiply-adds per body (n = 3: 64, n = 6: 4096, n = 8: 65536), so
matrices stay the cheaper representation for large n.
"""

from . import _clifford  # noqa: F401 (first: a missing clifford is reported with the extra that installs it)
from .algebra import (
    GA,
    algebra,
    bivector_to_skew,
    from_values,
    resolve,
    rotor_to_matrix,
    skew_to_bivector,
    to_values,
)
from .exponential import exp, matrix_to_rotor
from .motor import MotorGroup, MotorRigidBody
from .results import as_multivectors, read_multivectors
from .rotor_top import RotorEulerTop, Spin
from .spin import RotorForm, SpinCover, rotor_form
from .torque import torque, wedge_vectors

__all__ = [
    "GA",
    "MotorGroup",
    "MotorRigidBody",
    "RotorEulerTop",
    "RotorForm",
    "Spin",
    "SpinCover",
    "algebra",
    "as_multivectors",
    "bivector_to_skew",
    "exp",
    "from_values",
    "matrix_to_rotor",
    "read_multivectors",
    "resolve",
    "rotor_form",
    "rotor_to_matrix",
    "skew_to_bivector",
    "to_values",
    "torque",
    "wedge_vectors",
]
