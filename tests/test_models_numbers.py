"""Numbers in scenario files: the sympy-free path gives what the full parser gives."""

from __future__ import annotations

import math

import pytest

from stratcli.models import expressions
from stratcli.models.numbers import ExpressionError, parse_number

PLAIN = ["pi/3", "-pi/12", "2*pi/3", "60deg", "-45°", "1e-3", "(1+2)/7", "pi^2/4", "E**2", "π/5"]


@pytest.mark.parametrize("text", PLAIN)
def test_plain_arithmetic_equals_the_full_parser(text, monkeypatch):
    fast = parse_number(text)
    calls = []
    monkeypatch.setattr(expressions, "parse_number", lambda v: calls.append(v))
    assert parse_number(text) == fast and calls == []  # never reached the full parser
    monkeypatch.undo()
    assert fast == expressions.parse_number(text)


def test_a_caret_is_a_power_with_a_powers_precedence():
    """Python's `^` binds looser than `/`: "pi^2/4" must not become pi^(1/2)."""
    assert parse_number("pi^2/4") == parse_number("pi**2/4") == expressions.parse_number("pi^2/4")
    assert parse_number("pi^2/4") == pytest.approx(math.pi**2 / 4, rel=1e-15)


@pytest.mark.parametrize("text", ["sqrt(2)/2", "atan2(1, 2)", "cos(pi/3)"])
def test_functions_go_to_the_full_parser(text):
    assert parse_number(text) == expressions.parse_number(text)
    assert math.isfinite(parse_number(text))


@pytest.mark.parametrize(
    "text, words",
    [("x/2", "unknown name"), ("1/0", "infinite"), ("pi/", "cannot parse"), ("1e20", "exceeds")],
)
def test_what_is_not_a_number_gets_the_full_parsers_message(text, words):
    with pytest.raises(ExpressionError, match=words):
        parse_number(text)
    with pytest.raises(ExpressionError) as full:
        expressions.parse_number(text)
    with pytest.raises(ExpressionError) as fast:
        parse_number(text)
    assert str(fast.value) == str(full.value)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("5cm", "a unit (cm) is not read: write the number alone, in rad for an angle (or as "
         "'60deg' or '1.2 rad') and in the model's length unit (m) for a length"),
        ("-2.5 grad", "a unit (grad) is not read"),
        ("1e-3m", "a unit (m) is not read"),
        ("2pi", "write the product with *: '2*pi'"),
    ],
)  # fmt: skip
def test_a_number_with_a_unit_says_to_write_it_alone(text, message):
    with pytest.raises(ExpressionError) as info:
        parse_number(text)
    assert str(info.value).startswith(message), info.value


@pytest.mark.parametrize(("text", "value"), [("60deg", math.pi / 3), ("30 °", math.pi / 6),
                                            ("2e3", 2000.0), ("2*pi", 2 * math.pi),
                                            ("-2.5 rad", -2.5), ("pi/2rad", math.pi / 2),
                                            ("2*pi/3 rad", 2 * math.pi / 3),
                                            ("2.5 radians", 2.5), ("45 DEG", math.pi / 4),
                                            ("90 degrees", math.pi / 2),
                                            ("1 Radian", 1.0)])  # fmt: skip
def test_angle_units_and_exponents_are_still_numbers(text, value):
    """rad is the unit angles are read in, so writing it changes nothing (a user's "-2.5 rad"
    joint limit was refused while "-143deg" was read)."""
    assert parse_number(text) == pytest.approx(value)
    assert expressions.parse_number(text) == pytest.approx(value)
