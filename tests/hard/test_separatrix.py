"""Near the separatrix: the Dzhanibekov flip started 1e-8 from the unstable middle axis.

Truths: mpmath at 40 digits for the Jacobi functions and the flip times (independent of
lieint's elliptic code), the exact elliptic solution for the integrators.
"""

import mpmath as mp
import numpy as np
import pytest

import lieint
from lieint.groups import vee
from lieint.systems.euler_top_exact import euler_top_flip_times, jacobi_elliptic

pytestmark = pytest.mark.hard

I = np.array([1.0, 2.0, 3.0])


def middle_component_flips(top, sol):
    w2 = vee(top.angular_velocity(sol.states["A"]))[:, 1]
    i = np.flatnonzero(np.sign(w2[1:]) != np.sign(w2[:-1]))
    t = sol.t
    return t[i] - w2[i] * (t[i + 1] - t[i]) / (w2[i + 1] - w2[i])


def mpmath_flip_times(w0, t_end):
    """Flip times from first principles in 40-digit arithmetic: sign changes of w₂ = a₂ sn(u₀ + λt)."""
    mp.mp.dps = 40
    I1, I2, I3 = (mp.mpf(x) for x in I)
    w1, w2, w3 = (mp.mpf(x) for x in w0)
    E2 = I1 * w1**2 + I2 * w2**2 + I3 * w3**2
    G2 = (I1 * w1) ** 2 + (I2 * w2) ** 2 + (I3 * w3) ** 2
    assert G2 > E2 * I2  # this start circles the e₃ axis
    m = (I2 - I1) * (E2 * I3 - G2) / ((I3 - I2) * (G2 - E2 * I1))
    a1 = mp.sqrt((E2 * I3 - G2) / (I1 * (I3 - I1)))
    a2 = mp.sqrt((E2 * I3 - G2) / (I2 * (I3 - I2)))
    a3 = mp.sqrt((G2 - E2 * I1) / (I3 * (I3 - I1))) * mp.sign(w3)
    lam = (I3 - I2) * a2 * a3 / (I1 * a1)
    phi0 = mp.atan2(w2 / a2, w1 / a1)
    u0 = mp.ellipf(phi0, m)
    K = mp.ellipk(m)
    out, j = [], 1
    while True:
        t = (2 * j * K - u0) / lam
        if t > t_end:
            return np.array(out, dtype=float), float(1 - m)
        if t > 0:
            out.append(float(t))
        j += 1


def test_jacobi_functions_near_m_equal_one_against_mpmath(record):
    mp.mp.dps = 40
    worst = 0.0
    for p in (1e-16, 1e-12, 1e-6):
        K = float(mp.ellipk(1 - mp.mpf(p)))
        for u in (0.5, K - 0.3, K + 2.0, 2 * K - 1.0, 3 * K, 4.5 * K):
            ref = [float(mp.ellipfun(f, u, m=1 - mp.mpf(p))) for f in ("sn", "cn", "dn")]
            worst = max(worst, float(np.max(np.abs(np.array(jacobi_elliptic(u, p)) - ref))))
    record("max |sn,cn,dn − mpmath| (p = 1e-16…1e-6, u ≤ 4.5K)", worst, "mpmath 40 digits")
    assert worst < 1e-13


def test_exact_flip_times_against_mpmath(record):
    w0 = [1e-8, 1.0, 1e-8]
    ref, p = mpmath_flip_times(w0, 200.0)
    ours = euler_top_flip_times(I, w0, 200.0)
    record("1 − m of the 1e-8 start", p, "mpmath")
    record("max |exact flip time − mpmath|", float(np.max(np.abs(ours - ref))), "mpmath 40 digits")
    assert ours.shape == ref.shape and np.max(np.abs(ours - ref)) < 1e-9


@pytest.mark.parametrize(("method", "h"), [("rkmk4", 0.005), ("rkmk6", 0.02)])
def test_dzhanibekov_flip_1e8_from_the_middle_axis(record, method, h):
    w0 = [1e-8, 1.0, 1e-8]
    T = 180.0
    top = lieint.EulerTop.from_principal_moments(I, orientation=False)
    y0 = top.initial_state(angular_velocity=w0)
    sol = lieint.integrate(top, y0, (0, T), h=h, method=method)
    exact = euler_top_flip_times(I, w0, T)
    flips = middle_component_flips(top, sol)
    assert flips.size == exact.size == 3
    first = abs(flips[0] - exact[0])
    record(f"{method} h={h}: first flip error [s]", first, "exact elliptic flip time 34.847 s")
    record(
        f"{method} h={h}: later flips error [s]",
        float(np.max(np.abs(flips[1:] - exact[1:]))),
        "not determined in double precision, see below",
    )
    record(f"{method} h={h}: Casimir drift", float(sol.drift("casimirs")), "spectrum of A")
    assert first < 1e-6
    assert sol.drift("casimirs") < 1e-13


def test_why_later_flips_are_not_determined_in_double_precision(record):
    """Distance to the separatrix in energy: (G² − 2E I₂)/(2E I₂) = (3w₃² − w₁²)/(2 w₂²) ≈ 1e-16 —
    below the round-off of E itself. One rounding error of the energy (with G² kept, as Lie
    methods do) moves the start across a whole range of elliptic moduli, and the exact flip
    times after the first passage move by seconds."""
    w0 = np.array([1e-8, 1.0, 1e-8])
    E2 = float(np.sum(I * w0**2))
    gap = float(np.sum(I * (I - I[1]) * w0**2)) / (E2 * I[1])
    record("(G² − 2E I₂)/(2E I₂) of the 1e-8 start", gap, "machine epsilon 2.2e-16")
    assert gap < np.finfo(float).eps
    # raise 2E by one ulp at fixed G² (a ulp-sized move along the energy, as a rounding error does)
    spread = []
    base = euler_top_flip_times(I, w0, 180.0)
    for k in (1, 2, 4):
        # move w₁ and w₃ so that G² is unchanged and 2E changes by k ulps of E
        dE = k * np.spacing(E2)
        # d(2E) = 2 I₁w₁dw₁ + 2 I₃w₃dw₃, d(G²) = 2 I₁²w₁dw₁ + 2 I₃²w₃dw₃ = 0
        dw3 = dE / (2 * I[2] * w0[2] * (1 - I[2] / I[0]))
        dw1 = -(I[2] ** 2 * w0[2] * dw3) / (I[0] ** 2 * w0[0])
        moved = euler_top_flip_times(I, w0 + np.array([dw1, 0.0, dw3]), 180.0)
        spread.append(float(np.max(np.abs(moved[: base.size] - base[: moved.size]))))
    record("exact later-flip shift for a 1–4 ulp energy change [s]", max(spread), "exact solution")
    assert max(spread) > 0.1  # the conditioning, not the integrators, limits the later flips


@pytest.mark.parametrize(("offset", "tol"), [(1e-5, 1e-3), (1e-6, 5e-2)])
def test_all_flips_agree_when_the_distance_is_resolved(record, offset, tol):
    w0 = [offset, 1.0, offset]
    T = 180.0
    top = lieint.EulerTop.from_principal_moments(I, orientation=False)
    sol = lieint.integrate(top, top.initial_state(angular_velocity=w0), (0, T), h=0.02, method="rkmk6")
    exact = euler_top_flip_times(I, w0, T)
    flips = middle_component_flips(top, sol)
    assert flips.size == exact.size
    err = float(np.max(np.abs(flips - exact)))
    record(f"offset {offset:g}, rkmk6 h=0.02: max flip-time error [s]", err, "exact elliptic flip times")
    assert err < tol
