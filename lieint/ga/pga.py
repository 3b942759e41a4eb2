"""Projective geometric algebra Cl(3,0,1) (clifford's ``pga`` layout), batched.

Conventions, all read off clifford's own products and checked in ``tests/ga/test_motor.py``
(blade order ``1, e0, e1, e2, e3, e01, e02, e03, e12, e13, e23, e012, e013, e023, e123, e0123``;
``e0² = 0``):

* a point x is the trivector ``X = e123 − x₁ e023 + x₂ e013 − x₃ e012``, a direction d the same
  with no ``e123`` (an ideal point);
* a motor M moves body points to space points, ``X_space = M X_body M̃``; the motor of the pose
  ``(R, c)`` (``x ↦ R x + c``) is ``T_c S`` with S the rotor of R in the Euclidean blades
  ``1, e12, e13, e23`` (as in Cl(3)) and the translator ``T_c = 1 − ½ Σ c_i e0i``;
* a body twist ``ξ = (Ω, v)`` (``ġ = g ξ`` for the pose matrix g) is the bivector
  ``B = ω − Σ v_i e0i`` (ω the bivector of Ω), with ``Ṁ = ½ M B``;
* lines: the join ``X ∨ D`` of a point and a direction; momenta and forces are such lines
  (``x ∨ m v``, ``x ∨ f``, the *forques*), stored by their moment ``L = x × d`` about the origin and
  their direction d; they move like every line, ``P_space = M P_body M̃``.

The exponential of a bivector uses dual numbers: ``B² = −a² + 2m I`` (``I = e0123``, ``I² = 0``),
so ``B² = −φ²`` with the dual angle ``φ = a − (m/a) I``, and

    e^B = cos a + m sinc(a) I + sinc(a) B − m (cos a − sinc a)/a² · I ω,

smooth in a (the last factor is a series for small a); a translation (a = 0) gives ``1 + B``.
The exact projection onto unit motors divides by the dual-number square root of ``M M̃``.
"""

from __future__ import annotations

import math
from functools import cached_property

import numpy as np

__all__ = ["PGA"]


class _PGA:
    """Cl(3,0,1) with products batched over leading dimensions (coefficients ``(..., 16)``)."""

    size = 16
    #: indices of the blades in clifford's pga layout
    SCALAR, E0, E01, E02, E03, E12, E13, E23, E012, E013, E023, E123, E0123 = (
        0,
        1,
        5,
        6,
        7,
        8,
        9,
        10,
        11,
        12,
        13,
        14,
        15,
    )
    E0I = np.array([5, 6, 7])
    EUCLID_BIVECTOR = np.array([8, 9, 10])  # e12, e13, e23: Cl(3)'s blade order
    ROTOR = np.array([0, 8, 9, 10])
    BIVECTOR = np.array([5, 6, 7, 8, 9, 10])
    POINT = np.array([11, 12, 13, 14])  # e012, e013, e023, e123: the trivectors (points)
    EVEN = np.array([0, 5, 6, 7, 8, 9, 10, 15])  # the blades a motor lives on

    @cached_property
    def layout(self):
        from clifford import pga

        return pga.layout

    @cached_property
    def _table(self):
        layout = self.layout
        if list(layout.sig) != [0, 1, 1, 1] or layout.gaDims != 16:
            raise RuntimeError("clifford's pga layout is not Cl(3,0,1) with e0 first; lieint.ga.pga needs it.")
        i, k, j = layout.gmt.coords
        J = np.zeros((16, 16), dtype=np.intp)
        S = np.zeros((16, 16))
        J[i, k] = j
        S[i, k] = layout.gmt.data
        grades = np.array([len(t) for t in layout.bladeTupList])
        reverse = np.where((grades * (grades - 1) // 2) % 2 == 0, 1.0, -1.0)
        return J, S, reverse

    def product(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Geometric product of coefficient arrays (broadcast over leading dimensions)."""
        J, S, _ = self._table
        # (ab)_k = Σ_i a_i (b_J S)_ik: a row vector times a 16 × 16 matrix per member; matmul
        # carries less per-call overhead than einsum, which matters for one body
        return np.matmul(a[..., None, :], b[..., J] * S)[..., 0, :]

    def reverse(self, a: np.ndarray) -> np.ndarray:
        return a * self._table[2]

    def sandwich(self, M: np.ndarray, x: np.ndarray) -> np.ndarray:
        """``M x M̃``."""
        return self.product(self.product(M, x), self.reverse(M))

    def even_sandwich(self, m: np.ndarray, x: np.ndarray, grade: int) -> np.ndarray:
        """The grade-``grade`` part of ``M x M̃`` for even M and x of that grade.

        Parameters
        ----------
        m : ndarray, shape (..., 8)
            The coefficients of M on :attr:`EVEN` (a motor, a rotor, a translator).
        x : ndarray, shape (..., g)
            The coefficients of x on the g blades of the grade, in clifford's order (grade 2:
            :attr:`BIVECTOR`, lines; grade 3: :attr:`POINT`, points).
        grade : {1, 2, 3}

        Returns
        -------
        ndarray, shape (..., g)

        Notes
        -----
        ``(M x M̃)_k = Σ_{a,b,c} m_a m_b x_c ⟨e_a e_c ẽ_b⟩_k`` is quadratic in m and linear in x;
        its table (``8·8·g·g`` numbers) is read off clifford's product once. A motor moves points
        to points and lines to lines, so only this grade of ``M x M̃`` is formed. Per member this
        is the ``g × g`` matrix of the sandwich (``m ⊗ m`` times the table) applied to x: a few
        hundred multiply-adds in three numpy calls, instead of two full products.
        """
        blades, table = self._sandwich_table(grade)
        g = len(blades)
        mm = (m[..., :, None] * m[..., None, :]).reshape(m.shape[:-1] + (64,))
        matrix = (mm @ table).reshape(mm.shape[:-1] + (g, g))
        return np.matmul(x[..., None, :], matrix)[..., 0, :]

    def _sandwich_table(self, grade: int) -> tuple[np.ndarray, np.ndarray]:
        """The blades of ``grade`` and ``⟨e_a e_c ẽ_b⟩_k`` (a, b in :attr:`EVEN`; c, k those
        blades), shape ``(64, g·g)``; built once per grade."""
        cached = self._sandwich_tables.get(grade)
        if cached is not None:
            return cached
        blades = np.flatnonzero(self._grades == grade)
        g = len(blades)
        ea = np.zeros((8, 1, 1, 16))
        ea[np.arange(8), 0, 0, self.EVEN] = 1.0
        eb = np.zeros((1, 8, 1, 16))
        eb[0, np.arange(8), 0, self.EVEN] = 1.0
        ec = np.zeros((1, 1, g, 16))
        ec[0, 0, np.arange(g), blades] = 1.0
        full = self.product(self.product(ea, ec), self.reverse(eb))  # (8, 8, g, 16)
        table = np.ascontiguousarray(full[..., blades].reshape(64, g * g))
        self._sandwich_tables[grade] = (blades, table)
        return blades, table

    @cached_property
    def _sandwich_tables(self) -> dict:
        return {}

    @cached_property
    def _grades(self) -> np.ndarray:
        return np.array([len(t) for t in self.layout.bladeTupList])

    def multivectors(self, values: np.ndarray):
        """clifford MultiVector (one) or MVArray (a batch) of coefficient arrays."""
        import clifford

        values = np.asarray(values, dtype=float)
        if values.ndim == 1:
            return self.layout.MultiVector(values.copy())
        flat = [self.layout.MultiVector(v.copy()) for v in values.reshape(-1, 16)]
        return clifford.MVArray(flat).reshape(values.shape[:-1])

    # -- points and lines ---------------------------------------------------------------------
    def point(self, x: np.ndarray, weight: float = 1.0) -> np.ndarray:
        """The trivector of the point x (``weight`` 0: the direction x)."""
        x = np.asarray(x, dtype=float)
        out = np.zeros(x.shape[:-1] + (16,))
        out[..., self.E123] = weight
        out[..., self.E023] = -x[..., 0]
        out[..., self.E013] = x[..., 1]
        out[..., self.E012] = -x[..., 2]
        return out

    def point_coordinates(self, X: np.ndarray) -> np.ndarray:
        """x of point trivectors (divided by their weight)."""
        return self.point_coordinates_of_trivector(X[..., self.POINT])

    def point_coordinates_of_trivector(self, p: np.ndarray) -> np.ndarray:
        """x of points given by their coefficients ``(..., 4)`` on :attr:`POINT` (e012, e013,
        e023, e123): ``x = (−p_e023, p_e013, −p_e012)/p_e123``."""
        return p[..., 2::-1] * self._POINT_SIGNS / p[..., 3:]

    _POINT_SIGNS = np.array([-1.0, 1.0, -1.0])

    @cached_property
    def _line_maps(self):
        """``(moment L, direction d) ↦`` bivector coefficients of the line, and back.

        Built from clifford's regressive product: the line through x with direction d is
        ``X ∨ D``; it is linear in ``(x × d, d)``.
        """
        layout = self.layout
        cols = []
        origin = self.point(np.zeros(3))
        for k in range(3):  # pure directions through the origin
            d = np.eye(3)[k]
            cols.append(("d", k, (layout.MultiVector(origin) & layout.MultiVector(self.point(d, 0.0))).value))
        moment_cols = {}
        for i in range(3):
            for j in range(3):
                if i == j:
                    continue
                x, d = np.eye(3)[i], np.eye(3)[j]
                through = (layout.MultiVector(self.point(x)) & layout.MultiVector(self.point(d, 0.0))).value
                moment = through - cols[j][2]
                moment_cols[tuple(np.cross(x, d).astype(int))] = moment
        K = np.zeros((16, 6))
        for k in range(3):
            e = np.zeros(3, dtype=int)
            e[k] = 1
            K[:, k] = moment_cols[tuple(e)]
            K[:, 3 + k] = cols[k][2]
        Kb = K[self.BIVECTOR]
        return K, np.linalg.inv(Kb)

    def line(self, moment: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """The line (bivector) with moment ``L = x × d`` about the origin and direction d."""
        K, _ = self._line_maps
        md = np.concatenate([np.asarray(moment, dtype=float), np.asarray(direction, dtype=float)], axis=-1)
        return md @ K.T

    def line_parts(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(L, d)`` of lines: moment about the origin and direction."""
        return self.line_parts_of_bivector(P[..., self.BIVECTOR])

    def line_parts_of_bivector(self, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`line_parts` of the coefficients ``(..., 6)`` of lines on :attr:`BIVECTOR`."""
        _, Kinv = self._line_maps
        md = b @ Kinv.T
        return md[..., :3], md[..., 3:]

    # -- motors -------------------------------------------------------------------------------
    def twist_bivector(self, Omega: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The bivector ``B = ω − Σ v_i e0i`` of a body twist ``(Ω, v)`` (``Ṁ = ½ M B``)."""
        out = np.zeros(np.shape(v)[:-1] + (16,))
        out[..., self.E12] = Omega[..., 0, 1]
        out[..., self.E13] = Omega[..., 0, 2]
        out[..., self.E23] = Omega[..., 1, 2]
        out[..., self.E0I] = -v
        return out

    def exp(self, B: np.ndarray) -> np.ndarray:
        """``e^B`` of bivectors, exact (module docstring)."""
        if B.ndim == 1:
            return self._exp_single(B)
        w = B[..., self.EUCLID_BIVECTOR]
        a2 = np.einsum("...i,...i->...", w, w)
        b = B[..., self.BIVECTOR]
        m = np.einsum("...i,...i->...", b, b @ self._half_wedge)  # ½⟨B²⟩₄
        a = np.sqrt(a2)
        sinc = np.divide(np.sin(a), a, out=np.ones_like(a), where=a != 0.0)
        small = a < 1e-2
        safe = np.where(small, 1.0, a)
        # (cos a − sinc a)/a² = −1/3 + a²/30 − a⁴/840 + a⁶/45360 − …
        series = -1.0 / 3.0 + a2 / 30.0 - a2 * a2 / 840.0 + a2**3 / 45360.0
        k = np.where(small, series, (np.cos(safe) - np.sin(safe) / safe) / (safe * safe))
        Iw = self._dual_euclid(w)
        out = sinc[..., None] * B - (m * k)[..., None] * Iw
        out[..., self.SCALAR] = np.cos(a)
        out[..., self.E0123] = m * sinc
        return out

    def _exp_single(self, B: np.ndarray) -> np.ndarray:
        """:meth:`exp` of one bivector, the same formula in Python floats: for one body numpy's
        per-call overhead is larger than the two dozen multiplications themselves."""
        c = B.tolist()
        w = [c[i] for i in self.EUCLID_BIVECTOR]
        a2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
        m = 0.0  # ½⟨B²⟩₄: the few nonzero terms of the bilinear form
        for i, j, coef in self._half_wedge_terms:
            m += coef * c[i] * c[j]
        a = math.sqrt(a2)
        sinc = math.sin(a) / a if a != 0.0 else 1.0
        if a < 1e-2:  # (cos a − sinc a)/a², as a series (see exp)
            k = -1.0 / 3.0 + a2 / 30.0 - a2 * a2 / 840.0 + a2**3 / 45360.0
        else:
            k = (math.cos(a) - math.sin(a) / a) / (a * a)
        mk = m * k
        out = [sinc * x for x in c]
        for src, dst, coef in self._dual_euclid_terms:  # − m k · I ω, one term per ideal blade
            out[dst] -= mk * (coef * w[src])
        out[self.SCALAR] = math.cos(a)
        out[self.E0123] = m * sinc
        return np.array(out)

    @cached_property
    def _half_wedge_terms(self) -> list[tuple[int, int, float]]:
        """``(i, j, c)`` with ``½⟨B²⟩₄ = Σ c B_i B_j`` (blade indices, i ≤ j, nonzero c only)."""
        H = self._half_wedge
        return [
            (int(self.BIVECTOR[p]), int(self.BIVECTOR[q]), float(H[p, q] if p == q else 2.0 * H[p, q]))
            for p in range(6)
            for q in range(p, 6)
            if H[p, q] != 0.0
        ]

    @cached_property
    def _dual_euclid_terms(self) -> list[tuple[int, int, float]]:
        """``(src, dst, c)``: ``(I ω)_dst = c ω_src`` (src indexing e12, e13, e23); I ω is a signed
        permutation of ω onto the ideal blades, one term per blade (checked)."""
        unit = self._I_times_euclid
        terms = [(int(src), int(dst), float(unit[src, dst])) for src, dst in zip(*np.nonzero(unit), strict=True)]
        if sorted(dst for _, dst, _ in terms) != sorted(set(dst for _, dst, _ in terms)):
            raise RuntimeError("I ω is not a signed permutation in clifford's pga layout.")
        return terms

    def _dual_euclid(self, w: np.ndarray) -> np.ndarray:
        """``I ω`` for Euclidean bivectors ω (coefficients e12, e13, e23): an ideal bivector."""
        unit = self._I_times_euclid
        return w @ unit

    @cached_property
    def _half_wedge(self) -> np.ndarray:
        """The symmetric bilinear form ``b ↦ ½⟨B²⟩₄`` on bivector coefficients."""
        basis = np.zeros((6, 16))
        basis[np.arange(6), self.BIVECTOR] = 1.0
        pairs = self.product(basis[:, None, :], basis[None, :, :])[..., self.E0123]
        return 0.25 * (pairs + pairs.T)

    @cached_property
    def _I_times_euclid(self) -> np.ndarray:
        pseudo = np.zeros(16)
        pseudo[self.E0123] = 1.0
        basis = np.zeros((3, 16))
        basis[np.arange(3), self.EUCLID_BIVECTOR] = 1.0
        return self.product(pseudo, basis)

    def translator(self, c: np.ndarray) -> np.ndarray:
        """``T_c = 1 − ½ Σ c_i e0i``: ``x ↦ x + c``."""
        c = np.asarray(c, dtype=float)
        out = np.zeros(c.shape[:-1] + (16,))
        out[..., 0] = 1.0
        out[..., self.E0I] = -0.5 * c
        return out

    def motor(self, rotor: np.ndarray, c: np.ndarray) -> np.ndarray:
        """``T_c S`` from Cl(3) rotor coefficients ``(..., 8)`` and a translation c."""
        S = np.zeros(np.asarray(rotor).shape[:-1] + (16,))
        S[..., self.ROTOR] = np.asarray(rotor)[..., [0, 4, 5, 6]]  # Cl(3): 1, e1, e2, e3, e12, e13, e23, e123
        return self.product(self.translator(c), S)

    def rotor_part(self, M: np.ndarray) -> np.ndarray:
        """Cl(3) rotor coefficients ``(..., 8)`` of the rotation of motors (``M = T_c S``)."""
        out = np.zeros(M.shape[:-1] + (8,))
        out[..., [0, 4, 5, 6]] = M[..., self.ROTOR]
        return out

    def translation(self, M: np.ndarray) -> np.ndarray:
        """c of motors ``T_c S``: ``T_c = M S̃/(S S̃)``, read off as ``c = −2 ⟨M S̃⟩_{e0i}/(S S̃)``
        (a bilinear form in the e0 and the Euclidean even coefficients of M)."""
        S = M[..., self.ROTOR]
        num = np.einsum("...i,...j,ijk->...k", M[..., self._E0_EVEN], S, self._translation_form)
        return num / np.einsum("...i,...i->...", S, S)[..., None]

    _E0_EVEN = np.array([5, 6, 7, 15])

    @cached_property
    def _translation_form(self) -> np.ndarray:
        """``(m, s) ↦ −2 ⟨M S̃⟩_{e0i}`` for the e0 part m and the rotor part s of M."""
        form = np.zeros((4, 4, 3))
        for a, i in enumerate(self._E0_EVEN):
            for b, j in enumerate(self.ROTOR):
                ei, ej = np.zeros(16), np.zeros(16)
                ei[i], ej[j] = 1.0, 1.0
                form[a, b] = -2.0 * self.product(ei, self.reverse(ej))[self.E0I]
        return form

    def normalize(self, M: np.ndarray) -> np.ndarray:
        """Exact projection onto unit motors: ``M / √(M M̃)`` with ``M M̃ = s + p I`` a dual number,
        ``(s + pI)^{-1/2} = s^{-1/2}(1 − p/(2s) I)``."""
        MM = self.product(M, self.reverse(M))
        s, p = MM[..., 0], MM[..., self.E0123]
        factor = np.zeros(M.shape)
        factor[..., 0] = 1.0 / np.sqrt(s)
        factor[..., self.E0123] = -0.5 * p / (s * np.sqrt(s))
        return self.product(M, factor)

    def defect(self, M: np.ndarray) -> np.ndarray:
        """``‖M M̃ − 1‖``: zero for unit motors."""
        MM = self.product(M, self.reverse(M))
        MM[..., 0] -= 1.0
        return np.linalg.norm(MM, axis=-1)


#: the one instance (clifford is imported when it is first used)
PGA = _PGA()
