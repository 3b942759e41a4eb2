"""Every (method, built-in system) pair runs compiled, or is a declared exception.

Registry-driven: every registered method (in each coordinate map) on every built-in system it
applies to either runs on the compiled engine or is listed in :data:`NUMPY_PATH` — and then says
so in ``sol.stats.backend_reason`` and is named in docs/architecture.md's table of what does not
run compiled. The list works both ways: a pair listed that runs compiled fails too (the list
and the docs stay current when a method gains a compiled form).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from bodies import applies, coverage_systems, initial, registered_methods

import lieint
from lieint.methods.registry import get_method

#: the systems of the coverage tests (tests/fast/test_engine_coverage.py runs the same)
SYSTEMS = coverage_systems()
#: every one of them
ALL = frozenset(SYSTEMS)

#: the pairs that run on the numpy path: method -> the systems (labels of SYSTEMS); none today
#: (the last ones, the splittings beyond the free 3D top and the midpoint, now run compiled)
NUMPY_PATH: dict[str, frozenset] = {}
#: what backend_reason says of each kind of exception
REASONS = ("has no compiled",)

#: how docs/architecture.md's table names each listed method
DOC_NAMES: dict[str, str] = {}


@pytest.mark.parametrize("label", sorted(SYSTEMS))
def test_every_pair_runs_compiled_or_is_a_declared_exception(label):
    system = SYSTEMS[label]
    y0 = initial(system, np.random.default_rng(2))
    for name, coordinates in registered_methods():
        method = get_method(name, coordinates=coordinates)
        if method.self_controlled or not applies(method, system):
            continue
        kw = dict(rtol=1e-6, atol=1e-9) if method.adaptive else dict(h=0.01)
        sol = lieint.integrate(system, y0, (0.0, 0.03), method=name, coordinates=coordinates, **kw)
        where = (label, name, coordinates, sol.stats.backend_reason)
        assert sol.success, where
        listed = label in NUMPY_PATH.get(name, ())
        if listed:
            assert sol.stats.backend == "numpy", where
            assert any(f"{method.name!r} {reason}" in sol.stats.backend_reason for reason in REASONS), where
        else:
            assert sol.stats.backend == "numba", where


def test_the_declared_exceptions_are_in_the_architecture_table():
    text = (Path(__file__).resolve().parents[2] / "docs" / "architecture.md").read_text()
    table = text[text.index("What does not run compiled") :]
    table = table[: table.index("\n\n", table.index("| run |"))]
    for name in NUMPY_PATH:
        words = [v for k, v in DOC_NAMES.items() if k in name]
        assert words, name
        assert all(word in table for word in words), (name, words)
    assert "Moser–Veselov" not in table  # compiled on every top it applies to


def test_long_exact_flow_steps_are_a_declared_exception():
    # exact_flow runs compiled on the 3D top (above, h = 0.01); a step with |λh| > 1 takes the
    # numpy path's closed form, and the run says so — in backend_reason and in the docs' table
    top = SYSTEMS["euler_top n=3"]
    y0 = initial(top, np.random.default_rng(2))
    sol = lieint.integrate(top, y0, (0.0, 60.0), h=30.0, method="exact_flow")
    assert sol.stats.backend == "numpy", sol.stats.backend_reason
    assert "'exact_flow' steps with |λh| > 1" in sol.stats.backend_reason
    text = (Path(__file__).resolve().parents[2] / "docs" / "architecture.md").read_text()
    table = text[text.index("What does not run compiled") :]
    assert "exact flow with steps" in table[: table.index("\n\n", table.index("| run |"))]
