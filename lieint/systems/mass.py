"""Mass tensors and the inertia operator (docs/theory.md §2, §4).

The inertia operator solves the Lyapunov equation ``B X + X B = C`` in the eigenbasis of
the symmetric B: ``X̃_ij = C̃_ij / (b_i + b_j)``. The Euler top precomputes the basis of its
constant B; the rolling balls diagonalise ``B_K(Γ)`` at every evaluation (batched).
"""

from __future__ import annotations

import numpy as np

from .._validation import as_float_array, check_square_trailing, describe

__all__ = [
    "check_inertia_tensor",
    "check_mass_tensor",
    "is_mass_distribution",
    "moments_tensor",
    "solve_lyapunov",
    "solve_lyapunov_sym",
]

# A pair sum b_i + b_j below this fraction of the largest eigenvalue is treated as zero:
# the body is (numerically) a rod and Ω(A) is undefined.
#: range of the largest entry of B in which every derived quantity stays a finite double
_MIN_SCALE, _MAX_SCALE = 1e-100, 1e100
_ROD_TOLERANCE = 1e-13


def check_mass_tensor(B, name: str = "B") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate a body mass tensor ``B = ∫ m X Xᵀ``; return ``(B, b, P)`` with ``B = P diag(b) Pᵀ``.

    B must be a real symmetric positive semi-definite ``(n, n)`` matrix, n ≥ 2, with at most
    one zero eigenvalue (``b_i + b_j > 0`` for i ≠ j): a flat body is fine, a rod is not.
    """
    B, b, P = _symmetric_tensor(B, name)
    if b[0] < -1e-12 * b[-1]:
        hint = ""
        if b[0] + b[1] > _ROD_TOLERANCE * np.max(np.abs(b)):
            hint = (
                " (no mass distribution has it; the free top alone, lieint.EulerTop, takes any B with "
                "b_i + b_j > 0, which its equations need)"
            )
        raise ValueError(
            f"`{name}` must be positive semi-definite (a mass tensor ∫ m X Xᵀ); got eigenvalues {describe(b)}{hint}."
        )
    b = np.maximum(b, 0.0)
    if b[0] + b[1] <= _ROD_TOLERANCE * b[-1]:
        raise ValueError(
            f"`{name}` must be symmetric positive semi-definite with at most one zero eigenvalue; got "
            f"eigenvalues {describe(b)} (a rod: b_i + b_j = 0 for some i != j, so rotation about its "
            "axis is undefined)."
        )
    return B, b, P


def check_inertia_tensor(B, name: str = "B") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate the tensor B of a free top's inertia operator; return ``(B, b, P)``, ``B = P diag(b) Pᵀ``.

    What the free top's equations need: B real symmetric ``(n, n)``, n ≥ 2, with
    ``b_i + b_j > 0`` for every i ≠ j. Then the inertia operator ``Ω ↦ BΩ + ΩB`` is invertible
    and the kinetic energy ``T = ½ Σ_{i<j} (b_i + b_j) Ω_ij²`` is positive definite; for n = 3
    the principal moments ``I_k = b_i + b_j`` are any positive numbers. B need not be positive
    semi-definite (:func:`check_mass_tensor`): when it is not, no mass distribution has it
    (for n = 3: the moments break the triangle inequality ``I_k ≤ I_i + I_j``).
    """
    B, b, P = _symmetric_tensor(B, name)
    if is_mass_distribution(b):
        return check_mass_tensor(B, name)  # the same rules, and the rod's message
    if b[0] + b[1] <= _ROD_TOLERANCE * np.max(np.abs(b)):
        raise ValueError(
            f"`{name}` must have b_i + b_j > 0 for every pair of its eigenvalues b (so that the inertia operator "
            f"Ω ↦ BΩ + ΩB is invertible and the kinetic energy positive); got eigenvalues {describe(b)}, "
            f"b_1 + b_2 = {b[0] + b[1]:.3g}."
        )
    return B, b, P


def is_mass_distribution(b: np.ndarray) -> bool:
    """Whether eigenvalues ``b`` of a tensor B are those of a mass distribution (B ⪰ 0, to 1e-12)."""
    return bool(np.min(b) >= -1e-12 * np.max(np.abs(b)))


def _symmetric_tensor(B, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """B checked to be one finite symmetric ``(n, n)`` matrix, n ≥ 2, in range; ``(B, b, P)``."""
    B = as_float_array(B, name)
    if B.ndim != 2:
        raise ValueError(f"`{name}` must be one (n, n) mass tensor; got shape {B.shape}.")
    n = check_square_trailing(B, name)
    if n < 2:
        raise ValueError(f"`{name}` must be (n, n) with n >= 2; got shape {B.shape}.")
    scale = float(np.max(np.abs(B)))
    if scale == 0.0:
        raise ValueError(f"`{name}` must be a nonzero mass tensor; got the zero matrix.")
    if not _MIN_SCALE <= scale <= _MAX_SCALE:
        # B², b_i + b_j, 1/(b_i + b_j) and the energy must all be finite floating-point numbers
        raise ValueError(
            f"`{name}` must have its largest entry between {_MIN_SCALE:g} and {_MAX_SCALE:g} (so that B², "
            f"1/(b_i + b_j) and the energy stay finite); got max |B| = {scale:.3g}. Rescale the units."
        )
    asym = float(np.max(np.abs(B - B.T)))
    if asym > 1e-12 * scale:
        raise ValueError(
            f"`{name}` must be symmetric (a mass tensor ∫ m X Xᵀ); got max |B - Bᵀ| = {asym:.3g} "
            f"for max |B| = {scale:.3g}."
        )
    B = 0.5 * (B + B.T)
    b, P = np.linalg.eigh(B)
    return B, b, P


def moments_tensor(moments, name: str = "moments", *, mass_distribution: bool = True) -> np.ndarray:
    """``B = diag(b)``, ``b_i = (I_j + I_k − I_i)/2``, of three principal moments of inertia.

    Parameters
    ----------
    moments : array_like, shape (3,)
        Positive principal moments ``I₁, I₂, I₃``.
    name : str
        The argument's name in error messages.
    mass_distribution : bool, default True
        Require the moments of a body, ``I_i ≤ I_j + I_k`` (B ⪰ 0; equality: a flat plate).
        False: any positive moments (what the free top's equations need).

    Returns
    -------
    ndarray, shape (3, 3)
        B (entries within 1e-12 of zero below it are set to zero: a flat plate stays one).
    """
    I = as_float_array(moments, name)
    if I.shape != (3,):
        raise ValueError(f"`{name}` must be three principal moments (shape (3,)); got shape {I.shape}.")
    if np.any(I <= 0):
        raise ValueError(f"`{name}` must be positive; got {describe(I)}.")
    b = (I.sum() - 2.0 * I) / 2.0
    if mass_distribution and np.any(b < -1e-12 * I.max()):
        raise ValueError(
            f"`{name}` must satisfy the triangle inequality I_i <= I_j + I_k of a physical body; got {describe(I)} "
            "(the free top alone, lieint.EulerTop.from_principal_moments, takes any positive moments)."
        )
    return np.diag(np.where(np.abs(b) <= 1e-12 * I.max(), 0.0, b))


def eigh_or_nan(M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.linalg.eigh`` of a stack of symmetric matrices, NaN for the members that are not
    finite (LAPACK would refuse the whole stack: "Eigenvalues did not converge"). A stage state
    turns non-finite when a step is far too large (its Cayley map is then NaN, on purpose); the
    NaN reaches the result, which is reported or, a trial step, rejected."""
    finite = np.isfinite(M).all(axis=(-2, -1))
    if np.all(finite):
        return np.linalg.eigh(M)
    b = np.full(M.shape[:-1], np.nan)
    P = np.full(M.shape, np.nan)
    if np.any(finite):
        b[finite], P[finite] = np.linalg.eigh(M[finite])
    return b, P


def solve_lyapunov_sym(b: np.ndarray, P: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Solve ``B X + X B = C`` for skew C, with ``B = P diag(b) Pᵀ`` (batched).

    The diagonal of a skew C is zero, so the possibly vanishing ``2 b_i`` there never divides.
    """
    Pt = np.swapaxes(P, -1, -2)
    pair = b[..., :, None] + b[..., None, :]
    n = b.shape[-1]
    pair = pair + np.eye(n)  # diagonal: (2 b_i + 1), harmless since C̃_ii = 0
    X = P @ ((Pt @ C @ P) / pair) @ Pt
    return 0.5 * (X - np.swapaxes(X, -1, -2))  # exactly skew (see EulerTop.angular_velocity)


def solve_lyapunov(B: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Solve ``B X + X B = C`` for symmetric positive definite B and skew C (batched).

    Real arrays in B's eigenbasis (:func:`eigh_or_nan`, :func:`solve_lyapunov_sym`). Complex
    ones (the complex-step derivatives of :mod:`lieint.tangent`) by one dense solve on the skew
    matrices, ``d = n(n − 1)/2`` unknowns ``X_ij`` (i < j): the eigendecomposition of a complex
    matrix is the Hermitian one, not analytic in B, and would lose the derivative. The solve is
    on the skew matrices, not on all n² entries, because the diagonal's equations ``2 b_i X_ii = 0``
    are singular for a flat body (an eigenvalue ``b_i = 0``, e.g. I = (1, 2, 3)); on the skew
    matrices the operator's eigenvalues are ``b_i + b_j`` (i < j), nonzero for any body.
    """
    if not (np.iscomplexobj(B) or np.iscomplexobj(C)):
        b, P = eigh_or_nan(B)
        return solve_lyapunov_sym(b, P, C)
    n = B.shape[-1]
    i, j = np.triu_indices(n, k=1)
    d = i.size
    basis = np.zeros((d, n, n))
    basis[np.arange(d), i, j], basis[np.arange(d), j, i] = 1.0, -1.0
    # column m of the operator: the upper triangle of B E_m + E_m B
    images = np.einsum("...ik,mkj->...mij", B, basis) + np.einsum("mik,...kj->...mij", basis, B)
    L = np.swapaxes(images[..., i, j], -1, -2)  # (…, d rows (i < j), d columns (m))
    batch = np.broadcast_shapes(L.shape[:-2], C.shape[:-2])
    L = np.broadcast_to(L, batch + (d, d))
    rhs = np.broadcast_to(C, batch + C.shape[-2:])[..., i, j][..., None]
    x = np.linalg.solve(L, rhs)[..., 0]
    return np.einsum("...m,mij->...ij", x, basis)
