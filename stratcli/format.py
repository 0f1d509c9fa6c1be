"""Angles and configurations written for people (no I/O): `-π/3` where a value is an exact
multiple of π, else radians to 4 decimals; one copy for the decomposer's tables, the CLI and
the comparison records."""

from __future__ import annotations

import math
from collections.abc import Sequence
from fractions import Fraction

__all__ = ["format_angle", "format_configuration", "pi_fraction"]


def pi_fraction(x: float, max_denominator: int = 48) -> str | None:
    """`x` as a readable multiple of π ("-π/3", "π/4", "2π/3", "0") if exact to ~1e-12."""
    if math.isnan(x):
        return None
    f = Fraction(x / math.pi).limit_denominator(max_denominator)
    if abs(float(f) * math.pi - x) > 1e-12 * max(1.0, abs(x)):
        return None
    if f == 0:
        return "0"
    sign = "-" if f < 0 else ""
    num, den = abs(f.numerator), f.denominator
    head = "π" if num == 1 else f"{num}π"
    return f"{sign}{head}" if den == 1 else f"{sign}{head}/{den}"


def format_angle(x: float, style: str = "pi") -> str:
    """One entry for people: `-π/3` (style "pi", when exact) or `-1.0472` (radians); `*` if NaN."""
    if math.isnan(x):
        return "*"
    if style == "pi":
        frac = pi_fraction(x)
        if frac is not None:
            return frac
    return "0" if x == 0 else f"{x:.4f}".rstrip("0").rstrip(".")


def format_configuration(q: Sequence[float], style: str = "pi") -> str:
    """`(-π/3, π/3, 0, -π/12)` (style "pi") or `(-1.0472, 1.0472, 0, -0.2618)` ("rad")."""
    return "(" + ", ".join(format_angle(float(x), style) for x in q) + ")"
