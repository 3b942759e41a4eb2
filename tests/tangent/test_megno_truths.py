"""MEGNO against closed forms: how ⟨Y⟩ approaches 2 on a torus and 0 in an isochronous direction.

The spherical top (moments I, I, I) keeps its momentum A and turns at the constant Ω = A/I, so
its tangent flow is known exactly. Perturbing A along itself changes the speed of rotation, not
its axis: in the chart ``R → R exp(ξ̂)``, ``A → A + δA`` the deviation is ``(δA, ξ(t) = t δA/I)``,
so ``|δ(t)| = |δ(0)| √(1 + x²)`` with ``x = t/I`` — the model of a sheared torus. Then
(Cincotta & Simó 2000, ``Y(t) = (2/t) ∫ s d log|δ|``)::

    Y(t)   = 2 − 2 arctan(x)/x,
    ⟨Y⟩(t) = (1/t) ∫ Y = 2 − 2 Ti₂(x)/x ≈ 2 − π log(x)/x,   Ti₂(x) = ∫₀ˣ arctan(u)/u du,

so ⟨Y⟩ reaches 2 only slowly, at a rate set by how fast the deviation shears relative to its
bounded part. Perturbing A across itself turns the axis but keeps the speed (an isochronous
direction): ``|δ|`` stays bounded and ⟨Y⟩ → 0 like 1/t. RKMK4 is exact here (Ω constant), so
the only errors are the quadratures of the sums: midpoint and trapezoidal, ``O(h²)``.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import quad

import lieint
from lieint.groups.bivectors import bivector_coordinates

MOMENT = 2.0


def spherical_top():
    top = lieint.EulerTop.from_principal_moments([MOMENT, MOMENT, MOMENT])
    return top, top.initial_state(angular_velocity=[0.3, -0.5, 0.4])


def deviation(top, y0, momentum_direction):
    chart = lieint.tangent.chart_of(top)
    v = np.zeros(chart.dim)
    v[chart.offsets["A"]] = momentum_direction
    return v


def test_megno_of_a_sheared_deviation_follows_the_closed_form():
    top, y0 = spherical_top()
    a = bivector_coordinates(y0["A"])
    T, h = 40.0, 0.1
    m = lieint.megno(top, y0, (0.0, T), h=h, vector=deviation(top, y0, a))
    x = m.t / MOMENT
    y_truth = 2.0 - 2.0 * np.arctan(x) / x
    mean_truth = np.array([2.0 - 2.0 * quad(lambda u: np.arctan(u) / u, 0.0, xi)[0] / xi for xi in x[9::10]])
    # quadrature errors: the midpoint rule on ∫ g, g(s) = s d log|δ|/ds = s²/(I² + s²), |g''| ≤ 2/I²,
    # gives |ΔY| ≤ (2/t)(t/h)(h³/24)(2/I²) = h²/(6I²); the trapezoidal rule on ∫ Y adds
    # h² max|Y''|/12 with |Y''| ≤ 4/(3I²) (Y ≈ 2x²/3 near 0)
    tol_y = h**2 / (6.0 * MOMENT**2)
    tol_mean = tol_y + h**2 * (4.0 / (3.0 * MOMENT**2)) / 12.0
    assert np.max(np.abs(m.y_history - y_truth)) <= tol_y
    assert np.max(np.abs(m.mean_history[9::10] - mean_truth)) <= tol_mean
    # the exponent from the same vector is log√(1 + x²)/t, not 0: the log(t)/t of a torus
    assert np.allclose(m.lyapunov_history, 0.5 * np.log1p(x**2) / m.t, rtol=1e-9, atol=1e-12)
    # the slow approach itself: at x = T/I = 20 the deviation has grown twentyfold, yet ⟨Y⟩ = 1.52
    assert float(m.mean) < 1.53


def test_megno_of_an_isochronous_deviation_falls_to_zero_like_one_over_t():
    top, y0 = spherical_top()
    a = bivector_coordinates(y0["A"])
    across = np.cross(a, [1.0, 0.0, 0.0])
    T = 160.0
    m = lieint.megno(top, y0, (0.0, T), h=0.2, vector=deviation(top, y0, across))
    assert np.max(np.abs(m.lyapunov_history * m.t)) < 1.0  # |δ| bounded: no shear
    means = np.array([float(m.mean_history[np.searchsorted(m.t, t - 1e-9)]) for t in (T / 4, T / 2, T)])
    assert abs(means[-1]) < 0.01
    ratios = means[:-1] / means[1:]
    assert np.all((1.8 < ratios) & (ratios < 2.2)), means  # 1/t, where a sheared one would tend to 2
