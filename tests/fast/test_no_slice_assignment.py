"""The compiled layer copies arrays by loops, never by array slice assignment.

numba compiles the shape-mismatch message of an array-to-array slice assignment
(``out[:, :] = X``), string formatting included, about 2 s of CPU time per
signature in every process that compiles such a function for the first time; the copies of
``lieint.fast.products`` (``copy_matrix_into``, ``copy_vector_into``) do the same by loops.
Filling with a number (``Q[:, :] = np.nan``) has no shape to check and stays allowed.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

FAST = Path(__file__).resolve().parents[2] / "lieint" / "fast"


def _is_compiled(node: ast.FunctionDef) -> bool:
    for decorator in node.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
        if name in ("njit", "jit"):
            return True
    return False


def _is_number(value: ast.expr) -> bool:
    if isinstance(value, ast.Constant):
        return isinstance(value.value, (int, float))
    if isinstance(value, ast.UnaryOp):
        return _is_number(value.operand)
    return isinstance(value, ast.Attribute) and value.attr in ("nan", "inf", "pi")


def _takes_a_subarray(target: ast.expr) -> bool:
    """Whether ``target`` is a subscript with a slice (a row by an integer, ``work[0]``, is one
    too, but the source does not say the array's rank: those are left to review)."""
    if not isinstance(target, ast.Subscript):
        return False
    index = target.slice
    parts = index.elts if isinstance(index, ast.Tuple) else [index]
    return any(isinstance(p, ast.Slice) for p in parts)


def slice_assignments(source: str) -> list[str]:
    """``function: line`` of every array-valued slice assignment in a compiled function."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if not (isinstance(node, ast.FunctionDef) and _is_compiled(node)):
            continue
        for statement in ast.walk(node):
            if isinstance(statement, ast.Assign):
                targets, value = statement.targets, statement.value
            elif isinstance(statement, ast.AugAssign):
                targets, value = [statement.target], statement.value
            else:
                continue
            if any(_takes_a_subarray(t) for t in targets) and not _is_number(value):
                found.append(f"{node.name}: line {statement.lineno}")
    return found


def test_the_check_finds_what_it_forbids_and_allows_filling():
    source = """
@njit(cache=True)
def f(out, X, Q, S):
    out[:, :] = X
    Q[:, :] = np.nan
    S[:n, n] += X[0]
    out[0, 1] = X[1, 0]

def not_compiled(out, X):
    out[:] = X
"""
    assert slice_assignments(source) == ["f: line 4", "f: line 6"]


@pytest.mark.parametrize("path", sorted(FAST.glob("*.py")), ids=lambda p: p.name)
def test_compiled_functions_copy_arrays_by_loops(path):
    found = slice_assignments(path.read_text(encoding="utf-8"))
    assert not found, f"{path.name}: array slice assignment in compiled code (use products.copy_matrix_into): {found}"
