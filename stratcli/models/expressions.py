"""Safe parsing of math expressions into sympy, without `eval`.

Scenario files carry expressions (vector fields of custom models, angles such as ``"pi/3"``).
They are parsed with Python's `ast` and translated node by node into sympy; only arithmetic,
numbers, known symbols and a whitelist of functions are accepted. Nothing is ever evaluated as
Python code, so ``__import__('os')`` or attribute access is rejected with a clear message.
"""

from __future__ import annotations

import ast
import math
import re

import sympy as sp

FUNCTIONS = {
    "sin": sp.sin,
    "cos": sp.cos,
    "tan": sp.tan,
    "asin": sp.asin,
    "acos": sp.acos,
    "atan": sp.atan,
    "atan2": sp.atan2,
    "sinh": sp.sinh,
    "cosh": sp.cosh,
    "tanh": sp.tanh,
    "exp": sp.exp,
    "log": sp.log,
    "sqrt": sp.sqrt,
    "abs": sp.Abs,
}
CONSTANTS = {"pi": sp.pi, "π": sp.pi, "E": sp.E}

_BINOPS = {
    ast.Add: lambda a, b: a + b,
    ast.Sub: lambda a, b: a - b,
    ast.Mult: lambda a, b: a * b,
    ast.Div: lambda a, b: a / b,
    ast.Pow: lambda a, b: a**b,
    ast.BitXor: lambda a, b: a**b,  # "x^2" as users of other tools write it
}


class ExpressionError(ValueError):
    """An expression that is not plain arithmetic in the allowed names."""


def parse_expression(text: str, symbols: dict[str, sp.Symbol] | None = None) -> sp.Expr:
    """Parse `text` into a sympy expression over `symbols` (names → symbols)."""
    symbols = symbols or {}
    if not isinstance(text, str):
        raise ExpressionError(f"expected an expression string, got {text!r}")
    source = text.strip().replace("π", "pi")
    if not source:
        raise ExpressionError("empty expression")
    try:
        tree = ast.parse(source, mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"cannot parse {text!r}: {exc.msg}") from None
    allowed = ", ".join(sorted(symbols)) or "none"
    return _translate(tree.body, symbols, text, allowed)


def _translate(node: ast.AST, symbols: dict[str, sp.Symbol], text: str, allowed: str) -> sp.Expr:
    def rec(n: ast.AST) -> sp.Expr:
        return _translate(n, symbols, text, allowed)

    if isinstance(node, ast.Constant) and type(node.value) in (int, float):
        value = node.value
        return sp.Integer(value) if isinstance(value, int) else sp.Float(value)
    if isinstance(node, ast.Name):
        if node.id in symbols:
            return symbols[node.id]
        if node.id in CONSTANTS:
            return CONSTANTS[node.id]
        if node.id in FUNCTIONS:
            raise ExpressionError(f"in {text!r}: function {node.id!r} must be called")
        raise ExpressionError(f"in {text!r}: unknown name {node.id!r} (allowed names: {allowed})")
    if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
        return _BINOPS[type(node.op)](rec(node.left), rec(node.right))
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
        operand = rec(node.operand)
        return -operand if isinstance(node.op, ast.USub) else operand
    if isinstance(node, ast.Call):
        name = node.func.id if isinstance(node.func, ast.Name) else None
        if name not in FUNCTIONS or node.keywords:
            shown = name or ast.unparse(node.func)
            raise ExpressionError(
                f"in {text!r}: call of {shown!r} is not allowed "
                f"(functions: {', '.join(sorted(FUNCTIONS))})"
            )
        return FUNCTIONS[name](*[rec(a) for a in node.args])
    raise ExpressionError(
        f"in {text!r}: {ast.unparse(node)!r} is not allowed "
        "(only numbers, names, + - * / ** and math functions)"
    )


_DEG = re.compile(r"^\s*(.+?)\s*(deg|°)\s*$")


def parse_number(value: float | int | str) -> float:
    """A real number from a TOML value: 1.5, "pi/3", "-pi/12", "2*pi/3", "60deg", "60°"."""
    if isinstance(value, bool):
        raise ExpressionError(f"expected a number, got {value!r}")
    if isinstance(value, int | float):
        return float(value)
    if not isinstance(value, str):
        raise ExpressionError(f"expected a number or an expression such as 'pi/3', got {value!r}")
    scale = 1.0
    text = value
    match = _DEG.match(value)
    if match:
        text, scale = match.group(1), math.pi / 180.0
    expr = parse_expression(text)
    if expr.free_symbols:
        raise ExpressionError(f"{value!r} is not a constant")
    number = complex(sp.N(expr, 30))
    if abs(number.imag) > 0 or not math.isfinite(number.real):
        raise ExpressionError(f"{value!r} is not a finite real number")
    return number.real * scale
