"""Fast spin (‖hΩ‖ from 0.1 past π), large and small n, extreme scales."""

import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

import lieint
from lieint.groups import SO

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from conftest import random_skew

pytestmark = pytest.mark.hard


@pytest.mark.parametrize("n", [3, 4, 6])
def test_exp_stays_exact_and_cayley_orthogonal_at_any_angle(record, rng, n):
    G = SO(n)
    worst_exp, worst_cay = 0.0, 0.0
    for theta in (0.1, 1.0, 3.0, np.pi + 0.1, 5.0, 10.0, 100.0):
        X = random_skew(rng, n)
        X *= theta / np.linalg.norm(X, 2)
        worst_exp = max(worst_exp, float(np.max(np.abs(G.exp(X) - expm(X)))))
        C = G.cay(X)
        worst_cay = max(worst_cay, float(np.max(np.abs(C.T @ C - np.eye(n)))))
    record(f"n={n}: max |exp − scipy expm| for ‖X‖ ≤ 100", worst_exp, "scipy.linalg.expm")
    record(f"n={n}: max Cayley orthogonality defect for ‖X‖ ≤ 100", worst_cay, "RᵀR = I")
    assert worst_exp < 1e-12 * 100 and worst_cay < 1e-13


def test_fast_spin_step_sweep(record):
    """A 3D top spinning at |w| = 1 with h from 0.1 to 7: accurate while h|w| is small, warned
    past π, refused by exponential coordinates past the series radius 2π, never NaN."""
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.6, 0.0, 0.8])
    rows = []
    for h in (0.1, 0.5, 1.0, 2.0, 3.0, np.pi + 0.1, 5.0, 7.0):
        for coords in ("exp", "cayley"):
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    sol = lieint.integrate(top, y0, (0, 70.0), h=h, method="rkmk4", coordinates=coords, backend="numpy")
                except lieint.DexpinvRangeError:
                    rows.append(f"{coords} h={h:.2g}: refused")
                    assert coords == "exp" and h > 2.0
                    continue
            assert sol.success and np.all(np.isfinite(sol.states["A"]))
            assert np.max(sol.invariants["orthogonality"]) < 1e-13  # on SO(3) at every step size
            warned = any(issubclass(w.category, lieint.LieStepWarning) for w in caught)
            if h * 1.0 * 1.2 > np.pi:  # |w| ≤ 1.2 on this orbit
                assert warned
            rows.append(f"{coords} h={h:.2g}: E drift {float(sol.drift('energy')):.1e}{' (warned)' if warned else ''}")
    record("h sweep, |w| = 1 (RKMK4)", "; ".join(rows), "initial energy; SO(3)")


@pytest.mark.parametrize("n", [32, 64])
def test_large_n_cost_and_invariants(record, rng, n):
    top = lieint.EulerTop(np.diag(rng.uniform(0.5, 2.0, n)))
    y0 = top.initial_state(Omega=0.2 * random_skew(rng, n), R=np.eye(n))
    t0 = time.process_time()
    sol = lieint.integrate(top, y0, (0, 1.0), h=0.01, method="rkmk4", save_every=10)
    per_step = (time.process_time() - t0) / sol.nsteps
    record(f"n={n}: CPU per RKMK4 step [ms]", per_step * 1e3, "process time")
    record(
        f"n={n}: Casimir drift / energy drift over 100 steps",
        f"{float(sol.drift('casimirs')):.1e} / {float(sol.drift('energy')):.1e}",
        "spectrum of A; energy",
    )
    assert sol.drift("casimirs") < 1e-12 and sol.drift("momentum") < 1e-12


def test_n2_so2_is_abelian(rng):
    top = lieint.EulerTop(np.diag([0.0, 2.0]))  # even a flat 2D body
    Om = random_skew(rng, 2)
    sol = lieint.integrate(top, top.initial_state(Omega=Om), (0, 100), h=0.5, method="rkmk6")
    np.testing.assert_allclose(sol.states["A"], np.broadcast_to(top.momentum(Om), sol.states["A"].shape), atol=1e-14)
    np.testing.assert_allclose(sol.states["R"][-1], SO(2).exp(100 * Om), atol=1e-12)


@pytest.mark.parametrize("mass_scale", [1e-6, 1.0, 1e6])
@pytest.mark.parametrize("speed", [1e-8, 1.0, 1e4])
def test_extreme_scales_are_exact_rescalings(record, mass_scale, speed):
    """Dimensionless check: B → sB, Ω → kΩ, t → t/k, h → h/k gives A → skA(t k), the same R(t k)
    and the same relative drifts — so the results are exact rescalings of the unit run."""
    base_top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    w = np.array([0.3, 1.0, 0.4])
    base = lieint.integrate(
        base_top, base_top.initial_state(angular_velocity=w), (0, 10), h=0.01, method="rkmk4", save_every=100
    )
    top = lieint.EulerTop(mass_scale * base_top.B)
    sol = lieint.integrate(
        top,
        top.initial_state(angular_velocity=speed * w),
        (0, 10 / speed),
        h=0.01 / speed,
        method="rkmk4",
        save_every=100,
    )
    rel = float(np.max(np.abs(sol.states["A"] / (mass_scale * speed) - base.states["A"])))
    record(f"B×{mass_scale:g}, Ω×{speed:g}: |A/(sk) − A_unit|", rel, "the unit run, rescaled")
    assert rel < 1e-12
    np.testing.assert_allclose(sol.states["R"], base.states["R"], atol=1e-12)
    assert abs(sol.drift("energy") - base.drift("energy")) < 1e-12
