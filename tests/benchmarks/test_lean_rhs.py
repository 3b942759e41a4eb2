"""The lean right-hand sides of the DOP853 baselines (benchmarks/lean_rhs.py) are the systems'
equations: equal to ``system.vector_field`` at random states of every system the benchmarks time."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"


def _load(name):
    sys.path.insert(0, str(BENCHMARKS))
    try:
        spec = importlib.util.spec_from_file_location(name, BENCHMARKS / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    finally:
        sys.path.remove(str(BENCHMARKS))


lean = _load("lean_rhs")
systems_speed = _load("systems_speed")
CASES = systems_speed.cases()


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_lean_right_hand_side_is_the_vector_field(case):
    _, system, y0, _ = case
    assert lean.check(system, y0, rtol=1e-12) <= 1e-12


def test_the_check_sees_a_wrong_term():
    # the lean field reads the centre of mass from the system; doubling it after construction
    # (lieint's field keeps M X_G from the constructor) must be seen: the torque term is tested
    import copy

    _, system, y0, _ = next(c for c in CASES if c[0] == "heavy top n=3")
    broken = copy.copy(system)
    broken.center_of_mass = 2.0 * system.center_of_mass
    with pytest.raises(AssertionError, match="differs from its vector_field"):
        lean.check(broken, y0)


def test_an_unknown_system_is_refused():
    import lieint

    ball = lieint.RollingBall(np.diag([0.1, 0.15, 0.2, 0.25]), 1.0, 1.0)
    with pytest.raises(NotImplementedError, match="no lean right-hand side"):
        lean.lean_rhs(ball)
