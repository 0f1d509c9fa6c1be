"""Safe parsing of math expressions into sympy, without `eval`.

Scenario files carry expressions (vector fields of custom models, angles such as ``"pi/3"``).
They are parsed with Python's `ast` and translated node by node into sympy; only arithmetic,
numbers, known symbols and a whitelist of functions are accepted. Nothing is ever evaluated as
Python code, so ``__import__('os')`` or attribute access is rejected with a clear message.

Work is bounded so that no text can hang sympy's exact arithmetic or exhaust memory:

* at most `MAX_LENGTH` characters, `MAX_NODES` syntax nodes nested `MAX_DEPTH` deep;
* a numeric exponent must be at most `MAX_EXPONENT` in magnitude (``x**2``, ``x**(-1/2)``; not
  ``9**9**9**9`` or ``2**10**8``);
* every constant sub-expression (``1e20``, ``exp(800)``, ``10**30``) must be finite and at most
  `MAX_MAGNITUDE` in magnitude, and ``exp``/``sinh``/``cosh`` of a constant at most
  `MAX_EXP_ARGUMENT` (in magnitude; ``exp(-40)`` is fine);
* functions take their exact number of arguments.
"""

from __future__ import annotations

import ast
import math
import re

import sympy as sp

from .numbers import ExpressionError, angle_unit

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
ARITY = {name: 2 if name == "atan2" else 1 for name in FUNCTIONS}
_GROWING = {"exp", "sinh", "cosh"}

MAX_LENGTH = 2000
MAX_NODES = 2000
MAX_DEPTH = 100
MAX_EXPONENT = 64
MAX_MAGNITUDE = 1e15
MAX_EXP_ARGUMENT = 30.0

_BINOPS = {
    ast.Add: lambda a, b: a + b,
    ast.Sub: lambda a, b: a - b,
    ast.Mult: lambda a, b: a * b,
    ast.Div: lambda a, b: a / b,
    ast.Pow: lambda a, b: a**b,
}


def parse_expression(text: str, symbols: dict[str, sp.Symbol] | None = None) -> sp.Expr:
    """Parse `text` into a sympy expression over `symbols` (names → symbols)."""
    symbols = symbols or {}
    if not isinstance(text, str):
        raise ExpressionError(f"expected an expression string, got {text!r}")
    # "x^2" as users of other tools write it, with the precedence of a power: Python's `^`
    # binds looser than + and /, so "q^2/4" would otherwise parse as q^(2/4)
    source = text.strip().replace("π", "pi").replace("^", "**")
    if not source:
        raise ExpressionError("empty expression")
    if len(source) > MAX_LENGTH:
        raise ExpressionError(f"expression longer than {MAX_LENGTH} characters")
    shown = text if len(text) <= 60 else text[:57] + "..."
    try:
        tree = ast.parse(source, mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"cannot parse {shown!r}: {exc.msg}") from None
    except (RecursionError, MemoryError):
        raise ExpressionError(f"{shown!r} is nested too deeply") from None
    _check_size(tree.body, shown)
    allowed = _allowed(symbols)
    try:
        expr = _translate(tree.body, symbols, shown, allowed)
    except ExpressionError:
        raise
    except (ArithmeticError, TypeError, ValueError, RecursionError, MemoryError) as exc:
        raise ExpressionError(f"in {shown!r}: cannot be evaluated ({type(exc).__name__})") from None
    if expr.has(sp.zoo, sp.oo, -sp.oo, sp.nan):
        raise ExpressionError(f"in {shown!r}: the value is infinite or undefined")
    return expr


def _allowed(symbols: dict[str, sp.Symbol]) -> str:
    """What an expression may name, for the message of an unknown name."""
    functions = ", ".join(sorted(FUNCTIONS))
    if not symbols:
        return f"only numbers, pi (π), E, + - * / ** and the functions {functions}"
    return f"allowed names: {', '.join(sorted(symbols))}, pi (π), E; functions: {functions}"


def _check_size(root: ast.AST, text: str) -> None:
    """Refuse trees of more than MAX_NODES nodes or deeper than MAX_DEPTH (no recursion)."""
    count = 0
    stack = [(root, 1)]
    while stack:
        node, depth = stack.pop()
        count += 1
        if count > MAX_NODES:
            raise ExpressionError(f"{text!r} has more than {MAX_NODES} terms")
        if depth > MAX_DEPTH:
            raise ExpressionError(f"{text!r} is nested more than {MAX_DEPTH} levels")
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))


def _bounded(value: sp.Expr, text: str) -> sp.Expr:
    """`value` itself, after checking that a constant one is finite and not huge."""
    if not value.is_number:
        return value
    try:
        number = complex(sp.N(value, 15))
    except (ArithmeticError, TypeError, ValueError):
        raise ExpressionError(f"in {text!r}: a constant cannot be evaluated") from None
    if not (math.isfinite(number.real) and math.isfinite(number.imag)):
        raise ExpressionError(f"in {text!r}: a constant is infinite or undefined")
    if abs(number) > MAX_MAGNITUDE:
        raise ExpressionError(
            f"in {text!r}: constant {float(abs(number)):.3g} exceeds {MAX_MAGNITUDE:g} in magnitude"
        )
    return value


def _power(base: sp.Expr, exponent: sp.Expr, text: str) -> sp.Expr:
    """`base ** exponent`, refusing numeric exponents above MAX_EXPONENT in magnitude."""
    if exponent.is_number:
        e = complex(sp.N(exponent, 15))  # already bounded by _bounded
        if abs(e) > MAX_EXPONENT:
            raise ExpressionError(
                f"in {text!r}: exponent {abs(e):.3g} is too large (at most {MAX_EXPONENT})"
            )
    return base**exponent


def _translate(node: ast.AST, symbols: dict[str, sp.Symbol], text: str, allowed: str) -> sp.Expr:
    def rec(n: ast.AST) -> sp.Expr:
        return _translate(n, symbols, text, allowed)

    return _bounded(_node(node, rec, symbols, text, allowed), text)


def _node(node: ast.AST, rec, symbols: dict[str, sp.Symbol], text: str, allowed: str) -> sp.Expr:
    if isinstance(node, ast.Constant) and type(node.value) in (int, float):
        value = node.value
        if not (math.isfinite(value) and abs(value) <= MAX_MAGNITUDE):
            raise ExpressionError(f"in {text!r}: number {value:.3g} exceeds {MAX_MAGNITUDE:g}")
        return sp.Integer(value) if isinstance(value, int) else sp.Float(value)
    if isinstance(node, ast.Name):
        if node.id in symbols:
            return symbols[node.id]
        if node.id in CONSTANTS:
            return CONSTANTS[node.id]
        if node.id in FUNCTIONS:
            raise ExpressionError(f"in {text!r}: function {node.id!r} must be called")
        raise ExpressionError(f"in {text!r}: unknown name {node.id!r} ({allowed})")
    if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
        left, right = rec(node.left), rec(node.right)
        if isinstance(node.op, ast.Pow):
            return _power(left, right, text)
        return _BINOPS[type(node.op)](left, right)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
        operand = rec(node.operand)
        return -operand if isinstance(node.op, ast.USub) else operand
    if isinstance(node, ast.Call):
        name = node.func.id if isinstance(node.func, ast.Name) else None
        if name in symbols or name in CONSTANTS:
            raise ExpressionError(f"in {text!r}: {name!r} is a value, not a function")
        if name in FUNCTIONS and node.keywords:
            raise ExpressionError(f"in {text!r}: {name}() takes no keyword arguments")
        if name in FUNCTIONS and len(node.args) != ARITY[name]:
            raise ExpressionError(
                f"in {text!r}: {name}() takes {ARITY[name]} argument(s), got {len(node.args)}"
            )
        if name not in FUNCTIONS:
            shown = name or ast.unparse(node.func)
            raise ExpressionError(
                f"in {text!r}: call of {shown!r} is not allowed "
                f"(functions: {', '.join(sorted(FUNCTIONS))})"
            )
        args = [rec(a) for a in node.args]
        if name in _GROWING and args[0].is_number:
            x = complex(sp.N(args[0], 15))
            if (x.real if name == "exp" else abs(x)) > MAX_EXP_ARGUMENT:
                raise ExpressionError(
                    f"in {text!r}: {name}() of a constant above {MAX_EXP_ARGUMENT:g} is too large"
                )
        return FUNCTIONS[name](*args)
    raise ExpressionError(
        f"in {text!r}: {ast.unparse(node)!r} is not allowed "
        "(only numbers, names, + - * / ** and math functions)"
    )


_UNIT = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([A-Za-zµ]+)\s*$")


def parse_number(value: float | int | str) -> float:
    """A real number from a TOML value: 1.5, "pi/3", "-pi/12", "2*pi/3", "60deg", "60°",
    "2.5 rad"."""
    if isinstance(value, bool):
        raise ExpressionError(f"expected a number (got {value!r})")
    if isinstance(value, int | float):
        number = float(value)
        if not math.isfinite(number):
            raise ExpressionError(f"must be a finite number (got {number})")
        return number
    if not isinstance(value, str):
        raise ExpressionError(f"expected a number or an expression such as 'pi/3' (got {value!r})")
    text, scale = angle_unit(value)
    unit = _UNIT.match(text)
    if unit and unit.group(2) == "pi":
        raise ExpressionError(f"write the product with *: '{unit.group(1)}*pi'")
    if unit and unit.group(2) not in ("e", "E"):
        raise ExpressionError(
            f"a unit ({unit.group(2)}) is not read: write the number alone, in rad "
            "for an angle (or as '60deg' or '1.2 rad') and in the model's length unit (m) for "
            "a length"
        )
    expr = parse_expression(text)
    if expr.free_symbols:
        raise ExpressionError(f"{value!r} is not a constant")
    try:
        number = complex(sp.N(expr, 30))
    except (ArithmeticError, TypeError, ValueError):
        raise ExpressionError(f"{value!r} cannot be evaluated to a number") from None
    if abs(number.imag) > 0 or not math.isfinite(number.real):
        raise ExpressionError(f"{value!r} is not a finite real number")
    return number.real * scale
