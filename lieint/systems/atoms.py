"""The rigid body as atoms: N point masses held rigid by central reactions (docs/theory.md §8).

Atom i (mass ``mᵢ``, position ``qᵢ``) feels the reaction ``Rᵢ = Σₖ σᵢₖ (qₖ − qᵢ)`` with
``σᵢₖ = σₖᵢ``, on the pairs ``S = {(i, j): i < j, i among the first n atoms}``
(``|S| = nN − n(n+1)/2``, the number of internal degrees of freedom). At each instant the
σ solve the linear system, one equation per pair of S (no external force here)::

    ⟨qᵢ − qⱼ, rᵢ − rⱼ⟩ = −|q̇ᵢ − q̇ⱼ|²,     mᵢ rᵢ = Rᵢ,

the second derivative of ``|qᵢ − qⱼ|² = const``; then ``mᵢ q̈ᵢ = Rᵢ``. Every reaction is a sum
of forces along the lines joining atoms, equal and opposite in pairs, so ``Σ Rᵢ = 0`` and
``Σ qᵢ ∧ Rᵢ = 0``: the linear and angular momenta are constant, and the atoms move as the Euler
top (docs/theory.md §2) with ``B = Σ mᵢ XᵢXᵢᵀ`` about the centre of mass — an independent truth for
:class:`~lieint.EulerTop`. The state is the positions ``"q"`` and velocities ``"v"``, shape
``(N, n)`` (batched over leading axes); the group is ``R^{N×n} × R^{N×n}`` (translations).
"""

from __future__ import annotations

from types import MappingProxyType
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .._validation import as_float_array, check_vector, describe
from ..groups.bivectors import wedge
from ..groups.so import project_to_so
from ..groups.vector import ProductGroup, VectorSpace
from .base import Invariant, LieGroupSystem, Output, State
from .euler_top import EulerTop
from .rigid import InertiaOperator

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

__all__ = ["AtomsBody", "reaction_pairs"]


def reaction_pairs(N: int, n: int) -> np.ndarray:
    """The pairs S (rows ``(i, j)``, ``i < j``, i among the first n atoms)."""
    return np.array([(i, j) for i in range(n) for j in range(i + 1, N)], dtype=int).reshape(-1, 2)


class AtomsBody(LieGroupSystem):
    """N atoms held rigid by central reactions solved at each instant (module docstring).

    Parameters
    ----------
    masses : array_like, shape (N,)
        Positive masses ``mᵢ``.
    positions : array_like, shape (N, n)
        The atoms' positions ``Xᵢ`` in the body frame (any origin; the body frame used for the
        mass tensor and the initial state is centred at the centre of mass). The first n atoms
        must span a hyperplane and the body all of Rⁿ (``N ≥ n + 1``), so that the reactions on
        S are determined and the mass tensor is invertible.

    Attributes
    ----------
    mass_tensor : ndarray, shape (n, n)
        ``B = Σ mᵢ XᵢXᵢᵀ`` about the centre of mass: the Euler top these atoms are.
    pairs : ndarray, shape ``(|S|, 2)``
        The reaction pairs S.

    Invariants: ``energy`` ``½ Σ mᵢ|q̇ᵢ|²``, ``linear_momentum`` ``Σ mᵢ q̇ᵢ``,
    ``angular_momentum`` ``Σ mᵢ qᵢ ∧ q̇ᵢ`` and the defect ``distances`` (``|qᵢ − qⱼ| − |Xᵢ − Xⱼ|``
    over all pairs). Outputs: ``reactions`` ``Rᵢ``, ``R`` (the rotation with
    ``qᵢ − q_G = R Xᵢ``) and ``A`` (the body momentum ``Rᵀ a R`` about the centre of mass),
    the two fields of :class:`~lieint.EulerTop` to compare with.

    Examples
    --------
    >>> import numpy as np, lieint
    >>> X = [[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, -1, -1], [0.5, -0.3, 0.2]]
    >>> body = lieint.AtomsBody([1.0, 2.0, 1.5, 1.0, 0.7], X)
    >>> y0 = body.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    >>> sol = lieint.integrate(body, y0, (0.0, 1.0), h=0.01, method="rk4")
    >>> bool(sol.drift("distances") < 1e-8)
    True
    """

    autonomous = True
    structure = frozenset({"atoms"})
    field_kinds = MappingProxyType({"q": "point", "v": "vector"})

    def __init__(self, masses: ArrayLike, positions: ArrayLike):
        m = as_float_array(masses, "masses")
        X = as_float_array(positions, "positions")
        if m.ndim != 1 or np.any(m <= 0):
            raise ValueError(f"`masses` must be a vector of positive numbers; got {describe(m)}.")
        if X.ndim != 2 or X.shape[0] != m.size:
            raise ValueError(f"`positions` must have shape (N, n) with N = {m.size} atoms; got shape {X.shape}.")
        N, n = X.shape
        if n < 2 or N < n + 1:
            raise ValueError(
                f"`positions` must hold N ≥ n + 1 atoms in n ≥ 2 dimensions (a body spanning Rⁿ); got N = {N}, n = {n}."
            )
        self.masses, self.N, self.n = m, N, n
        self.total_mass = float(m.sum())
        centre = m @ X / self.total_mass
        self.body_positions = X - centre  # Xᵢ about the centre of mass
        self.mass_tensor = np.einsum("i,ij,ik->jk", m, self.body_positions, self.body_positions)
        if np.linalg.matrix_rank(self.mass_tensor) < n:
            raise ValueError("`positions` must span Rⁿ: the atoms lie in a hyperplane (the mass tensor is singular).")
        self.pairs = reaction_pairs(N, n)
        self._inertia = InertiaOperator(self.mass_tensor, "mass tensor of the atoms")
        self._coupling = self._coupling_matrix()
        self._incidence = np.zeros((len(self.pairs), N))
        self._incidence[np.arange(len(self.pairs)), self.pairs[:, 0]] = 1.0
        self._incidence[np.arange(len(self.pairs)), self.pairs[:, 1]] = -1.0
        self.fields = {"q": (N, n), "v": (N, n)}
        self.group = ProductGroup(VectorSpace((N, n)), VectorSpace((N, n)))
        # the reactions must be determined at the body's own shape (the seed proves it generically)
        _, s, _ = np.linalg.svd(self._system_matrix(self.body_positions))
        if s[-1] <= 1e-10 * s[0]:
            raise ValueError(
                "`positions`: the reactions on the pairs S are not determined for this body (singular linear system; "
                "the first n atoms must span a hyperplane not containing the others)."
            )
        self._pair_index = np.triu_indices(N, 1)
        Xi, Xj = self.body_positions[self._pair_index[0]], self.body_positions[self._pair_index[1]]
        self._distances = np.linalg.norm(Xi - Xj, axis=-1)

    # -- reactions ----------------------------------------------------------------------
    def _coupling_matrix(self) -> np.ndarray:
        """``C[row, s]``: how σ_s enters ``rᵢ − rⱼ`` along ``u_s = q_b − q_a`` for row ``(i, j)``."""
        P, m = self.pairs, self.masses
        i, j = P[:, 0][:, None], P[:, 1][:, None]
        a, b = P[:, 0][None, :], P[:, 1][None, :]
        return ((i == a).astype(float) - (j == a)) / m[a] - ((i == b).astype(float) - (j == b)) / m[b]

    def _system_matrix(self, q: np.ndarray) -> np.ndarray:
        P = self.pairs
        d = q[..., P[:, 0], :] - q[..., P[:, 1], :]  # q_i − q_j per pair
        gram = d @ np.swapaxes(d, -1, -2)  # ⟨d_row, d_s⟩; u_s = −d_s
        return -gram * self._coupling

    def tensions(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The σ on the pairs S at the state ``(q, q̇)``.

        Parameters
        ----------
        q, v : ndarray, shape (..., N, n)
            Positions and velocities of the atoms.

        Returns
        -------
        ndarray, shape ``(..., |S|)``
            σ on each pair of :attr:`pairs`.
        """
        P = self.pairs
        dv = v[..., P[:, 0], :] - v[..., P[:, 1], :]
        rhs = -np.sum(dv * dv, axis=-1)
        return np.linalg.solve(self._system_matrix(q), rhs[..., None])[..., 0]

    def reactions(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The central reactions ``Rᵢ = Σₖ σᵢₖ (qₖ − qᵢ)``.

        Parameters
        ----------
        q, v : ndarray, shape (..., N, n)
            Positions and velocities of the atoms.

        Returns
        -------
        ndarray, shape (..., N, n)
            The reaction on each atom.
        """
        P = self.pairs
        sigma = self.tensions(q, v)
        u = q[..., P[:, 1], :] - q[..., P[:, 0], :]  # q_b − q_a
        # σ_s (q_b − q_a) acts on a, its opposite on b: equal and opposite along the line ab
        return np.einsum("...sk,sa->...ak", sigma[..., None] * u, self._incidence)

    # -- the LieGroupSystem contract ---------------------------------------------------
    def generator(self, t: float | np.ndarray, y: State) -> np.ndarray | tuple[np.ndarray, ...]:
        return (y["v"], self.reactions(y["q"], y["v"]) / self.masses[:, None])

    def act(self, g: np.ndarray | tuple[np.ndarray, ...], y: State) -> State:
        return {"q": y["q"] + g[0], "v": y["v"] + g[1]}

    def infinitesimal_action(self, xi: np.ndarray | tuple[np.ndarray, ...], y: State) -> State:
        return {"q": xi[0], "v": xi[1]}

    def project(self, y: State) -> State:
        """The nearest rigid state in the mass-weighted norm: ``qᵢ ← q_G + R Xᵢ`` with R the
        rotation nearest to ``Σ mᵢ (qᵢ − q_G) Xᵢᵀ`` (polar factor), then ``q̇ᵢ ← v_G + ω (qᵢ − q_G)``
        with ω from the momentum ``a = −(bω + ωb)``, ``b = R B Rᵀ`` (the least-squares rigid
        velocity). The centre of mass, its velocity and a are kept.

        Parameters
        ----------
        y : dict of ndarray
            A state ``{"q", "v"}``, nearly rigid.

        Returns
        -------
        dict of ndarray
            The rigid state.
        """
        q, v = y["q"], y["v"]
        qG, vG = self.centre_of_mass(q), self.centre_of_mass(v)
        d = q - qG[..., None, :]
        R = project_to_so(np.einsum("i,...ij,ik->...jk", self.masses, d, self.body_positions))
        Y = np.einsum("...jk,ik->...ij", R, self.body_positions)
        a = np.einsum("i,...ijk->...jk", self.masses, wedge(Y, v - vG[..., None, :]))
        Rt = np.swapaxes(R, -1, -2)
        w = R @ self._inertia.angular_velocity(Rt @ a @ R) @ Rt
        return {"q": qG[..., None, :] + Y, "v": vG[..., None, :] + np.einsum("...jk,...ik->...ij", w, Y)}

    # -- rigid-body quantities ---------------------------------------------------------
    def centre_of_mass(self, q: np.ndarray) -> np.ndarray:
        """The mass-weighted mean ``Σ mᵢ qᵢ / M`` (of positions, or of velocities).

        Parameters
        ----------
        q : ndarray, shape (..., N, n)
            Positions (or velocities) of the atoms.

        Returns
        -------
        ndarray, shape (..., n)
            The centre of mass (or its velocity).
        """
        return np.einsum("i,...ik->...k", self.masses, q) / self.total_mass

    def rotation(self, q: np.ndarray) -> np.ndarray:
        """R with ``qᵢ − q_G = R Xᵢ`` (exact for a rigid state): ``R = (Σ mᵢ (qᵢ − q_G) Xᵢᵀ) B⁻¹``.

        Parameters
        ----------
        q : ndarray, shape (..., N, n)
            Positions of the atoms.

        Returns
        -------
        ndarray, shape (..., n, n)
            R (body to space; in SO(n) for a rigid state).
        """
        d = q - self.centre_of_mass(q)[..., None, :]
        M = np.einsum("i,...ij,ik->...jk", self.masses, d, self.body_positions)
        return M @ np.linalg.inv(self.mass_tensor)

    def space_momentum(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``a = Σ mᵢ (qᵢ − q_G) ∧ (q̇ᵢ − q̇_G)``, the momentum about the centre of mass.

        Parameters
        ----------
        q, v : ndarray, shape (..., N, n)
            Positions and velocities of the atoms.

        Returns
        -------
        ndarray, shape (..., n, n)
            The space momentum bivector a.
        """
        d = q - self.centre_of_mass(q)[..., None, :]
        w = v - self.centre_of_mass(v)[..., None, :]
        return np.einsum("i,...ijk->...jk", self.masses, wedge(d, w))

    def body_momentum(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``A = Rᵀ a R`` (the Euler top's state field).

        Parameters
        ----------
        q, v : ndarray, shape (..., N, n)
            Positions and velocities of the atoms.

        Returns
        -------
        ndarray, shape (..., n, n)
            The body momentum bivector A.
        """
        R = self.rotation(q)
        return np.swapaxes(R, -1, -2) @ self.space_momentum(q, v) @ R

    def energy(self, y: State) -> np.ndarray:
        """Kinetic energy ``½ Σ mᵢ |q̇ᵢ|²``.

        Parameters
        ----------
        y : dict of ndarray
            States ``{"q", "v"}`` (any leading shape).

        Returns
        -------
        ndarray
            The energy per state.
        """
        v = y["v"]
        return 0.5 * np.einsum("i,...ik,...ik->...", self.masses, v, v)

    @property
    def invariants(self) -> dict[str, Invariant]:
        m = self.masses
        iu, ju = self._pair_index

        def distances(t, y):
            q = y["q"]
            return np.linalg.norm(q[..., iu, :] - q[..., ju, :], axis=-1) - self._distances

        return {
            "energy": Invariant(lambda t, y: self.energy(y), "integral", "½ Σ mᵢ |q̇ᵢ|²"),
            "linear_momentum": Invariant(lambda t, y: np.einsum("i,...ik->...k", m, y["v"]), "integral", "Σ mᵢ q̇ᵢ"),
            "angular_momentum": Invariant(
                lambda t, y: np.einsum("i,...ijk->...jk", m, wedge(y["q"], y["v"])), "integral", "Σ mᵢ qᵢ ∧ q̇ᵢ"
            ),
            "distances": Invariant(distances, "defect", "|qᵢ − qⱼ| − |Xᵢ − Xⱼ| over all pairs"),
        }

    @property
    def outputs(self) -> dict[str, Output]:
        N, n = self.N, self.n
        out = dict(super().outputs)
        out["reactions"] = Output(
            lambda t, y: self.reactions(y["q"], y["v"]), (N, n), "central reactions Rᵢ = Σₖ σᵢₖ (qₖ − qᵢ)", "vector"
        )
        out["R"] = Output(lambda t, y: self.rotation(y["q"]), (n, n), "rotation R with qᵢ − q_G = R Xᵢ", "rotation")
        out["A"] = Output(
            lambda t, y: self.body_momentum(y["q"], y["v"]), (n, n), "body momentum A = Rᵀ a R", "bivector"
        )
        return out

    # -- states ------------------------------------------------------------------------
    def initial_state(
        self,
        *,
        R: ArrayLike | Rotation | None = None,
        Omega: ArrayLike | None = None,
        angular_velocity: ArrayLike | None = None,
        center: ArrayLike | None = None,
        velocity: ArrayLike | None = None,
    ) -> State:
        """Atoms of a rigid motion: ``qᵢ = q_G + R Xᵢ``, ``q̇ᵢ = v_G + R Ω Xᵢ``.

        Parameters
        ----------
        R : array_like, shape (..., n, n), or scipy Rotation, optional
            Orientation, body to space (default: the identity).
        Omega : array_like, shape (..., n, n), optional
            Body angular velocity bivector (give it or ``angular_velocity``).
        angular_velocity : array_like, shape (..., 3), optional
            n = 3: the body angular velocity vector w.
        center : array_like, shape (..., n), optional
            The centre of mass ``q_G`` (default: the origin).
        velocity : array_like, shape (..., n), optional
            Its velocity ``v_G`` (default: at rest).

        Returns
        -------
        dict of ndarray
            ``{"q": (*batch, N, n), "v": (*batch, N, n)}``.
        """
        n = self.n
        top = EulerTop(self.mass_tensor, orientation=True)
        s = top.initial_state(Omega=Omega, R=R, angular_velocity=angular_velocity)
        Om = top.angular_velocity(s["A"])
        Rm = s["R"]
        c = np.zeros(n) if center is None else check_vector(center, "center", n, batch=True)
        vc = np.zeros(n) if velocity is None else check_vector(velocity, "velocity", n, batch=True)
        X = self.body_positions
        q = c[..., None, :] + np.einsum("...jk,ik->...ij", Rm, X)
        v = vc[..., None, :] + np.einsum("...jk,ik->...ij", Rm @ Om, X)
        batch = np.broadcast_shapes(q.shape[:-2], v.shape[:-2])
        return {
            "q": np.broadcast_to(q, batch + (self.N, n)).copy(),
            "v": np.broadcast_to(v, batch + (self.N, n)).copy(),
        }

    def euler_top(self) -> EulerTop:
        """The Euler top with ``B = Σ mᵢ XᵢXᵢᵀ`` these atoms should move as.

        Returns
        -------
        EulerTop
            The top, with its orientation.
        """
        return EulerTop(self.mass_tensor, orientation=True)

    def __repr__(self) -> str:
        return f"AtomsBody(N={self.N}, n={self.n}, masses={describe(self.masses)})"
