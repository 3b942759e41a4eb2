"""The lecture's counts toward integrability beside what the motion says (MEGNO, separation growth).

A count of 1 (integrable) predicts motion on a torus: nearby motions separate linearly,
``|δ(t)|² ≈ |b(t)|² + a²t²`` with b bounded, so ``log|δ(T)| − log|δ(T/2)| = log 2`` up to the
bounded part (measured within 0.14 of it at T = 100 for every case below; the bound 0.5 allows
``|b| ≲ aT/2``); chaos separates them exponentially, by ``λT/2`` over the same interval. Short
runs (T = 100, h = 0.1); the T = 2000 figures are benchmarks/chaos_indicators.py. The heavy tops
are not counted by ``integrability_count`` (their count, 6 − 1 − 1 − 1 = 3 and one more integral
with its flow for Lagrange and Kovalevskaya, is the gallery's); the 4D Chaplygin ball is the
open case: only its count is asserted here.
"""

from __future__ import annotations

import numpy as np
import pytest

import lieint
from lieint.analysis import integrability_count
from lieint.groups.bivectors import hat

T, H = 100.0, 0.1
B3 = lieint.EulerTop.from_principal_moments([1.0, 1.5, 2.0]).B


def _cases():
    """name → (the counted system and its state or None, the moving system and its state, count, regime)."""
    top3 = dict(moments=[1.0, 2.0, 3.0], angular_velocity=[1.0, 0.3, 0.2])
    rng = np.random.default_rng(4)
    Q, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    X = rng.normal(size=(4, 4))
    Omega4 = 0.5 * (X - X.T)
    w = np.array([1.0, 2.0, 1.5])

    def euler3(orientation):
        return lieint.EulerTop.from_principal_moments(top3["moments"], orientation=orientation)

    def euler4(orientation):
        return lieint.EulerTop(np.diag([0.6, 0.9, 1.2, 1.5]), orientation=orientation)

    def ball3(orientation):
        return lieint.ChaplyginBall(
            np.diag([0.08, 0.12, 0.16]), 1.0, 1.0, orientation=orientation, track_center=orientation
        )

    def ball4(orientation):
        B = Q @ np.diag([0.06, 0.09, 0.12, 0.15]) @ Q.T
        return lieint.ChaplyginBall(B, 1.0, 1.0, orientation=orientation, track_center=orientation)

    lag = lieint.HeavyTop.lagrange(1.0, 0.5, mass=1.0, length=0.2, orientation=False)
    kov = lieint.HeavyTop.kovalevskaya(1.0, mass=1.0, length=0.1, orientation=False)
    generic = lieint.HeavyTop(B3, 1.0, [0.1, 0.05, 0.08], [0.0, 0.0, -9.81], orientation=False)
    return {
        "3D top": (euler3, {"angular_velocity": top3["angular_velocity"]}, "momentum", 1, "regular"),
        "4D top": (euler4, {"Omega": Omega4}, "manakov", 1, "regular"),
        "3D Chaplygin ball": (ball3, {"Omega": hat([0.3, 1.0, 0.4])}, "momentum", 1, "regular"),
        "4D Chaplygin ball": (ball4, {"Omega": Omega4}, "momentum", 4, None),
        "Lagrange top": (lambda o: lag, {"angular_velocity": [1.0, 0.5, 5.0]}, None, None, "regular"),
        "Kovalevskaya top": (lambda o: kov, {"angular_velocity": [1.0, 0.5, 1.0]}, None, None, "regular"),
        "generic heavy top": (
            lambda o: generic,
            {"angular_velocity": 2.0 * w / np.linalg.norm(w)},
            None,
            None,
            "chaotic",
        ),
    }


# the 4D top's case takes seconds (its MEGNO over the longest run): the full suite's
@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n == "4D top" else n for n in _cases()])
def test_the_count_and_the_motion_agree(name):
    build, initial, integrals, expected_count, regime = _cases()[name]
    if integrals is not None:
        counted = build(True)
        count = integrability_count(counted, counted.initial_state(**initial), integrals=integrals, verbose=False)
        assert count.result == expected_count, count.equation()
    if regime is None:
        return
    system = build(False)
    m = lieint.megno(system, system.initial_state(**initial), (0.0, T), h=H, save_every=10)
    log_norm = m.lyapunov_history * m.t
    growth = float(log_norm[-1] - log_norm[np.searchsorted(m.t, T / 2 - 1e-9)])
    if regime == "regular":
        assert abs(growth - np.log(2.0)) < 0.5, growth
        assert 1.0 < float(m.mean) < 2.5, float(m.mean)
    else:
        assert growth > 5.0, growth  # λT/2 with λ ≥ 0.1
        assert float(m.mean) > 4.0, float(m.mean)
