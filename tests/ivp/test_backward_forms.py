"""Backward runs on every compiled form of the engine (the 3D top, the n-D top, the compiled pieces
of the heavy top, the free body and the balls, and the SIMD lanes of the ensembles of the 3D top,
the 3D heavy top and balls and the 4D top): the compiled engine and the numpy path take the same
steps backward, and a run forward and back returns to y0 within its error."""

from __future__ import annotations

import numpy as np
import pytest
from bodies import initial, initial_batch, variants

import lieint

T = 0.3


def _systems() -> dict[str, tuple]:
    rng = np.random.default_rng(7)
    top3 = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    out = {
        "euler_top n=3": (top3, initial(top3, rng)),
        "euler_top n=3, 64 bodies": (top3, initial_batch(top3, rng, 64)),
        "euler_top n=4": (lieint.EulerTop(np.diag([0.6, 0.9, 1.2, 1.5])), None),
    }
    top4 = lieint.EulerTop(np.diag([0.6, 0.9, 1.2, 1.5]))
    out["euler_top n=4, 8 bodies"] = (top4, initial_batch(top4, rng, 8))
    for n in (3, 4):
        for name, system in variants(n).items():
            if "/" not in name:
                out[f"{name} n={n}"] = (system, None)
            lanes = ("heavy_top", "chaplygin_ball", "rolling_ball/offset", "rolling_ball/offset, incline")
            if n == 3 and name in lanes:
                out[f"{name} n=3, 8 bodies"] = (system, initial_batch(system, rng, 8))  # in SIMD lanes (rkmk4)
    return {label: (s, initial(s, rng) if y is None else y) for label, (s, y) in out.items()}


SYSTEMS = _systems()


def last(sol) -> dict:
    return {k: v[-1] for k, v in sol.states.items()}


def distance(a: dict, b: dict) -> float:
    return max(float(np.abs(a[k] - b[k]).max()) for k in b)


@pytest.mark.parametrize("label", sorted(SYSTEMS))
@pytest.mark.parametrize(("method", "options"), [("rkmk4", {"h": 0.01}), ("rkmk45", {"rtol": 1e-8, "atol": 1e-10})])
def test_backward_on_every_compiled_form(label, method, options):
    system, y0 = SYSTEMS[label]
    forward = lieint.integrate(system, y0, (0.0, T), method=method, **options)
    fast = lieint.integrate(system, last(forward), (T, 0.0), method=method, **options)
    slow = lieint.integrate(system, last(forward), (T, 0.0), method=method, backend="numpy", **options)
    assert (forward.stats.backend, fast.stats.backend, slow.stats.backend) == ("numba", "numba", "numpy"), (
        fast.stats.backend_reason
    )
    if "bodies" in label and "h" in options:  # the ensembles' fixed steps run in SIMD lanes
        assert "SIMD lanes" in forward.stats.backend_reason and "SIMD lanes" in fast.stats.backend_reason
    assert fast.t[-1] == slow.t[-1] == 0.0 and np.all(np.diff(fast.t) < 0)
    assert (fast.stats.nsteps, fast.stats.nrejected) == (slow.stats.nsteps, slow.stats.nrejected)
    scale = max(float(np.abs(v).max()) for v in y0.values())
    if "h" in options:
        np.testing.assert_array_equal(fast.t, slow.t)
        assert distance(last(fast), last(slow)) <= 1e-12 * scale
        # rkmk4 (even order): the round trip's error is O(h⁵), here far below the step's own error
        assert distance(last(fast), y0) <= 1e-8 * scale
    else:
        assert distance(last(fast), last(slow)) <= 100 * options["rtol"] * scale
        assert distance(last(fast), y0) <= 100 * options["rtol"] * scale
