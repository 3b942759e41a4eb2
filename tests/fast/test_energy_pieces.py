"""The compiled energy pieces (what the energy-keeping pairs move every step onto) against each
system's own energy, on random states of every built-in variant with compiled pieces."""

from __future__ import annotations

import numpy as np
import pytest
from bodies import initial, variants

from lieint.fast.engine import _orbit_numbers, _PiecesLayout, _vector_factors, orbit_parts

CASES = {f"{name} n={n}": system for n in (3, 4) for name, system in variants(n).items()}


@pytest.mark.parametrize("label", sorted(CASES))
def test_the_compiled_energy_is_the_systems(label):
    system = CASES[label]
    if "energy" not in system.invariants:
        pytest.skip("no conserved energy declared (a tilted ball that does not track its centre)")
    layout = _PiecesLayout(system.compiled(), system)
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
    layout = _PiecesLayout(system.compiled(), system)
    flat = _orbit_numbers(_vector_factors(system.group), layout.n, layout.nv, layout.m)
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
