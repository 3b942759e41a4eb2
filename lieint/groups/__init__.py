"""Matrix Lie groups SO(n), SE(n) and bivector algebra (batched, any n ≥ 2)."""

from .base import DexpinvRangeError, LieGroup, MatrixLieGroup, bernoulli_dexpinv_coefficients
from .bivectors import (
    bivector_coordinates,
    bivector_dimension,
    commutator,
    from_bivector_coordinates,
    hat,
    inner,
    skew_part,
    vee,
    wedge,
)
from .se import SE, se_join, se_split
from .so import (
    SO,
    dexpinv_so3,
    dexpinv_spectral,
    project_to_so,
    so3_exp,
    so3_log,
    so_ad_spectral_radius,
    so_exp,
    so_log,
    so_norm,
)
from .vector import ProductGroup, VectorSpace

__all__ = [
    "SE",
    "SO",
    "DexpinvRangeError",
    "LieGroup",
    "MatrixLieGroup",
    "ProductGroup",
    "VectorSpace",
    "bernoulli_dexpinv_coefficients",
    "bivector_coordinates",
    "bivector_dimension",
    "commutator",
    "dexpinv_so3",
    "dexpinv_spectral",
    "from_bivector_coordinates",
    "hat",
    "inner",
    "project_to_so",
    "se_join",
    "se_split",
    "skew_part",
    "so3_exp",
    "so3_log",
    "so_ad_spectral_radius",
    "so_exp",
    "so_log",
    "so_norm",
    "vee",
    "wedge",
]
