"""Bivectors and rotors of Cl(n) through ``clifford``, batched (docs/theory.md §1).

Sign convention, checked once and for all in ``tests/ga/test_ga.py``: the skew matrix of a
bivector ω acts on vectors as the commutator product ``x ↦ ω × x = ½(ωx − xω)`` (the entry
``[i, j]``, i < j, is the coefficient of the blade ``e_ij = e_i ∧ e_j``), and the rotor
``exp(tω/2)`` moves ``x ↦ R x R̃`` with ``d/dt = ω × x``. So the rotation matrix ``exp(X)``
corresponds to the rotor ``exp(X/2)`` (up to the sign of the double cover).

clifford provides the algebra (its layout and multiplication table); lieint vectorises the
products over leading batch dimensions with a gather table: for each left blade i, the right
blade j that lands on the output blade k, and the sign. A product then costs ``(2ⁿ)²``
multiply-adds per member (n = 6: 4096), which keeps Cl(n) practical up to n ≈ 8.
"""

from __future__ import annotations

from functools import cache, cached_property

import clifford
import numpy as np

__all__ = [
    "GA",
    "algebra",
    "bivector_to_skew",
    "from_values",
    "resolve",
    "rotor_to_matrix",
    "skew_to_bivector",
    "to_values",
]

_MAX_N = 8


class GA:
    """Cl(n) (Euclidean signature) with batched products on coefficient arrays ``(..., 2ⁿ)``.

    Attributes
    ----------
    layout : clifford.Layout
        clifford's layout (blade order: shortlex, so grade-2 blades run ``e12, e13, …, e23, …``
        exactly like :func:`lieint.groups.bivector_coordinates`).
    size : int
        ``2ⁿ``.
    """

    def __init__(self, n: int):
        self.n = n
        self.layout, self.blades = clifford.Cl(n)
        self.size = self.layout.gaDims
        grades = np.array([len(t) for t in self.layout.bladeTupList])
        self.grades = grades
        self.reverse_sign = np.where((grades * (grades - 1) // 2) % 2 == 0, 1.0, -1.0)
        self.vector_index = np.flatnonzero(grades == 1)
        self.bivector_index = np.flatnonzero(grades == 2)
        # the (i, j), i < j, of each grade-2 blade e_ij in clifford's order
        pairs = [self.layout.bladeTupList[k] for k in self.bivector_index]
        self.identity_matrix = np.eye(n)
        self.bivector_pairs = (np.array([p[0] - 1 for p in pairs]), np.array([p[1] - 1 for p in pairs]))
        # Gather table of the geometric product: (ab)_k = Σ_i a_i b_{J[i,k]} S[i,k].
        i, k, j = self.layout.gmt.coords
        J = np.zeros((self.size, self.size), dtype=np.intp)
        S = np.zeros((self.size, self.size))
        J[i, k] = j
        S[i, k] = self.layout.gmt.data
        self._J, self._S = J, S
        if n == 4:
            # bivector → bivector maps of Cl(4): B ↦ B I (the dual) and the bilinear form of B ∧ B
            # on the pseudoscalar I (the last blade), read off clifford's tables
            nb = len(self.bivector_index)
            unit = np.zeros((nb, self.size))
            unit[np.arange(nb), self.bivector_index] = 1.0
            pseudo = np.zeros(self.size)
            pseudo[-1] = 1.0
            self.dual4 = self.product(unit, pseudo)[:, self.bivector_index]
            pairs_prod = self.product(unit[:, None, :], unit[None, :, :])[..., -1]
            self.wedge4 = 0.5 * (pairs_prod + pairs_prod.T)
            self.ones6_pm = np.ones((nb, 2))  # |B|² twice: for φ₊² and φ₋²
            self.signs_pm = np.array([1.0, -1.0])
            # the same maps as term lists for one bivector in Python floats (exponential._exp4_single):
            # B ∧ B on I is Σ c b_p b_q over three pairs of complementary planes, and B I a signed
            # permutation of the coefficients
            self.wedge4_terms = [
                (p, q, 2.0 * float(self.wedge4[p, q]))
                for p in range(nb)
                for q in range(p + 1, nb)
                if self.wedge4[p, q] != 0.0
            ]
            src, dst = np.nonzero(self.dual4)
            if sorted(dst.tolist()) != list(range(nb)) or np.any(np.diag(self.wedge4) != 0.0):
                raise RuntimeError("clifford's Cl(4) tables are not of the expected form.")
            self.dual4_terms = sorted((int(k), int(p), float(self.dual4[p, k])) for p, k in zip(src, dst, strict=True))
            self.bivector_pair_list = list(zip(*(ix.tolist() for ix in self.bivector_pairs), strict=True))
            self.bivector_index_list = self.bivector_index.tolist()

    def product(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Geometric product of coefficient arrays (broadcast over leading dimensions)."""
        # a row vector times the 2ⁿ × 2ⁿ matrix b_J S per member; matmul carries less per-call
        # overhead than einsum, which matters for one body
        if a.ndim == 1 and b.ndim == 1:
            return a @ (b[self._J] * self._S)
        return np.matmul(a[..., None, :], b[..., self._J] * self._S)[..., 0, :]

    def reverse(self, a: np.ndarray) -> np.ndarray:
        """Reversion ``ã`` (sign ``(−1)^{g(g−1)/2}`` on grade g)."""
        return a * self.reverse_sign

    def scalar(self, value: np.ndarray) -> np.ndarray:
        """Multivector with scalar part ``value``."""
        out = np.zeros(np.shape(value) + (self.size,))
        out[..., 0] = value
        return out

    def vector(self, x: np.ndarray) -> np.ndarray:
        out = np.zeros(np.shape(x)[:-1] + (self.size,))
        out[..., self.vector_index] = x
        return out

    def bivector(self, X: np.ndarray) -> np.ndarray:
        """Coefficients of the bivector of a skew matrix X."""
        i, j = self.bivector_pairs
        out = np.zeros(np.shape(X)[:-2] + (self.size,))
        out[..., self.bivector_index] = X[..., i, j]
        return out

    def skew(self, a: np.ndarray) -> np.ndarray:
        """Skew matrix of the grade-2 part of ``a``."""
        i, j = self.bivector_pairs
        c = a[..., self.bivector_index]
        out = np.zeros(a.shape[:-1] + (self.n, self.n))
        out[..., i, j] = c
        out[..., j, i] = -c
        return out

    def sandwich(self, R: np.ndarray, x: np.ndarray) -> np.ndarray:
        """``R x R̃``."""
        return self.product(self.product(R, x), self.reverse(R))

    def normalize(self, R: np.ndarray) -> np.ndarray:
        """Nearest rotor: ``R (R̃R)^{-1/2}`` — the Clifford analogue of the polar factor.

        ``R̃R = 1 + ε`` for a rotor perturbed by round-off (ε of grades 0 and 4, …); the inverse
        square root is the series ``1 − ε/2 + 3ε²/8 − 5ε³/16``, exact to round-off for ε ~ 1e-15.
        For n ≤ 3, ``R̃R`` is a scalar and this is division by the norm.
        """
        RR = self.product(self.reverse(R), R)
        if self.n <= 3:
            return R / np.sqrt(RR[..., :1])
        eps = RR - self.scalar(np.ones(RR.shape[:-1]))
        eps2 = self.product(eps, eps)
        inv_sqrt = self.scalar(np.ones(RR.shape[:-1])) - 0.5 * eps + 0.375 * eps2 - 0.3125 * self.product(eps2, eps)
        return self.product(R, inv_sqrt)

    def rotor_matrix(self, R: np.ndarray) -> np.ndarray:
        """Rotation matrix Q of a rotor: ``Q e_i = R e_i R̃``."""
        basis = np.eye(self.n)
        cols = self.sandwich(R[..., None, :], self.vector(basis))  # (..., n basis, 2ⁿ)
        return np.swapaxes(cols[..., self.vector_index], -1, -2)

    #: the largest n for which :meth:`even_rotor_matrix` keeps a table (``4^{n−1} n²`` numbers)
    EVEN_TABLE_MAX_N = 6

    def even_rotor_matrix(self, R: np.ndarray) -> np.ndarray:
        """:meth:`rotor_matrix` of rotors, reading their even part only (a rotor is even).

        ``Q_ij = ⟨R e_j R̃⟩_i = Σ_{a,b} R_a R_b ⟨e_a e_j ẽ_b⟩_i`` over the ``2ⁿ⁻¹`` even blades
        is a quadratic form in R: ``R ⊗ R`` times a table read off clifford's product once
        (``4ⁿ⁻¹ n²`` numbers; kept for n ≤ :attr:`EVEN_TABLE_MAX_N`, beyond which this is
        :meth:`rotor_matrix`). One matrix product per member instead of two batched
        geometric products, and exact to round-off like them: for a unit rotor Q is orthogonal
        to round-off.
        """
        if self.n > self.EVEN_TABLE_MAX_N:
            return self.rotor_matrix(R)
        even, table = self._even_rotation_table
        r = R[..., even]
        rr = (r[..., :, None] * r[..., None, :]).reshape(r.shape[:-1] + (len(even) ** 2,))
        return (rr @ table).reshape(r.shape[:-1] + (self.n, self.n))

    @cached_property
    def _even_rotation_table(self) -> tuple[np.ndarray, np.ndarray]:
        """The even blades and ``⟨e_a e_j ẽ_b⟩_i`` as a ``(E², n²)`` table, rows (a, b), columns (i, j)."""
        even = np.flatnonzero(self.grades % 2 == 0)
        E, n = len(even), self.n
        units = np.zeros((E, self.size))
        units[np.arange(E), even] = 1.0
        left = self.product(units[:, None, :], self.vector(np.eye(n))[None, :, :])  # e_a e_j: (E, n, 2ⁿ)
        full = self.product(left[:, None, :, :], self.reverse(units)[None, :, None, :])  # (E, E, n, 2ⁿ)
        table = np.swapaxes(full[..., self.vector_index], -1, -2)  # (a, b, i, j)
        return even, np.ascontiguousarray(table.reshape(E * E, n * n))


@cache
def algebra(n: int) -> GA:
    """The (cached) batched Cl(n) for ``2 ≤ n ≤ 8``."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 2 <= n <= _MAX_N:
        raise ValueError(
            f"`n` must be an integer in [2, {_MAX_N}] for geometric algebra (Cl(n) has 2^n coefficients "
            f"and a product costs 4^n per body); got {n!r}."
        )
    return GA(int(n))


def to_values(mv, n=None) -> np.ndarray:
    """Coefficient array ``(..., 2ⁿ)`` of a clifford MultiVector or MVArray (or an array).

    ``n`` (an int or a clifford layout), when given, is checked against the coefficients.
    """
    if n is None:
        if isinstance(mv, clifford.MultiVector):
            return np.asarray(mv.value, dtype=float)
        if isinstance(mv, np.ndarray) and mv.dtype == object:
            return np.stack([to_values(m) for m in mv.ravel()]).reshape(mv.shape + (-1,))
        return np.asarray(mv, dtype=float)
    return resolve(mv, n, "mv")[0]


def _dims_of(n, name: str) -> int:
    """``n`` from an int or a (Euclidean) clifford layout."""
    if isinstance(n, clifford.Layout):
        sig = np.asarray(n.sig)
        if not np.all(sig == 1):
            raise ValueError(
                f"`{name}`: lieint.ga works in Euclidean Cl(n); got a layout of signature {sig.tolist()} "
                "(PGA motors live in lieint.ga.motor)."
            )
        return int(n.dims)
    return algebra(n).n


def resolve(x, n=None, name: str = "x") -> tuple[np.ndarray, GA, str]:
    """Read multivector(s) given as clifford objects or coefficient arrays.

    Parameters
    ----------
    x : clifford.MultiVector, clifford.MVArray or array_like
        Plain arrays hold coefficients ``(..., 2ⁿ)`` in clifford's blade order.
    n : int or clifford.Layout, optional
        Needed for plain arrays (their size alone does not say which algebra they belong to:
        16 coefficients are Cl(4) or the PGA Cl(3,0,1)); checked against clifford objects.
    name : str
        The argument's name in error messages.

    Returns
    -------
    values : ndarray, shape (..., 2ⁿ)
    ga : GA
        The algebra.
    kind : {"multivector", "mvarray", "array"}
        What was given, so that results come back alike (:func:`from_values`).
    """
    layout = _layout_of(x)
    if layout is not None:
        dims = _dims_of(layout, name)
        if n is not None and _dims_of(n, "n") != dims:
            raise ValueError(f"`{name}` is a multivector of Cl({dims}) but `n` = {_dims_of(n, 'n')} was given.")
        kind = "multivector" if isinstance(x, clifford.MultiVector) else "mvarray"
        return to_values(x), algebra(dims), kind
    try:
        values = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(
            f"`{name}` must be a clifford MultiVector/MVArray or an array of coefficients; got {type(x).__name__}."
        ) from None
    size = values.shape[-1] if values.ndim else 0
    if n is None:
        guess = int(np.log2(size)) if size > 0 and size & (size - 1) == 0 else None
        hint = f" (e.g. n={guess} for Cl({guess}))" if guess is not None and 2 <= guess <= _MAX_N else ""
        raise ValueError(
            f"`{name}` is a plain array of shape {values.shape}: pass `n` (or a clifford layout) to say which "
            f"algebra its coefficients belong to{hint}, or pass clifford multivectors."
        )
    ga = algebra(_dims_of(n, "n"))
    if size != ga.size:
        raise ValueError(
            f"`{name}` must hold the {ga.size} coefficients of a multivector of Cl({ga.n}) on its last axis; "
            f"got shape {values.shape}."
        )
    return values, ga, "array"


def from_values(values: np.ndarray, ga: GA, kind: str):
    """Coefficients back to the kind :func:`resolve` reported (clifford objects or an array)."""
    if kind == "array":
        return values
    return _to_mv(values, ga)


def _to_mv(values: np.ndarray, ga: GA):
    if values.ndim == 1:
        return ga.layout.MultiVector(values.copy())
    flat = [ga.layout.MultiVector(v.copy()) for v in values.reshape(-1, ga.size)]
    return clifford.MVArray(flat).reshape(values.shape[:-1])


def skew_to_bivector(X):
    """clifford bivector(s) of skew matrices ``(..., n, n)``: a MultiVector, or an MVArray for batches."""
    X = np.asarray(X, dtype=float)
    ga = algebra(X.shape[-1])
    return _to_mv(ga.bivector(X), ga)


def bivector_to_skew(B, n=None) -> np.ndarray:
    """Skew matrices ``(..., n, n)`` of bivector(s) (other grades must vanish).

    ``B``: clifford MultiVector/MVArray, or coefficient arrays ``(..., 2ⁿ)`` with ``n`` (an int
    or a clifford layout).
    """
    values, ga, _ = resolve(B, n, "B")
    other = np.delete(values, ga.bivector_index, axis=-1)
    scale = max(float(np.max(np.abs(values), initial=0.0)), 1e-300)
    if np.max(np.abs(other), initial=0.0) > 1e-12 * scale:
        raise ValueError(
            "expected a bivector (grade 2 only); got a multivector with other grades of size "
            f"{float(np.max(np.abs(other))):.3g}."
        )
    return ga.skew(values)


def rotor_to_matrix(R, n=None) -> np.ndarray:
    """Rotation matrices ``(..., n, n)`` of rotors: ``Q e_i = R e_i R̃``.

    ``R``: clifford MultiVector/MVArray, or coefficient arrays ``(..., 2ⁿ)`` with ``n`` (an int
    or a clifford layout), e.g. ``rotor_to_matrix(sol.states["rotor"], n=3)``.
    """
    values, ga, _ = resolve(R, n, "R")
    return ga.rotor_matrix(values)


def _layout_of(mv):
    if isinstance(mv, clifford.MultiVector):
        return mv.layout
    if isinstance(mv, np.ndarray) and mv.dtype == object and mv.size:
        first = mv.ravel()[0]
        return first.layout if isinstance(first, clifford.MultiVector) else None
    return None
