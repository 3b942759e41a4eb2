"""Lyapunov exponents and MEGNO on the exact tangent map: integrable against chaotic tops.

Horizons are short (T = 200; the T = 2000/4000 figures are benchmarks/chaos_indicators.py),
so the tolerances come from how the indicators converge, not from the long-time limits:

* a regular motion separates nearby orbits linearly, ``|δ(t)|² ≈ |b(t)|² + a²t²`` with b bounded;
  then ``T λ(T) = log|δ(T)| = log(aT) + O(1)``, so doubling T adds ``log 2`` to ``T λ(T)``, and
  ``⟨Y⟩(T) = 2 − O(log(aT)/(aT))`` (the model ``|δ| = √(B² + a²t²)`` gives ``π log(aT/B)/(aT/B)``
  with B the unknown size of the bounded part), so the test asks ``⟨Y⟩`` in ``(1.5, 2.5)`` and
  no farther from 2 at T than at T/2;
* a chaotic one separates them exponentially: ``T λ(T)`` grows by ``λT/2`` when T doubles and
  ``⟨Y⟩ ≈ λT/2`` grows linearly: above 5 at T = 200 for λ ≥ 0.05, outside the regular band.
"""

from __future__ import annotations

import numpy as np
import pytest

import lieint

T, H = 200.0, 0.05


def _integrable():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0], orientation=False)
    lag = lieint.HeavyTop.lagrange(1.0, 0.5, mass=1.0, length=0.2, orientation=False)
    kov = lieint.HeavyTop.kovalevskaya(1.0, mass=1.0, length=0.1, orientation=False)
    ball = lieint.ChaplyginBall(np.diag([0.08, 0.12, 0.16]), 1.0, 1.0, orientation=False, track_center=False)
    return {
        "free top": (top, top.initial_state(angular_velocity=[1.0, 0.3, 0.2])),
        "Lagrange": (lag, lag.initial_state(angular_velocity=[1.0, 0.5, 5.0])),
        "Kovalevskaya": (kov, kov.initial_state(angular_velocity=[1.0, 0.5, 1.0])),
        "Chaplygin ball": (ball, ball.initial_state(Omega=lieint.groups.bivectors.hat([0.3, 1.0, 0.4]))),
    }


def generic_heavy_top():
    """Principal moments (1, 1.5, 2), X_G = (0.1, 0.05, 0.08), g = 9.81: no known integral besides
    energy and the Casimirs. A scan of MEGNO over |w| along two directions (T = 200, h = 0.05 and
    0.025) finds chaos below energy ≈ 7 and regular motion above ≈ 10 (the fast top is close to
    the free one). This state (|w| = 2 along (1, 2, 1.5), energy 3.96) is chaotic away from the
    border: λ₁ = 0.129 at T = 2000 and 0.134 at T = 4000 (benchmarks/chaos_indicators.py); at
    energy 6.5 the largest exponent moves by 20 % between h and h/2 (stickiness)."""
    B = lieint.EulerTop.from_principal_moments([1.0, 1.5, 2.0]).B
    top = lieint.HeavyTop(B, 1.0, [0.1, 0.05, 0.08], [0.0, 0.0, -9.81], orientation=False)
    w = np.array([1.0, 2.0, 1.5])
    return top, top.initial_state(angular_velocity=2.0 * w / np.linalg.norm(w))


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(_integrable()))
def test_megno_of_integrable_motion_tends_to_two(name):
    system, y0 = _integrable()[name]
    m = lieint.megno(system, y0, (0.0, T), h=H, save_every=100)
    half = float(m.mean_history[np.searchsorted(m.t, T / 2)])
    assert 1.5 < float(m.mean) < 2.5, float(m.mean)
    assert abs(float(m.mean) - 2.0) <= abs(half - 2.0) + 1e-3, (half, float(m.mean))


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(_integrable()))
def test_largest_exponent_of_integrable_motion_falls_like_log_t_over_t(name):
    system, y0 = _integrable()[name]
    spec = lieint.lyapunov(system, y0, (0.0, T), h=H, k=1, every=20)
    half = spec.history[np.searchsorted(spec.t, T / 2), 0]
    growth = T * spec.exponents[0] - (T / 2) * half  # log 2 for linear separation
    assert spec.exponents[0] < 3 * np.log(T) / T
    assert abs(growth - np.log(2.0)) < 1.0, growth


@pytest.mark.slow
def test_generic_heavy_top_is_chaotic():
    system, y0 = generic_heavy_top()
    m = lieint.megno(system, y0, (0.0, T), h=H, save_every=100)
    half = m.mean_history[np.searchsorted(m.t, T / 2)]
    assert float(m.mean) > 4.0
    assert float(m.mean) - float(half) > 2.5  # ⟨Y⟩ ≈ λt/2 + c grows by λT/4 ≥ 2.5 from T/2 to T
    spec = lieint.lyapunov(system, y0, (0.0, T), h=H, k=1, every=20)
    assert spec.exponents[0] > 0.05
    growth = T * spec.exponents[0] - (T / 2) * spec.history[np.searchsorted(spec.t, T / 2), 0]
    assert growth > 5.0  # λT/2, not log 2


def test_spectrum_of_a_symplectic_map_sums_to_zero_and_pairs():
    """splitting2 on the free top with attitude (T*SO(3), symplectic): the exponents sum to
    log|det M|/T = 0 to round-off at every time; the pairs λ_i + λ_{7−i} are within the
    finite-time error of the exponents themselves (log(T)/T)."""
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    y0 = top.initial_state(angular_velocity=[1.0, 0.3, 0.2])
    spec = lieint.lyapunov(top, y0, (0.0, T), h=H, method="splitting2", every=20)
    assert spec.exponents.shape == (6,)
    assert np.all(np.diff(spec.exponents) <= 0)
    assert np.max(np.abs(spec.history.sum(axis=-1))) < 1e-12
    assert spec.pairing_defect() < 3 * np.log(T) / T


def test_a_batch_gives_each_body_its_indicator():
    system, y0 = generic_heavy_top()
    batch = {k: np.stack([v, v]) for k, v in y0.items()}
    vector = np.arange(1.0, 7.0)
    m = lieint.megno(system, batch, (0.0, 20.0), h=H, vector=vector)
    one = lieint.megno(system, y0, (0.0, 20.0), h=H, vector=vector)
    assert m.mean.shape == (2,)
    assert np.allclose(m.mean, float(one.mean), rtol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"k": 0}, "`k` must be an integer from 1"), ({"k": 7}, "tangent dimension 6"), ({"every": 0}, "`every`")],
)
def test_bad_arguments_are_named(kwargs, message):
    system, y0 = generic_heavy_top()
    with pytest.raises(ValueError, match=message):
        lieint.lyapunov(system, y0, (0.0, 1.0), h=H, **kwargs)


def test_megno_refuses_a_method_without_tangent_map():
    system, y0 = generic_heavy_top()
    with pytest.raises(ValueError, match="scipy"):
        lieint.megno(system, y0, (0.0, 1.0), h=H, method="RK45")
