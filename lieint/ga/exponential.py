"""The exponential of any bivector of Cl(n), non-simple included, to round-off.

A bivector ``B`` of Cl(n) is a sum of at most ``⌊n/2⌋`` *commuting simple* bivectors in
mutually orthogonal planes (its invariant decomposition), ``B = Σ_k θ_k v_k∧u_k`` with
``(v_k∧u_k)² = −1``, so that

    e^B = Π_k (cos θ_k + sin θ_k v_k∧u_k).

The planes and angles are those of the skew matrix X of B (``X u_k = θ_k v_k``,
``X v_k = −θ_k u_k``), read from the Hermitian eigenproblem of ``iX``: an eigenvector
``w = (u − i v)/√2`` of eigenvalue θ > 0 gives the plane. This is backward stable, so the
result is a unit rotor to round-off (no series, no scaling and squaring) even for repeated
angles, where the planes are not unique but the product is.

clifford's own ``MultiVector.exp`` sums a series that is accurate for simple bivectors only; on
non-simple bivectors in n ≥ 4 it errs by 1e-8 to 1e-6 (``benchmarks/ga_figures.py`` measures
it against mpmath).
"""

from __future__ import annotations

import math

import numpy as np

from ..groups.so import so_log
from .algebra import GA, _to_mv, algebra, from_values, resolve

__all__ = ["exp", "matrix_to_rotor", "rotor_exp_of_skew", "simple_planes", "so_exp_with_rotor"]


def simple_planes(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The invariant decomposition of skew matrices ``(..., n, n)``.

    Returns
    -------
    theta : ndarray, shape (..., ⌊n/2⌋)
        Rotation angles θ_k ≥ 0 (ascending).
    u, v : ndarray, shape (..., ⌊n/2⌋, n)
        Orthonormal pairs with ``X u_k = θ_k v_k`` and ``X v_k = −θ_k u_k``, so that
        ``X = Σ_k θ_k (v_k u_kᵀ − u_k v_kᵀ)``.
    """
    X = np.asarray(X, dtype=float)
    n = X.shape[-1]
    m = n // 2
    lam, W = np.linalg.eigh(1j * X)  # Hermitian; eigenvalues ±θ_k (and 0 for odd n), ascending
    theta = lam[..., n - m :]
    w = np.swapaxes(W[..., :, n - m :], -1, -2)  # (..., m, n): eigenvectors of +θ_k
    u = np.sqrt(2.0) * w.real
    v = np.sqrt(2.0) * w.imag
    return theta, u, v


def _sinc(x: np.ndarray) -> np.ndarray:
    """``sin x / x`` (1 at 0); accurate to round-off for every x (no cancellation)."""
    x = np.asarray(x, dtype=float)
    return np.divide(np.sin(x), x, out=np.ones_like(x), where=x != 0.0)


def _plane_bivectors(ga: GA, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Coefficients of the unit bivectors ``v∧u`` (``(..., m, 2ⁿ)``)."""
    i, j = ga.bivector_pairs
    out = np.zeros(u.shape[:-1] + (ga.size,))
    blade = v[..., i] * u[..., j] - u[..., i] * v[..., j]
    # unit norm exactly: each factor cos θ + sin θ v∧u is then a unit rotor to round-off, and
    # so is their product (eigh leaves |u|, |v|, ⟨u, v⟩ off by a few ulps)
    norm = np.sqrt(np.sum(blade * blade, axis=-1, keepdims=True))
    out[..., ga.bivector_index] = blade / np.where(norm > 0.0, norm, 1.0)
    return out


def rotor_exp_of_skew(X: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """Coefficients of ``e^{scale·B}`` for the bivectors B of skew matrices ``(..., n, n)``.

    ``scale = 0.5`` gives the rotor of the rotation ``exp(X)`` (the double cover's convention,
    docs/theory.md §1).
    """
    X = np.asarray(X, dtype=float)
    n = X.shape[-1]
    if n == 3 and X.ndim == 2:  # one body: the same formula in floats
        return _so3_rotor_single(X, scale)
    ga = algebra(n)
    if n <= 3:  # every bivector is simple: ω² = −θ² is a scalar
        b = scale * ga.bivector(X)
        theta = np.sqrt(np.sum(b * b, axis=-1))
        out = _sinc(theta)[..., None] * b
        out[..., 0] = np.cos(theta)
        return out
    if n == 4:
        if X.ndim == 2:  # one body: straight from the matrix entries, in floats
            return _exp4_single(ga, X, scale)
        return _exp4(ga, scale * ga.bivector(X))
    theta, u, v = simple_planes(X)
    theta = scale * theta
    planes = _plane_bivectors(ga, u, v)
    factors = np.sin(theta)[..., None] * planes
    factors[..., 0] = np.cos(theta)
    out = factors[..., 0, :]
    for k in range(1, factors.shape[-2]):
        out = ga.product(out, factors[..., k, :])
    return out


def _exp4(ga: GA, B: np.ndarray) -> np.ndarray:
    """``e^B`` in Cl(4) in closed form, through the self-dual split.

    The pseudoscalar I (``I² = 1``) is central in the even subalgebra, so ``P± = (1 ± I)/2`` are
    orthogonal central idempotents and ``B = B₊ + B₋``, ``B± = P± B``, with ``B±² = −φ±² P±``,
    ``φ±² = |B|² ∓ β`` where ``B² = −|B|² + β I``. Hence
    ``e^B = cos φ₊ P₊ + cos φ₋ P₋ + sinc φ₊ B₊ + sinc φ₋ B₋`` — no eigenproblem, and the
    cosines and sincs depend smoothly on φ±², which carry only round-off relative to |B|².
    """
    bi = B[..., ga.bivector_index]
    dual = bi @ ga.dual4  # bivector coefficients of B I
    # |B|² and ⟨B²⟩₄ (B ∧ B on I) in one bilinear form: columns (1, ±1) give φ±² = |B|² ∓ β
    phi2 = (bi * bi) @ ga.ones6_pm
    phi2 = phi2 - np.einsum("...i,...i->...", bi, bi @ ga.wedge4)[..., None] * ga.signs_pm
    phi = np.sqrt(np.maximum(phi2, 0.0))
    c, s = np.cos(phi), 0.5 * _sinc(phi)
    out = np.zeros(B.shape)
    out[..., 0] = 0.5 * (c[..., 0] + c[..., 1])
    out[..., -1] = 0.5 * (c[..., 0] - c[..., 1])
    out[..., ga.bivector_index] = s[..., 0:1] * (bi + dual) + s[..., 1:2] * (bi - dual)
    return out


def _exp4_single(ga: GA, X: np.ndarray, scale: float) -> np.ndarray:
    """:func:`_exp4` of the bivector ``scale · ω`` of one skew matrix X, in Python floats.

    For one body numpy's per-call overhead exceeds the few dozen multiplications; the formula
    is :func:`_exp4`'s, with ``B ∧ B`` and ``B I`` as the term lists of :class:`GA`.
    """
    rows = X.tolist()
    b = [scale * rows[i][j] for i, j in ga.bivector_pair_list]  # e12, e13, e14, e23, e24, e34
    norm2 = b[0] * b[0] + b[1] * b[1] + b[2] * b[2] + b[3] * b[3] + b[4] * b[4] + b[5] * b[5]
    beta = 0.0
    for p, q, coef in ga.wedge4_terms:
        beta += coef * b[p] * b[q]
    cs = []
    for phi2 in (norm2 - beta, norm2 + beta):
        phi = math.sqrt(phi2) if phi2 > 0.0 else 0.0
        cs.append((math.cos(phi), 0.5 * (math.sin(phi) / phi if phi > 0.0 else 1.0)))
    (cp, sp), (cm, sm) = cs
    out = np.zeros(ga.size)  # filled item by item: cheaper than np.array of a list here
    out[0] = 0.5 * (cp + cm)
    out[-1] = 0.5 * (cp - cm)
    plus, minus = sp + sm, sp - sm
    for (k, p, sign), index in zip(ga.dual4_terms, ga.bivector_index_list, strict=True):
        out[index] = plus * b[k] + minus * (sign * b[p])  # (B I)_k = sign · b_p
    return out


def so_exp_with_rotor(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(exp X, e^{ω/2})``: the rotation and its rotor from one invariant decomposition.

    n ≤ 3: with ``s = cos(θ/2)`` and ``K = sin(θ/2) X/θ`` (the rotor is ``s + K``),
    ``exp X = I + 2sK + 2K²``. n ≥ 4: ``exp X = I + Σ_k sin θ_k (v_k u_kᵀ − u_k v_kᵀ) +
    (cos θ_k − 1)(u_k u_kᵀ + v_k v_kᵀ)`` over the planes of X.
    """
    X = np.asarray(X, dtype=float)
    n = X.shape[-1]
    ga = algebra(n)
    eye = ga.identity_matrix
    if n == 3 and X.ndim == 2:
        return _so3_exp_with_rotor_single(X)
    if n <= 3:
        S = rotor_exp_of_skew(X, 0.5)
        K = ga.skew(S)
        return eye + 2.0 * S[..., 0, None, None] * K + 2.0 * (K @ K), S
    theta, u, v = simple_planes(X)
    s, c1 = np.sin(theta)[..., None, :], (np.cos(theta) - 1.0)[..., None, :]
    Ut, Vt = np.swapaxes(u, -1, -2), np.swapaxes(v, -1, -2)
    Q = eye + (Vt * s) @ u - (Ut * s) @ v + (Ut * c1) @ u + (Vt * c1) @ v
    half = 0.5 * theta
    factors = np.sin(half)[..., None] * _plane_bivectors(ga, u, v)
    factors[..., 0] = np.cos(half)
    S = factors[..., 0, :]
    for k in range(1, factors.shape[-2]):
        S = ga.product(S, factors[..., k, :])
    return Q, S


def _so3_exp_with_rotor_single(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`so_exp_with_rotor` of one 3 × 3 skew matrix, the same closed form in Python floats.

    The rotor ``s + K`` (``s = cos(θ/2)``, ``K = sinc(θ/2) ω/2`` on e12, e13, e23, clifford's
    order) and ``exp X = I + 2sK + 2K²`` with K as a skew matrix: some thirty multiplications,
    fewer than the numpy calls that would carry them for one body.
    """
    S = _so3_rotor_single(X, 0.5)
    s, _, _, _, k12, k13, k23, _ = S.tolist()
    return _rotation_of_rotor3(s, k12, k13, k23), S


def _so3_rotor_single(X: np.ndarray, scale: float) -> np.ndarray:
    """:func:`rotor_exp_of_skew` of one 3 × 3 skew matrix in floats: ``e^b = cos θ + sinc θ b``
    for ``b = scale · ω`` (e12, e13, e23), ``θ = |b|``."""
    (_, x01, x02), (_, _, x12) = X.tolist()[:2]
    b12, b13, b23 = scale * x01, scale * x02, scale * x12
    theta = math.sqrt(b12 * b12 + b13 * b13 + b23 * b23)
    k = math.sin(theta) / theta if theta != 0.0 else 1.0
    return np.array([math.cos(theta), 0.0, 0.0, 0.0, k * b12, k * b13, k * b23, 0.0])


def _rotation_of_rotor3(s: float, k12: float, k13: float, k23: float) -> np.ndarray:
    """``I + 2sK + 2K²`` for ``K = [[0, k12, k13], [−k12, 0, k23], [−k13, −k23, 0]]`` in floats."""
    s2, a, b, c = 2.0 * s, 2.0 * k12, 2.0 * k13, 2.0 * k23
    # 2K² = [[−a k12 − b k13, −b k23, a k23], [−c k13, −a k12 − c k23, −a k13], [c k12, −b k12, −b k13 − c k23]]
    return np.array(
        [
            [1.0 - (a * k12 + b * k13), s2 * k12 - b * k23, s2 * k13 + a * k23],
            [-s2 * k12 - c * k13, 1.0 - (a * k12 + c * k23), s2 * k23 - a * k13],
            [-s2 * k13 + c * k12, -s2 * k23 - b * k12, 1.0 - (b * k13 + c * k23)],
        ]
    )


def exp(B, n: int | None = None):
    """``e^B`` of bivector(s) of Cl(n), accurate to round-off for every bivector.

    Parameters
    ----------
    B : clifford.MultiVector, clifford.MVArray or array_like
        Bivector(s); a plain array holds coefficients ``(..., 2ⁿ)`` in clifford's blade order and
        needs ``n``.
    n : int, optional
        Dimension of the space (2 ≤ n ≤ 8) for plain coefficient arrays.

    Returns
    -------
    clifford.MultiVector, clifford.MVArray or ndarray
        The rotor(s) ``e^B``, of the kind given (coefficients for plain arrays). ``e^{ω/2}`` is
        the rotor of the rotation ``exp(X)`` when ω is the bivector of the skew matrix X.

    Notes
    -----
    Uses the invariant decomposition ``B = Σ_k θ_k v_k∧u_k`` into commuting simple bivectors
    (see the module docstring): ``e^B = Π_k (cos θ_k + sin θ_k v_k∧u_k)``. For n ≥ 4 this differs
    from clifford's ``B.exp()``, which is accurate only for simple bivectors.

    Examples
    --------
    >>> import numpy as np
    >>> from lieint import ga
    >>> X = np.zeros((4, 4)); X[0, 1], X[2, 3] = 0.7, 1.9     # non-simple in R⁴
    >>> X = X - X.T
    >>> R = ga.exp(ga.skew_to_bivector(X) / 2)
    >>> bool(np.allclose(ga.rotor_to_matrix(R), __import__("scipy").linalg.expm(X), atol=1e-15))
    True
    """
    values, ga, kind = resolve(B, n, "B")
    other = np.delete(values, ga.bivector_index, axis=-1)
    scale = max(float(np.max(np.abs(values), initial=0.0)), 1e-300)
    if np.max(np.abs(other), initial=0.0) > 1e-12 * scale:
        raise ValueError(
            f"`B` must be a bivector (grade 2 only); got other grades of size {float(np.max(np.abs(other))):.3g}."
        )
    return from_values(rotor_exp_of_skew(ga.skew(values)), ga, kind)


def matrix_to_rotor(Q, reference=None, *, as_multivector: bool = True):
    """Rotor(s) of rotation matrices: ``exp(log(Q)/2)``.

    The double cover leaves a sign free; it is chosen so that the rotor has a nonnegative
    scalar part, or, given ``reference`` rotors (clifford objects or coefficient arrays), a
    nonnegative inner product with them (continuity along a trajectory).
    """
    Q = np.asarray(Q, dtype=float)
    ga = algebra(Q.shape[-1])
    R = rotor_exp_of_skew(so_log(Q), 0.5)
    ref = resolve(reference, ga.n, "reference")[0] if reference is not None else ga.scalar(np.ones(R.shape[:-1]))
    sign = np.where(np.sum(R * ref, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    R = sign * R
    return _to_mv(R, ga) if as_multivector else R
