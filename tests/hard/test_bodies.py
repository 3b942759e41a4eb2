"""Degenerate bodies: flat (one zero b_i), nearly a rod (b_i + b_j → 0), nearly symmetric."""

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import solve_continuous_lyapunov

import lieint

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from conftest import fitted_slope, random_rotation, random_skew

pytestmark = pytest.mark.hard


def test_flat_plate_n3_against_the_exact_solution(record):
    # b = (1, 1.5, 0): a plate, I = (1.5, 1, 2.5) with I₃ = I₁ + I₂
    top = lieint.EulerTop(np.diag([1.0, 1.5, 0.0]))
    y0 = top.initial_state(angular_velocity=[0.4, 1.0, -0.3])
    exact = top.exact_solution([5.0], y0)["A"][-1]
    hs = [0.04, 0.02, 0.01]
    errs = [np.linalg.norm(lieint.integrate(top, y0, (0, 5), h=h, method="rkmk4").states["A"][-1] - exact) for h in hs]
    slope = fitted_slope(hs, errs)
    record("plate n=3: fitted RKMK4 order", slope, "exact elliptic solution")
    assert abs(slope - 4) < 0.3


def test_flat_slab_n4_integrates_and_keeps_its_casimirs(record, rng):
    top = lieint.EulerTop(np.diag([0.0, 1.0, 2.0, 3.0]))
    y0 = top.initial_state(Omega=random_skew(rng, 4), R=random_rotation(rng, 4))
    ref = lieint.integrate(top, y0, (0, 5), method="scipy:DOP853", rtol=1e-13, atol=1e-13, t_eval=[0, 5])
    hs = [0.04, 0.02, 0.01]
    sols = [lieint.integrate(top, y0, (0, 5), h=h, method="rkmk4") for h in hs]
    errs = [np.linalg.norm(s.states["A"][-1] - ref.states["A"][-1]) for s in sols]
    record("slab n=4: fitted RKMK4 order", fitted_slope(hs, errs), "DOP853 at rtol 1e-13")
    record("slab n=4: Casimir drift", float(max(s.drift("casimirs") for s in sols)), "spectrum of A")
    assert abs(fitted_slope(hs, errs) - 4) < 0.3
    assert max(s.drift("casimirs") for s in sols) < 1e-13


@pytest.mark.parametrize("gap", [1e-6, 1e-8, 1e-10])
def test_nearly_a_rod_is_refused_when_unresolved_and_accurate_when_resolved(record, gap):
    """b₂ + b₃ = gap · b₁ (a symmetric near-rod, I₁ = gap): w₁ = Π₁/gap, so any error in Π₁ is
    amplified by 1/gap — the truncation error h⁵ of RKMK4 must stay well below gap. Steps that
    are too coarse spin w₁ up until a stage leaves the dexp⁻¹ radius and exponential coordinates
    refuse it with a clear error; steps with h ≲ 0.05 gap^¼ are accurate. Never NaN."""
    top = lieint.EulerTop(np.diag([1.0, gap / 2, gap / 2]))
    y0 = top.initial_state(Omega=lieint.groups.hat([0.3, 0.2, 1.0]))
    outcomes = []
    for c in (0.2, 0.05, 0.01):
        h = c * gap**0.25
        try:
            sol = lieint.integrate(top, y0, (0, 2000 * h), h=h, method="rkmk4")
        except lieint.DexpinvRangeError as exc:
            assert "Reduce the step" in str(exc)
            outcomes.append(f"h={h:.2g}: refused")
            continue
        assert np.all(np.isfinite(sol.states["A"]))
        outcomes.append(f"h={h:.2g}: energy drift {float(sol.drift('energy')):.1e}")
    record(f"rod gap {gap:g}: outcome per step (2000 steps, RKMK4)", "; ".join(outcomes), "initial energy")
    # the finest step is accurate: energy to 1e-9 and the spectrum of A to round-off
    assert "refused" not in outcomes[-1] and sol.drift("energy") < 1e-9 and sol.drift("casimirs") < 1e-12


def test_nearly_a_rod_cayley_at_large_steps_warns(rng):
    top = lieint.EulerTop(np.diag([1.0, 5e-11, 5e-11]))
    y0 = top.initial_state(Omega=lieint.groups.hat([0.3, 0.2, 1.0]))
    with pytest.warns(lieint.LieStepWarning, match="too large for this motion"):
        sol = lieint.integrate(top, y0, (0, 0.01), h=1e-3, method="rkmk4", coordinates="cayley")
    assert np.all(np.isfinite(sol.states["A"]))


def test_nearly_symmetric_body_has_a_continuous_inertia_operator(record, rng):
    """b₁ = b₂(1 + 1e-12), given in a rotated frame: eigh's basis of the near-degenerate plane is
    arbitrary, but Ω(A) must not depend on it. Truth: scipy's Lyapunov solver on BΩ + ΩB = −A."""
    Q = random_rotation(rng, 3)
    b = np.array([1.0, 1.0 + 1e-12, 2.5])
    B = Q @ np.diag(b) @ Q.T
    top = lieint.EulerTop(B)
    worst = 0.0
    for _ in range(20):
        A = random_skew(rng, 3)
        ref = solve_continuous_lyapunov(B, -A)
        worst = max(worst, float(np.max(np.abs(top.angular_velocity(A) - ref)) / np.max(np.abs(ref))))
    record("near-symmetric: max relative |Ω(A) − Lyapunov solve|", worst, "scipy solve_continuous_lyapunov")
    assert worst < 1e-12
    # and the trajectory is continuous in the body: exactly symmetric vs nearly symmetric
    sym = lieint.EulerTop(Q @ np.diag([1.0, 1.0, 2.5]) @ Q.T)
    y0 = top.initial_state(Omega=random_skew(rng, 3))
    a = lieint.integrate(top, y0, (0, 10), h=0.01, backend="numpy").states["A"]
    s = lieint.integrate(sym, y0, (0, 10), h=0.01, backend="numpy").states["A"]
    record("near-symmetric vs symmetric trajectory difference", float(np.max(np.abs(a - s))), "symmetric body")
    assert np.max(np.abs(a - s)) < 1e-10


def test_nearly_symmetric_chaplygin_ball_diagonalises_B_K_continuously(record, rng):
    B_C = np.diag([0.1, 0.1 * (1 + 1e-12), 0.15])
    ball = lieint.ChaplyginBall(B_C, 1.0, 1.0)
    worst = 0.0
    for _ in range(20):
        G = rng.normal(size=3)
        G /= np.linalg.norm(G)
        A = random_skew(rng, 3)
        ref = solve_continuous_lyapunov(ball.contact_mass_tensor(G), -A)
        worst = max(worst, float(np.max(np.abs(ball.angular_velocity(A, G) - ref)) / np.max(np.abs(ref))))
    record("near-symmetric Chaplygin: relative |Ω − Lyapunov solve|", worst, "scipy solve_continuous_lyapunov")
    assert worst < 1e-12
