"""Numbers in scenario files: 1.5, "pi/3", "-pi/12", "2*pi/3", "60deg", "60°", "2.5 rad".

Plain arithmetic of literals and the constants pi (π) and E is evaluated here, in decimal
arithmetic with 40 digits and rounded once to a float, without sympy (a scenario is read on
every run, and sympy costs 0.2 s to import). Anything else (functions, unknown names, bad
syntax) goes to `expressions.parse_number`, the sympy-backed parser, which evaluates it or
gives the error message; the values agree (both round a correctly computed value once).
"""

from __future__ import annotations

import ast
import math
import re
from decimal import Context, Decimal, DivisionByZero, InvalidOperation, Overflow

__all__ = ["ExpressionError", "angle_unit", "parse_length", "parse_number"]

_ANGLE = re.compile(  # a whole word ("grad" is no rad), in any case: 45 DEG, 2.5 radians
    r"^\s*(.+?)\s*(?<![A-Za-zµ])(degrees?|deg|°|radians?|rad)\s*$", re.IGNORECASE
)
_UNIT = re.compile(r"^\s*[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?\s*([A-Za-zµ°]+)\s*$")
_CONTEXT = Context(prec=40, Emax=999, Emin=-999, traps=[DivisionByZero, InvalidOperation, Overflow])
_PI = Decimal("3.141592653589793238462643383279502884197169399375")
_CONSTANTS = {"pi": _PI, "π": _PI, "E": Decimal("2.718281828459045235360287471352662497757")}
_MAX_LENGTH = 200  # longer text goes to the full parser, which bounds it
_MAX_POWER = 64
_MAX_MAGNITUDE = Decimal("1e15")  # larger constants: the full parser decides (it refuses them)


class ExpressionError(ValueError):
    """An expression that is not plain arithmetic in the allowed names."""


class _NotPlain(Exception):
    """Not plain constant arithmetic: the full parser decides."""


def _eval(node: ast.AST) -> Decimal:
    value = _value(node)
    if abs(value) > _MAX_MAGNITUDE:
        raise _NotPlain
    return value


def _value(node: ast.AST) -> Decimal:
    if isinstance(node, ast.Expression):
        return _eval(node.body)
    if isinstance(node, ast.Constant) and type(node.value) in (int, float):
        return Decimal(repr(node.value)) if isinstance(node.value, float) else Decimal(node.value)
    if isinstance(node, ast.Name) and node.id in _CONSTANTS:
        return _CONSTANTS[node.id]
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.UAdd | ast.USub):
        value = _eval(node.operand)
        return _CONTEXT.minus(value) if isinstance(node.op, ast.USub) else value
    if isinstance(node, ast.BinOp):
        a, b = _eval(node.left), _eval(node.right)
        if isinstance(node.op, ast.Add):
            return _CONTEXT.add(a, b)
        if isinstance(node.op, ast.Sub):
            return _CONTEXT.subtract(a, b)
        if isinstance(node.op, ast.Mult):
            return _CONTEXT.multiply(a, b)
        if isinstance(node.op, ast.Div):
            return _CONTEXT.divide(a, b)
        if isinstance(node.op, ast.Pow) and b == b.to_integral_value() and abs(b) <= _MAX_POWER:
            return _CONTEXT.power(a, int(b))
    raise _NotPlain


def angle_unit(text: str) -> tuple[str, float]:
    """`text` without a trailing angle unit, and that unit in rad: ("60", π/180) for "60deg",
    "60°" or "60 degrees", ("2.5", 1.0) for "2.5 rad" or "2.5 radians" (angles are rad; the
    unit may still be written), in any case."""
    match = _ANGLE.match(text)
    if match is None:
        return text, 1.0
    return match.group(1), 1.0 if match.group(2).lower().startswith("rad") else math.pi / 180.0


def _plain(text: str) -> float | None:
    """The value of plain constant arithmetic, or None when it is anything else."""
    if len(text) > _MAX_LENGTH:
        return None
    try:
        number = float(_eval(ast.parse(text.strip().replace("^", "**"), mode="eval")))
    except (_NotPlain, SyntaxError, ValueError, ArithmeticError, RecursionError):
        return None
    return number if math.isfinite(number) else None


def parse_number(value: float | int | str) -> float:
    """A real number from a TOML value: 1.5, "pi/3", "-pi/12", "2*pi/3", "60deg", "60°",
    "2.5 rad" (an angle's unit is read, in rad; no other unit is).

    Raises
    ------
    ExpressionError
        Not a finite real constant (the message says why).
    """
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
    number = _plain(text)
    if number is not None:
        return number * scale
    from .expressions import parse_number as full  # functions, names, and every error message

    return full(value)


def parse_length(value: float | int | str) -> float:
    """A length from a TOML value: as `parse_number` ("0.05", "1/20"), but no unit is read,
    an angle's neither: a clearance of "3deg" was read as 0.0524, a circle's centre
    ["-0.3 rad", "90deg"] as (-0.3, 1.5708).

    Raises
    ------
    ExpressionError
        A unit written, or not a finite real constant.
    """
    if isinstance(value, str):
        match = _ANGLE.match(value) or _UNIT.match(value)
        unit = match.group(match.lastindex) if match else None
        if unit is not None and unit not in ("pi", "π", "e", "E"):
            raise ExpressionError(
                f"a unit ({unit}) is not read on a length: write the number alone, in the "
                "model's length unit (m)"
            )
    return parse_number(value)
