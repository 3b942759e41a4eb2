"""The count toward integrability (docs/theory.md §7) and the Frobenius test (docs/theory.md §9):
the numbers of theory §7 reproduced exactly at random generic states."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_rotation, random_skew

import lieint
from lieint.analysis import (
    Distribution,
    constraint_of,
    integrability_count,
    is_holonomic,
    numerical_rank,
    rolling_constraint,
)


def generic_top(rng, n):
    top = lieint.EulerTop(np.diag(np.sort(rng.uniform(0.5, 2.0, n))))
    return top, top.initial_state(Omega=random_skew(rng, n), R=random_rotation(rng, n))


def generic_chaplygin(rng, n):
    ball = lieint.ChaplyginBall(np.diag(rng.uniform(0.1, 0.3, n)), 1.0, 1.0)
    return ball, ball.initial_state(Omega=random_skew(rng, n), R=random_rotation(rng, n))


# -- docs/theory.md §7: the reduction equations --------------------------------------------------------


@pytest.mark.parametrize(
    "n, equation, rank, isotropy",
    [
        (3, "6 − 1 − 3 − 1 = 1", 4, 1),
        (4, "12 − 1 − 6 − 2 = 3", 7, 2),
        (5, "20 − 1 − 10 − 2 = 7", 11, 2),
    ],
)
def test_euler_top_counts(rng, n, equation, rank, isotropy):
    top, y = generic_top(rng, n)
    count = integrability_count(top, y)
    assert count.equation() == equation
    assert count.integrals == rank and count.isotropy == isotropy
    # the decisions are clear: a wide gap between kept and dropped singular values
    assert count.jacobian_rank.kept > 1e-4 and count.jacobian_rank.dropped < 1e-9
    assert count.isotropy_rank.kept > 1e-2 and count.isotropy_rank.dropped < 1e-12


def test_euler_top_4d_with_schottky_frahm_is_integrable(rng):
    top, y = generic_top(rng, 4)
    count = integrability_count(top, y, integrals="manakov")
    # docs/theory.md §7: 12 − 1 − 6 − 2 − 1 − 1 = 1 (Schottky's integral, then its Hamiltonian flow),
    # the same as 12 − 8 − 2 − 1 = 1
    assert count.equation() == "12 − 1 − 6 − 2 − 1 − 1 = 1"
    assert count.integrals == 8 and count.extra_integrals == 1
    assert 12 - 8 - 2 - 1 == count.result == 1


def test_euler_top_5d_manakov_family(rng):
    top, y = generic_top(rng, 5)
    count = integrability_count(top, y, integrals="manakov")
    assert count.extra_integrals == 3 and count.result == 1


def test_chaplygin_ball_3d_count(rng):
    ball, y = generic_chaplygin(rng, 3)
    count = integrability_count(ball, y)
    assert count.equation() == "8 − 1 − 3 − 2 − 1 = 1"
    assert count.measure == 1 and count.isotropy == 2


def test_chaplygin_ball_4d_count_and_its_arithmetic(rng):
    ball, y = generic_chaplygin(rng, 4)
    count = integrability_count(ball, y)
    assert count.terms() == [15, 1, 6, 3, 1]
    # docs/theory.md §7: the source writes "15 − 1 − 6 − 3 − 1 = 3"; the terms it names sum to 4
    assert 15 - 1 - 6 - 3 - 1 == 4 != 3
    assert count.result == 4 and count.equation() == "15 − 1 − 6 − 3 − 1 = 4"


def test_isotropy_is_larger_at_a_special_state():
    """A momentum a with a double eigenvalue pair in n = 4 (a ∝ e₁∧e₂ + e₃∧e₄) is kept by
    u(2), dimension 4, not by SO(2) × SO(2): the count detects non-generic states."""
    top = lieint.EulerTop(np.diag([0.5, 1.0, 1.7, 2.3]))
    A = np.zeros((4, 4))
    A[0, 1], A[2, 3] = 1.0, 1.0
    A = A - A.T
    count = integrability_count(top, {"A": A, "R": np.eye(4)})
    assert count.isotropy == 4


def test_particle_in_a_central_field_count(rng):
    p = lieint.CentralForceParticle(1.0, [0.0, 0.1, 0.0], "kepler")
    count = integrability_count(p, p.initial_state(position=[1.0, 0.2, 0.0], velocity=[0.1, 1.0, 0.3]))
    assert count.equation() == "6 − 1 − 3 − 1 = 1"


@pytest.mark.parametrize("n, equation", [(3, "4 − 1 − 1 − 1 = 1"), (4, "6 − 1 − 3 − 1 = 1")])
def test_particle_on_a_surface_of_revolution_count(n, equation):
    """Clairaut's integral makes the particle on a surface of revolution integrable."""
    e = np.eye(n)[-1]
    egg = lieint.systems.SurfaceOfRevolution([0.0, 0.0, 1.0, 0.3], e)
    p = lieint.SurfaceParticle(1.0, egg, -e)
    v = np.zeros(n)
    v[1:-1] = [0.8, 0.3][: n - 2]
    y = p.initial_state(position=egg.point(np.eye(n)[0] + 0.2 * e), velocity=v)
    assert integrability_count(p, y).equation() == equation
    # no axis of symmetry (an ellipsoid): no chart, a clear refusal
    q = lieint.SurfaceParticle(1.0, lieint.systems.Ellipsoid([1.0, 2.0, 3.0]))
    with pytest.raises(ValueError, match="`system`: the count needs a chart"):
        integrability_count(q, q.initial_state(position=[1.0, 0.0, 0.0]))


def test_report_prints_the_reduction_equation(rng, capsys):
    top, y = generic_top(rng, 3)
    integrability_count(top, y, verbose=True)
    out = capsys.readouterr().out
    assert "Euler top n = 3: 6 − 1 − 3 − 1 = 1" in out and "threshold 1e-07" in out
    assert "dim{ξ ∈ so(3) : [ξ, a] = 0}" in out


def test_count_errors_name_the_argument(rng):
    top, y = generic_top(rng, 3)
    with pytest.raises(ValueError, match="`integrals` must be"):
        integrability_count(top, y, integrals="all")
    ball, yb = generic_chaplygin(rng, 3)
    with pytest.raises(ValueError, match="applies to an EulerTop"):
        integrability_count(ball, yb, integrals="manakov")
    body = lieint.HeavyTop(np.eye(3), 1.0, [0, 0, 0.1], [0, 0, -1.0])
    with pytest.raises(ValueError, match="`system`: the count needs a chart"):
        integrability_count(body, {})
    batch = {k: np.stack([v, v]) for k, v in y.items()}
    with pytest.raises(ValueError, match="one state"):
        integrability_count(top, batch)


def test_numerical_rank_states_its_threshold():
    M = np.diag([1.0, 1e-3, 1e-9])
    r = numerical_rank(M, 1e-7)
    assert (r.rank, r.kept, r.dropped) == (2, 1e-3, 1e-9)
    assert numerical_rank(M, 1e-10).rank == 3


# -- docs/theory.md §9: holonomic or not ------------------------------------------------------------


def test_rolling_ball_is_nonholonomic():
    r = is_holonomic(rolling_constraint(3, radius=0.7))
    assert not r.holonomic
    assert (r.distribution_dimension, r.closure_dimension, r.configuration_dimension) == (3, 5, 5)
    assert r.depth == 1


def test_rolling_ball_4d_is_nonholonomic():
    r = is_holonomic(rolling_constraint(4))
    assert not r.holonomic and (r.distribution_dimension, r.closure_dimension) == (6, 9)


def test_rolling_disk_on_a_line_is_holonomic():
    r = is_holonomic(rolling_constraint(2))
    assert r.holonomic and (r.distribution_dimension, r.closure_dimension, r.configuration_dimension) == (1, 1, 2)
    assert "the true configuration space has dimension 1" in r.report()


def test_heisenberg_distribution_brackets_out_and_a_foliation_does_not():
    # the contact distribution {∂x, ∂y + x ∂z}: [X, Y] = ∂z, nonholonomic
    X = lambda p: np.array([1.0, 0.0, 0.0])  # noqa: E731
    Y = lambda p: np.array([0.0, 1.0, p[0]])  # noqa: E731
    r = is_holonomic(Distribution("Heisenberg", np.array([0.3, -0.2, 0.5]), (X, Y), 3))
    assert not r.holonomic and r.closure_dimension == 3
    # tangent to the spheres |x| = const: brackets nonzero but inside the distribution
    Z = [lambda p, k=k: np.cross(np.eye(3)[k], p) for k in range(3)]
    r = is_holonomic(Distribution("rotations", np.array([0.3, -0.2, 0.5]), tuple(Z), 3))
    assert r.holonomic and r.distribution_dimension == r.closure_dimension == 2


def test_constraints_of_the_systems():
    p = lieint.SurfaceParticle(1.0, lieint.systems.SurfaceOfRevolution([0, 0, 1, 0.3], [0, 0, 1]))
    q = p.surface.point([1.0, 0.5, 0.3])
    r = is_holonomic(constraint_of(p, {"q": q, "v": np.zeros(3)}))
    assert r.holonomic and (r.distribution_dimension, r.configuration_dimension) == (2, 3)
    body = lieint.AtomsBody([1.0, 2.0, 1.0, 1.5], [[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, -1, -1]])
    r = is_holonomic(constraint_of(body, body.initial_state(angular_velocity=[0.1, 0.2, 0.3])))
    assert r.holonomic and (r.distribution_dimension, r.configuration_dimension) == (6, 12)
    top = lieint.EulerTop(np.diag([1.0, 2.0, 3.0]))
    r = is_holonomic(constraint_of(top))
    assert r.holonomic and r.distribution_dimension == r.configuration_dimension == 3
    ball = lieint.RollingBall(np.diag([0.1, 0.15, 0.2]), 1.0, 1.0, [0, 0.1, -0.2], [0, 0, -9.81])
    assert not is_holonomic(constraint_of(ball)).holonomic
    with pytest.raises(TypeError, match="`constraint` must be a Distribution"):
        is_holonomic("rolling")
