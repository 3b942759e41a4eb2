"""The public API's docstrings and type hints (.ci/check_api_docs.py), and its examples run."""

import doctest
import importlib.util
import inspect
from pathlib import Path

import numpy as np
import pytest

import lieint

SPEC = importlib.util.spec_from_file_location(
    "check_api_docs", Path(__file__).resolve().parents[2] / ".ci" / "check_api_docs.py"
)
check = importlib.util.module_from_spec(SPEC)
SPEC.loader.exec_module(check)

PUBLIC = list(check.public_api())


def test_the_public_api_is_documented_and_annotated():
    assert check.findings() == []
    names = {name for name, _, _ in PUBLIC}
    # what the checker covers: lieint.__all__, the modules in it, the systems' and Solution's members
    assert {
        "lieint.integrate",
        "lieint.run",
        "lieint.sweep",
        "lieint.Solution.drift",
        "lieint.EulerTop.initial_state",
    } <= names
    assert {"lieint.rotations.to_quaternion", "lieint.analysis.is_holonomic", "lieint.HeavyTop.lagrange"} <= names


def test_the_checker_finds_drift():
    def undocumented(x: int, y: float) -> float:
        """Add.

        Parameters
        ----------
        x : int
            A number.

        Returns
        -------
        float
            The sum.
        """
        return x + y

    def unannotated(x, *, y=1.0):
        """Add.

        Parameters
        ----------
        x : float
            A number.
        y : float
            Another.

        Returns
        -------
        float
            The sum.
        """
        return x + y

    def renamed(z: float) -> float:
        """Square.

        Parameters
        ----------
        x : float
            A number.
        """
        return z * z

    assert any("PR01" in f and "'y'" in f for f in check.numpydoc_findings("undocumented", undocumented, False))
    assert check.numpydoc_findings("unannotated", unannotated, False) == []
    hints = check.type_hint_findings("unannotated", unannotated)
    assert hints == [
        "unannotated: TH01 parameter 'x' has no type hint",
        "unannotated: TH01 parameter 'y' has no type hint",
        "unannotated: TH02 no return type hint",
    ]
    codes = {f.split()[1] for f in check.numpydoc_findings("renamed", renamed, False)}
    assert {"PR01", "PR02", "RT01"} <= codes
    assert any("EX01" in f for f in check.numpydoc_findings("lieint.integrate-like", renamed, True))


def _examples():
    """(name, doctest) of every public object's docstring examples, and the modules'."""
    finder = doctest.DocTestFinder(recurse=False)
    seen = set()
    objects = [("lieint", lieint), ("lieint.rotations", lieint.rotations)]
    objects += [(name, check._function_of(documented)) for name, _, documented in PUBLIC]
    for name, obj in objects:
        try:
            tests = finder.find(obj, name, globs={})
        except ValueError:  # objects doctest cannot read the source of
            continue
        for test in tests:
            if test.examples and (test.filename, test.lineno) not in seen:
                seen.add((test.filename, test.lineno))
                yield pytest.param(test, id=name)


EXAMPLES = list(_examples())


def test_every_required_example_is_collected():
    names = {p.id for p in EXAMPLES}
    required = set(check.NEEDS_EXAMPLES) | {
        f"lieint.{name}"
        for name in lieint.__all__
        if inspect.isclass(getattr(lieint, name)) and issubclass(getattr(lieint, name), lieint.LieGroupSystem)
    }
    assert required - {"lieint.LieGroupSystem"} <= names


@pytest.mark.parametrize("test", EXAMPLES)
def test_public_examples_run(test, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # examples that write files write them here
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    report: list[str] = []
    with np.printoptions(legacy=False):
        result = runner.run(test, out=report.append)
    assert result.failed == 0, "".join(report)
