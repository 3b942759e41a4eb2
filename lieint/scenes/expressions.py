"""A small safe grammar for numbers written as text in scene files, e.g. ``"pi/4"``.

A scene is data: nothing in it is ever evaluated as code. Strings are parsed with
:func:`ast.parse` (which only parses) and the tree is walked with a whitelist: numbers, the
constants ``pi``, ``e``, ``tau``, the operators ``+ - * / **`` and unary ``±``, and the
functions ``sin cos tan asin acos atan sqrt exp log radians degrees``. All arithmetic is on
floats (no big-integer blow-ups) and the text is limited to 200 characters.
"""

from __future__ import annotations

import ast
import math
import operator

__all__ = ["ExpressionError", "evaluate"]

_MAX_LENGTH = 200
_CONSTANTS = {"pi": math.pi, "e": math.e, "tau": math.tau}
_FUNCTIONS = {
    name: getattr(math, name)
    for name in ("sin", "cos", "tan", "asin", "acos", "atan", "sqrt", "exp", "log", "radians", "degrees")
}
_BINARY = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.Pow: operator.pow,
}
_UNARY = {ast.UAdd: operator.pos, ast.USub: operator.neg}


class ExpressionError(ValueError):
    """A text number that is not in the grammar, or whose value is not a finite number."""


def evaluate(text: str) -> float:
    """Value of an arithmetic expression such as ``"pi/4"`` or ``"9.81*sin(radians(30))"``."""
    if not isinstance(text, str):
        raise ExpressionError(f"expected an expression string, got {type(text).__name__}")
    if len(text) > _MAX_LENGTH:
        raise ExpressionError(f"expression longer than {_MAX_LENGTH} characters")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError:
        raise ExpressionError(f"{text!r} is not an arithmetic expression") from None
    try:
        value = _eval(tree.body, text)
    except (ArithmeticError, ValueError) as exc:
        if isinstance(exc, ExpressionError):
            raise
        raise ExpressionError(f"{text!r} has no finite value ({exc})") from None
    if not math.isfinite(value):
        raise ExpressionError(f"{text!r} has no finite value")
    return value


def _eval(node: ast.AST, text: str) -> float:
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
        return float(node.value)
    if isinstance(node, ast.Name) and node.id in _CONSTANTS:
        return _CONSTANTS[node.id]
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        return _BINARY[type(node.op)](_eval(node.left, text), _eval(node.right, text))
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        return _UNARY[type(node.op)](_eval(node.operand, text))
    if (
        isinstance(node, ast.Call)
        and isinstance(node.func, ast.Name)
        and node.func.id in _FUNCTIONS
        and len(node.args) == 1
        and not node.keywords
    ):
        return float(_FUNCTIONS[node.func.id](_eval(node.args[0], text)))
    allowed = "numbers, pi, e, tau, + - * / **, and " + ", ".join(sorted(_FUNCTIONS))
    raise ExpressionError(f"{text!r} uses something outside the scene grammar ({allowed})")
