"""Geometric algebra with clifford: the sign convention, round trips, the rotor path."""

import clifford
import numpy as np
import pytest
from conftest import random_rotation, random_skew

import lieint
from lieint import ga
from lieint.ga.exponential import rotor_exp_of_skew
from lieint.groups import SO, wedge

NS = [2, 3, 4, 5, 6]


@pytest.mark.parametrize("n", NS)
@pytest.mark.slow
def test_sign_convention_against_clifford_itself(rng, n):
    """docs/theory.md §1: the matrix of ω acts as x ↦ ½(ωx − xω), and exp(tω/2) moves x ↦ R x R̃
    with d/dt = ω × x. Computed with clifford's own operators, not lieint's product table."""
    _layout, blades = clifford.Cl(n)
    X = random_skew(rng, n)
    omega = ga.skew_to_bivector(X)
    x_vec = rng.normal(size=n)
    x = sum(c * blades[f"e{i + 1}"] for i, c in enumerate(x_vec))
    comm = 0.5 * (omega * x - x * omega)
    np.testing.assert_allclose(comm.value[1 : n + 1], X @ x_vec, atol=1e-13)
    t = 1e-6
    R = (t * omega / 2).exp()
    moved = (R * x * ~R).value[1 : n + 1]
    np.testing.assert_allclose((moved - x_vec) / t, X @ x_vec, atol=1e-5)
    # and the finite rotation exp(X) ↔ exp(ω/2), on a simple bivector θ u∧v, where clifford's
    # exp is a closed form (for non-simple bivectors in n ≥ 4 it errs by ~1e-8)
    u, v = rng.normal(size=(2, n))
    P = 1.3 * wedge(u, v) / np.linalg.norm(wedge(u, v)) * np.sqrt(2)
    R1 = (ga.skew_to_bivector(P) / 2).exp()
    np.testing.assert_allclose(ga.rotor_to_matrix(R1), SO(n).exp(P), atol=1e-12)
    np.testing.assert_allclose(rotor_exp_of_skew(P, 0.5), R1.value, atol=1e-14)


@pytest.mark.parametrize("n", NS)
def test_batched_product_matches_clifford(rng, n):
    alg = ga.algebra(n)
    a, b = rng.normal(size=(2, 3, alg.size))
    ours = alg.product(a, b)
    for i in range(3):
        ref = (alg.layout.MultiVector(a[i]) * alg.layout.MultiVector(b[i])).value
        np.testing.assert_allclose(ours[i], ref, atol=1e-12)


@pytest.mark.parametrize("n", NS)
def test_round_trips_matrix_bivector_rotor(rng, n):
    X = random_skew(rng, n, (2, 3))
    B = ga.skew_to_bivector(X)
    assert B.shape == (2, 3)
    np.testing.assert_allclose(ga.bivector_to_skew(B), X, atol=1e-15)
    Q = random_rotation(rng, n, (2, 3))
    R = ga.matrix_to_rotor(Q)
    np.testing.assert_allclose(ga.rotor_to_matrix(R), Q, atol=1e-12)
    S = ga.to_values(R)
    alg = ga.algebra(n)
    np.testing.assert_allclose(alg.product(alg.reverse(S), S)[..., 0], 1.0, atol=1e-13)
    assert np.all(S[..., 0] >= 0)  # the sign chosen by default
    single = ga.skew_to_bivector(X[0, 0])
    assert isinstance(single, clifford.MultiVector)


def test_bivector_to_skew_rejects_other_grades():
    _layout, blades = clifford.Cl(3)
    with pytest.raises(ValueError, match="expected a bivector"):
        ga.bivector_to_skew(blades["e1"] + blades["e12"])
    with pytest.raises(ValueError, match=r"`n` must be an integer in \[2, 8\]"):
        ga.algebra(9)


@pytest.mark.parametrize("n", [4, 5])
def test_rotor_normalisation_is_an_exact_projection(rng, n):
    alg = ga.algebra(n)
    S = ga.matrix_to_rotor(random_rotation(rng, n, (4,)), as_multivector=False)
    noisy = S + 1e-9 * rng.normal(size=S.shape) * (alg.grades % 2 == 0)
    P = alg.normalize(noisy)
    np.testing.assert_allclose(alg.product(alg.reverse(P), P), alg.scalar(np.ones(4)), atol=1e-15)
    assert np.max(np.abs(P - S)) < 1e-8


@pytest.mark.parametrize("n", [3, 4])
@pytest.mark.parametrize("method", ["lie_euler", "rkmk4"])
def test_rotor_path_and_matrix_path_agree_to_round_off(rng, n, method):
    B = np.diag(np.linspace(0.6, 1.8, n))
    Om, R0 = random_skew(rng, n), random_rotation(rng, n)
    mat = lieint.EulerTop(B)
    rot = ga.RotorEulerTop(B)
    a = lieint.integrate(mat, mat.initial_state(Omega=Om, R=R0), (0, 5), h=0.01, method=method, save_every=50)
    b = lieint.integrate(rot, rot.initial_state(Omega=Om, R=R0), (0, 5), h=0.01, method=method, save_every=50)
    np.testing.assert_allclose(b.states["A"], a.states["A"], atol=1e-12)
    np.testing.assert_allclose(rot.rotation_matrix(b.states["rotor"]), a.states["R"], atol=1e-12)
    assert b.drift("casimirs") < 1e-12 and b.drift("momentum") < 1e-12
    assert b.drift("rotor_defect") < 1e-13


def test_rotor_path_projection_and_cayley(rng):
    rot = ga.RotorEulerTop(np.diag([1.0, 2.0, 3.0, 4.0]))
    y0 = rot.initial_state(Omega=random_skew(rng, 4))
    sol = lieint.integrate(rot, y0, (0, 2), h=0.01, project=True)
    assert sol.drift("rotor_defect") < 1e-15
    # Cayley coordinates: the rotor of cay(X) is the normalised outer exponential of ω/2
    mat = lieint.EulerTop(rot.B)
    a = lieint.integrate(rot, y0, (0, 1), h=0.1, coordinates="cayley")
    b = lieint.integrate(
        mat, mat.initial_state(Omega=rot.system.angular_velocity(y0["A"])), (0, 1), h=0.1, coordinates="cayley"
    )
    np.testing.assert_allclose(rot.rotation_matrix(a.states["rotor"]), b.states["R"], atol=1e-14)


def test_initial_state_accepts_clifford_bivectors_and_results_convert_back(rng):
    top = lieint.EulerTop(np.diag([1.0, 2.0, 3.0, 4.0]))
    Om = random_skew(rng, 4)
    from_ga = top.initial_state(Omega=ga.skew_to_bivector(Om))
    np.testing.assert_allclose(from_ga["A"], top.initial_state(Omega=Om)["A"])
    A_ga = ga.skew_to_bivector(from_ga["A"])
    np.testing.assert_allclose(top.initial_state(A=A_ga)["A"], from_ga["A"])
    sol = lieint.integrate(top, from_ga, (0, 1), h=0.1)
    back = ga.skew_to_bivector(sol.states["A"])
    assert back.shape == (11,) and isinstance(back[0], clifford.MultiVector)
    _layout, blades = clifford.Cl(4)
    with pytest.raises(ValueError, match=r"`Omega`: expected a bivector"):
        top.initial_state(Omega=blades["e1"])
    ball = lieint.ChaplyginBall(np.diag([0.1, 0.12, 0.14]), 1.0, 1.0)
    s = ball.initial_state(Omega=ga.skew_to_bivector(lieint.groups.hat([1.0, 2.0, 3.0])))
    np.testing.assert_allclose(s["A"], ball.initial_state(angular_velocity=[1.0, 2.0, 3.0])["A"])


def test_torque_from_the_wedge_of_clifford_vectors(rng):
    _layout, blades = clifford.Cl(3)
    q = 0.3 * blades["e1"] - 0.2 * blades["e3"]
    f = -9.81 * blades["e3"]
    np.testing.assert_allclose(ga.torque(q, f), wedge([0.3, 0, -0.2], [0, 0, -9.81]), atol=1e-15)
    np.testing.assert_allclose(ga.torque(q, f, origin=q), 0.0)
    # the heavy top's gravity torque M X_G ∧ Γ is the torque of the weight applied at X_G
    top = lieint.HeavyTop(np.diag([1.0, 2.0, 3.0]), 2.0, [0.1, -0.2, 0.3], [0, 0, -9.81])
    y = top.initial_state(R=random_rotation(rng, 3), angular_velocity=[0.0, 0.0, 0.0])
    dA = top.vector_field(0.0, y)["A"]  # Ω = 0: Ȧ is the torque alone
    np.testing.assert_allclose(dA, ga.torque(top.center_of_mass, top.mass * y["Gamma"]), atol=1e-14)
    batch = ga.wedge_vectors(rng.normal(size=(5, 4)), rng.normal(size=(5, 4)))
    assert batch.shape == (5, 4, 4)
