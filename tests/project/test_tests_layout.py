"""The test suite's own layout: test files live in the directory of the package part they test
(never at the top of tests/), and no test module imports another one — what several share lives
in tests/conftest.py, tests/bodies.py or tests/taylor_reference.py."""

from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]


def test_no_test_file_sits_at_the_top_of_tests():
    assert sorted(p.name for p in TESTS.glob("test_*.py")) == []


def test_no_test_module_imports_another():
    offenders = []
    for path in sorted(TESTS.rglob("test_*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names = []
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            offenders += [
                f"{path.relative_to(TESTS)}:{node.lineno} {n}" for n in names if n.split(".")[0].startswith("test_")
            ]
    assert offenders == []


def test_the_rule_sees_an_import_of_a_test_module(tmp_path, monkeypatch):
    """The check itself: a test module importing another is found."""
    (tmp_path / "groups").mkdir()
    (tmp_path / "groups" / "test_a.py").write_text("from test_b import helper\n")
    import sys

    monkeypatch.setattr(sys.modules[__name__], "TESTS", tmp_path)
    try:
        test_no_test_module_imports_another()
    except AssertionError as exc:
        assert "test_b" in str(exc)
    else:
        raise AssertionError("the import of test_b was not found")
