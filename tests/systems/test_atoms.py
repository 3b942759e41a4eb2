"""The rigid body as atoms (docs/theory.md §8): N atoms held by central reactions move as the Euler
top with ``B = Σ mᵢ XᵢXᵢᵀ`` — an independent truth for EulerTop, compared at tight tolerance."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_skew

import lieint
from lieint.groups.bivectors import wedge
from lieint.systems.atoms import reaction_pairs

#: (n, N, bound) — both runs
#: here are DOP853 at rtol = atol = 1e-13, which resolve the comparison to about 1e-12 for any body
CASES = [(3, 6, 1e-12), (4, 7, 1e-12), (5, 9, 1e-12)]


def random_body(rng, n, N):
    return lieint.AtomsBody(rng.uniform(0.5, 2.0, size=N), rng.normal(size=(N, n)))


@pytest.mark.parametrize("n, N, stated", CASES)
def test_atoms_move_as_the_euler_top(rng, n, N, stated):
    body = random_body(rng, n, N)
    Om = random_skew(rng, n)
    vG = np.full(n, 0.3)
    y0 = body.initial_state(Omega=Om, velocity=vG)
    T = 2.0
    tight = dict(method="scipy:DOP853", rtol=1e-13, atol=1e-13, t_eval=[0.0, T])
    atoms = lieint.integrate(body, y0, (0.0, T), **tight)
    top = body.euler_top()
    ref = lieint.integrate(top, top.initial_state(Omega=Om), (0.0, T), **tight)
    q, v = atoms.states["q"][-1], atoms.states["v"][-1]
    R_top, A_top = ref.states["R"][-1], ref.states["A"][-1]
    # every atom where the top puts it: q_i = q_G(0) + v_G T + R(T) X_i
    q_top = vG * T + body.body_positions @ R_top.T
    assert np.max(np.abs(q - q_top)) <= stated
    assert np.max(np.abs(body.rotation(q) - R_top)) <= stated
    assert np.max(np.abs(body.body_momentum(q, v) - A_top)) <= stated * np.max(np.abs(A_top))
    assert atoms.drift("distances") <= 1e-12
    assert atoms.drift("angular_momentum") <= 1e-12 and atoms.drift("energy") <= 1e-12


@pytest.mark.parametrize("n, N", [(3, 6), (4, 7)])
def test_reactions_are_central_equal_and_opposite(rng, n, N):
    body = random_body(rng, n, N)
    y = body.initial_state(Omega=random_skew(rng, n), velocity=np.ones(n))
    q, v = y["q"], y["v"]
    R = body.reactions(q, v)
    scale = np.max(np.abs(R))
    assert scale > 0.1  # a rotating body needs reactions
    # no net force, no net torque about any point: internal forces along the lines joining atoms
    assert np.max(np.abs(R.sum(axis=0))) <= 1e-14 * scale * N
    torque = np.einsum("ijk->jk", wedge(q - 5.0, R))
    assert np.max(np.abs(torque)) <= 1e-13 * scale * N
    # each pair's force is σ (q_b − q_a): rebuilt from the tensions it is R exactly
    sigma = body.tensions(q, v)
    P = reaction_pairs(N, n)
    rebuilt = np.zeros_like(q)
    for s, (a, b) in enumerate(P):
        rebuilt[a] += sigma[s] * (q[b] - q[a])
        rebuilt[b] -= sigma[s] * (q[b] - q[a])
    np.testing.assert_allclose(R, rebuilt, rtol=0, atol=1e-14 * scale * N)
    # and they keep every distance: d²/dt² |q_i − q_j|² = 0 on S
    acc = R / body.masses[:, None]
    for a, b in P:
        d, dv, da = q[a] - q[b], v[a] - v[b], acc[a] - acc[b]
        assert abs(d @ da + dv @ dv) <= 1e-12 * (1 + dv @ dv)


def test_the_pairs_are_the_internal_degrees_of_freedom():
    for n, N in [(2, 3), (3, 4), (3, 6), (4, 7), (5, 9)]:
        P = reaction_pairs(N, n)
        assert len(P) == n * N - n * (n + 1) // 2
        assert np.all(P[:, 0] < n) and np.all(P[:, 0] < P[:, 1])


def test_atoms_with_rkmk4_reach_order_four_against_the_top(rng):
    body = random_body(rng, 3, 5)
    Om = random_skew(rng, 3)
    y0 = body.initial_state(Omega=Om)
    top, T = body.euler_top(), 2.0
    ref = lieint.integrate(top, top.initial_state(Omega=Om), (0.0, T), method="scipy:DOP853", rtol=1e-13, atol=1e-13)
    exact = body.body_positions @ ref.states["R"][-1].T
    hs = [0.1, 0.05, 0.025]
    runs = [lieint.integrate(body, y0, (0.0, T), h=h, method="rkmk4") for h in hs]
    errs = [np.max(np.abs(run.states["q"][-1] - exact)) for run in runs]
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert slope == pytest.approx(4.0, abs=0.3)


@pytest.mark.parametrize(
    "masses, positions, match",
    [
        ([1.0, -1.0, 1.0, 1.0], np.eye(4)[:, :3], "`masses` must be a vector of positive"),
        ([1.0, 1.0, 1.0], np.eye(3)[:, :3], "N ≥ n \\+ 1 atoms"),
        ([1.0, 1.0], [[0.0, 0.0], [1.0, 0.0]], "N ≥ n \\+ 1 atoms"),
        ([1.0] * 4, [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], "atoms lie in a hyperplane"),
        ([1.0] * 3, [[0, 0, 0], [1, 0, 0]], "`positions` must have shape"),
    ],
)
def test_bad_atoms_are_named(masses, positions, match):
    with pytest.raises(ValueError, match=match):
        lieint.AtomsBody(masses, positions)


def test_projection_is_the_nearest_rigid_state_and_keeps_the_momenta(rng):
    body = random_body(rng, 4, 6)
    y = body.initial_state(Omega=random_skew(rng, 4), velocity=[0.1, 0.2, 0.3, 0.4])
    assert np.max(np.abs(body.project(y)["q"] - y["q"])) <= 1e-14  # a rigid state is its own projection
    assert np.max(np.abs(body.project(y)["v"] - y["v"])) <= 1e-14
    noisy = {"q": y["q"] + 1e-3 * rng.normal(size=y["q"].shape), "v": y["v"] + 1e-3 * rng.normal(size=y["v"].shape)}
    p = body.project(noisy)
    inv = body.invariants
    assert np.max(np.abs(inv["distances"](0.0, p))) <= 1e-14
    # rigid velocities: ⟨qᵢ − qⱼ, q̇ᵢ − q̇ⱼ⟩ = 0 on every pair
    d, w = p["q"][:, None] - p["q"][None], p["v"][:, None] - p["v"][None]
    assert np.max(np.abs(np.sum(d * w, axis=-1))) <= 1e-14
    for name in ("linear_momentum",):
        np.testing.assert_allclose(inv[name](0.0, p), inv[name](0.0, noisy), atol=1e-14)
    np.testing.assert_allclose(body.space_momentum(p["q"], p["v"]), body.space_momentum(p["q"], noisy["v"]), atol=1e-13)
