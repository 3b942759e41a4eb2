"""The compiled energy pieces (what the energy-keeping pairs move every step onto) against each
system's own energy, on random states of every built-in variant with compiled pieces."""

from __future__ import annotations

import numpy as np
import pytest
from bodies import initial, variants

from lieint.fast.layouts import PiecesLayout, orbit_numbers, orbit_parts, vector_factors

CASES = {f"{name} n={n}": system for n in (3, 4) for name, system in variants(n).items()}


@pytest.mark.parametrize("label", sorted(CASES))
def test_the_compiled_energy_is_the_systems(label):
    system = CASES[label]
    if "energy" not in system.invariants:
        pytest.skip("no conserved energy declared (a tilted ball that does not track its centre)")
    layout = PiecesLayout(system.compiled(), system)
    energy = layout.pieces.energy
    rng = np.random.default_rng(7)
    for _ in range(3):
        y = initial(system, rng)
        if "Gamma" in y:  # a tilted Γ, not the default's vertical one
            g = rng.normal(size=system.n)
            y["Gamma"] = g / np.linalg.norm(g) * np.linalg.norm(y["Gamma"])
        for name in ("center", "velocity"):
            if name in y:
                y[name] = rng.normal(size=y[name].shape)
        flat = layout.start(y, 1)[0]
        work = np.zeros(max(layout.work, 1))
        expected = float(system.invariants["energy"](0.0, y))
        got = energy(flat, layout.params, work)
        assert abs(got - expected) <= 1e-13 * max(1.0, abs(expected)), (label, got, expected)


@pytest.mark.parametrize("label", ["free_body n=3", "rolling_ball/offset n=4", "heavy_top n=3"])
def test_the_orbit_basis_is_the_generic_paths(label):
    """The compiled pieces' basis of the algebra, flat ``(W, v, a)``, is the generic path's
    (:func:`lieint.methods.energy_projection.algebra_basis`) element by element, and its group
    elements are ``exp(±ε e_i)``."""
    from lieint.methods.energy_projection import algebra_basis

    system = CASES[label]
    layout = PiecesLayout(system.compiled(), system)
    flat = orbit_numbers(vector_factors(system.group), layout.n, layout.nv, layout.m)
    W, v, a, Q, t, _shift = orbit_parts(flat, layout.n, layout.nv, layout.m)
    basis = algebra_basis(system.group)
    parts = basis if isinstance(basis, tuple) else (basis,)
    pose = parts[0]
    n = layout.n
    if layout.nv:  # SE(n): the homogeneous matrices
        np.testing.assert_array_equal(W, pose[:, :n, :n])
        np.testing.assert_array_equal(v, pose[:, :n, n])
    else:
        np.testing.assert_array_equal(W, pose)
    rest = [p.reshape(len(p), -1) for p in parts[1:]]
    np.testing.assert_array_equal(a, np.concatenate(rest, axis=1) if rest else np.zeros((len(W), 0)))
    exp = system.group.exp
    for i in range(len(W)):
        for side, sign in ((0, 1.0), (1, -1.0)):
            element = tuple(sign * 1e-6 * p[i] for p in parts)
            g = exp(element if isinstance(basis, tuple) else element[0])
            pose_g = g[0] if isinstance(basis, tuple) else g
            np.testing.assert_allclose(Q[side, i], pose_g[:n, :n], rtol=0, atol=1e-15)
            if layout.nv:
                np.testing.assert_allclose(t[side, i], pose_g[:n, n], rtol=0, atol=1e-15)


_OMEGA0 = np.array([[0.0, -0.3, 0.2], [0.3, 0.0, -1.0], [-0.2, 1.0, 0.0]])
_S = np.array([[0.0, 0.5, -0.1], [-0.5, 0.0, 0.7], [0.1, -0.7, 0.0]])


def _spinner_energy(y):
    """``H = ⟨R Ω₀ Rᵀ, S⟩``: the spatial rate is constant along ``Ṙ = RΩ₀``, so H is an integral."""
    R = y["R"]
    return np.einsum("...ij,ij->...", R @ _OMEGA0 @ np.swapaxes(R, -1, -2), _S)


def _spinner(with_energy: bool):
    """A system from outside the package with compiled pieces (``Ṙ = RΩ₀`` on SO(3)), whose pieces
    declare its energy or not."""
    from numba import njit

    import lieint
    from lieint.fast.forms import PiecesForm
    from lieint.fast.pieces import ACTION, ENERGY, FIELD, GENERATOR, CompiledPieces
    from lieint.systems.base import Invariant

    @njit(GENERATOR)
    def generator(y, par, W, v, a, work):
        for i in range(3):
            for j in range(3):
                W[i, j] = par[1 + 3 * i + j]

    @njit(ACTION)
    def action(Q, t, a, y, par, out, work):
        for i in range(3):
            for j in range(3):
                out[3 * i + j] = y[3 * i] * Q[0, j] + y[3 * i + 1] * Q[1, j] + y[3 * i + 2] * Q[2, j]

    @njit(FIELD)
    def field(y, par, out, work):
        out[:] = (y.reshape(3, 3) @ par[1:10].reshape(3, 3)).reshape(9)

    @njit(FIELD)
    def projection(y, par, out, work):
        out[:] = y

    @njit(ENERGY)
    def energy(y, par, work):
        R, Om, S = y.reshape(3, 3), par[1:10].reshape(3, 3), par[10:19].reshape(3, 3)
        return float(np.sum((R @ Om @ R.T) * S))

    pieces = CompiledPieces(generator, action, field, projection, energy=energy if with_energy else None)

    class Spinner(lieint.LieGroupSystem):
        autonomous = True

        def __init__(self):
            self.group = lieint.groups.SO(3)
            self.fields = {"R": (3, 3)}

        def generator(self, t, y):
            return np.broadcast_to(_OMEGA0, y["R"].shape)

        def act(self, g, y):
            return {"R": y["R"] @ g}

        def infinitesimal_action(self, xi, y):
            return {"R": y["R"] @ xi}

        @property
        def invariants(self):
            return {"energy": Invariant(lambda t, y: _spinner_energy(y), "integral", "⟨R Ω₀ Rᵀ, S⟩")}

        def compiled(self):
            params = np.concatenate([[3.0], _OMEGA0.ravel(), _S.ravel()])
            return PiecesForm(pieces, params, 3, False, 0, self.fields)

    return Spinner()


@pytest.mark.slow  # numba compiles the system's own pieces (~30 s on a busy two-core machine)
def test_a_system_outside_the_package_runs_the_energy_pairs_compiled_when_its_pieces_declare_the_energy():
    from scipy.linalg import expm

    import lieint

    y0 = {"R": np.eye(3)}
    kw = dict(method="rkmk45+energy", rtol=1e-8, atol=1e-11)
    without = lieint.integrate(_spinner(False), y0, (0.0, 1.0), **kw)
    assert without.stats.backend == "numpy"
    assert "its compiled pieces declare no energy" in without.stats.backend_reason
    system = _spinner(True)
    fast = lieint.integrate(system, y0, (0.0, 1.0), **kw)
    assert fast.stats.backend == "numba" and "energy kept" in fast.stats.backend_reason
    assert fast.stats.nsteps == without.stats.nsteps
    exact = expm(_OMEGA0)  # R(1) = R₀ exp(Ω₀)
    assert np.max(np.abs(fast.states["R"][-1] - exact)) < 1e-7
    assert np.max(np.abs(fast.states["R"][-1] - without.states["R"][-1])) < 1e-7
