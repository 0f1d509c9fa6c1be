"""Times given to a plan's or a leg's `controls`: numbers within its span (`checked_times`)."""

from __future__ import annotations

import numpy as np

from .arguments import wrong_type
from .errors import InputError, Problem

__all__ = ["TIME_ROUNDING", "checked_times"]

TIME_ROUNDING = 1e-9  # relative: how far outside [0, duration] `controls` still takes a time


def checked_times(t, total: float, within: str) -> tuple[np.ndarray, bool]:
    """`t` as a 1-D float array and whether it was a single time, or a TypeError (not
    numbers: a string "1" was read as 1.0, None as NaN) or an InputError (2-D, or outside
    [0, total] beyond `TIME_ROUNDING`, naming `within` and its span)."""
    try:
        single = np.ndim(t) == 0
        if isinstance(t, str | bytes) or np.asarray(t).dtype.kind not in "iuf":
            raise TypeError
        t = np.atleast_1d(np.asarray(t, dtype=float))
    except (TypeError, ValueError):
        raise wrong_type("t", "a time or an array of times (s)", t) from None
    if t.ndim > 1:  # (its rows would be read as times and fail deep inside)
        shape = "x".join(map(str, t.shape))
        raise InputError([Problem("t", f"must be a time or a 1-D array of times (got {shape})")])
    slack = TIME_ROUNDING * total
    outside = ~(np.isfinite(t) & (t >= -slack) & (t <= total + slack))
    if outside.any():
        bad = t[outside][0]
        digits = 6 if f"{bad:g}" != f"{total:g}" else 17  # 0.666667 beyond 0.666667?
        raise InputError(
            [
                Problem(
                    "t",
                    f"must be within {within}, from 0 to {total:.{digits}g} s "
                    f"(got {bad:.{digits}g})",
                )
            ]
        )
    return t, single
