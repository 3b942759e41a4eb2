"""Geometric algebra with ``clifford``: bivectors, rotors on Spin(n), wedge-built torques.

This is the only part of lieint that imports ``clifford`` (about 0.5 s once compiled).
Every function is batched over leading dimensions. Cl(n) is handled for 2 ≤ n ≤ 8: a
multivector has ``2ⁿ`` coefficients and a geometric product costs ``4ⁿ`` multiply-adds per
body (n = 3: 64, n = 6: 4096, n = 8: 65536), so matrices stay the cheaper representation for
large n.
"""

from .algebra import (
    GA,
    algebra,
    bivector_to_skew,
    from_values,
    matrix_to_rotor,
    resolve,
    rotor_to_matrix,
    skew_to_bivector,
    to_values,
)
from .exp import exp
from .rotor_top import RotorEulerTop, Spin
from .torque import torque, wedge_vectors

__all__ = [
    "GA",
    "RotorEulerTop",
    "Spin",
    "algebra",
    "bivector_to_skew",
    "matrix_to_rotor",
    "rotor_to_matrix",
    "skew_to_bivector",
    "to_values",
    "torque",
    "wedge_vectors",
]
