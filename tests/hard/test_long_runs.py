"""Long runs: 10⁶ RKMK4 steps with and without projection, with growth laws fitted."""

import numpy as np
import pytest

import lieint

pytestmark = pytest.mark.hard


def growth_exponent(t, err):
    """Least-squares slope of log(err) against log(t) over the second half of the run."""
    keep = (t > t[-1] / 20) & (err > 0)
    return float(np.polyfit(np.log(t[keep]), np.log(err[keep]), 1)[0])


@pytest.fixture(scope="module")
def long_runs():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    kw = dict(t_span=(0.0, 10_000.0), h=0.01, method="rkmk4", save_every=1000)
    return lieint.integrate(top, y0, project=True, **kw), lieint.integrate(top, y0, project=False, **kw)


def test_one_million_steps_with_projection(record, long_runs):
    sol, _ = long_runs
    assert sol.nsteps == 1_000_000
    orth = float(np.max(sol.invariants["orthogonality"]))
    spec = float(sol.drift("casimirs"))
    energy = np.abs(sol.invariants["energy"] - sol.invariants["energy"][0]) / sol.invariants["energy"][0]
    record("10⁶ RKMK4 steps, projected: max ‖RᵀR − I‖", orth, "RᵀR = I")
    record("10⁶ steps: spectrum of A, relative drift", spec, "initial spectrum")
    record("10⁶ steps: max relative energy error", float(energy.max()), "initial energy")
    record("10⁶ steps: energy error growth exponent (err ∝ t^p)", growth_exponent(sol.t, energy), "fit over t")
    assert orth <= 1e-14
    assert spec <= 1e-12
    assert energy.max() < 1e-8  # bounded: 10⁴ time units at h = 0.01
    assert np.max(np.abs(np.linalg.det(sol.states["R"]) - 1)) < 1e-14


def test_one_million_steps_without_projection_orthogonality_grows(record, long_runs):
    _, sol = long_runs
    defect = sol.invariants["orthogonality"]
    p = growth_exponent(sol.t, defect)
    record("10⁶ steps, unprojected: final ‖RᵀR − I‖", float(defect[-1]), "RᵀR = I")
    record("unprojected: defect growth exponent (defect ∝ t^p; 0.5 = random walk, 1 = linear)", p, "fit over t")
    record(
        "unprojected: defect at t = 500 / 5000 / 10000",
        " / ".join(f"{defect[np.searchsorted(sol.t, t)]:.1e}" for t in (500.0, 5000.0, 10000.0)),
        "RᵀR = I",
    )
    assert 1e-16 < defect[-1] < 1e-10
    assert p < 1.3  # no faster than linear growth
