"""What the result values compare by: every field's value, arrays element by element (no I/O).

A dataclass holding arrays cannot use the generated `__eq__` (an array's `==` is an array),
and identity made a leg unequal to its own pickle. `ByValue` compares every field (arrays by
shape and elements, NaN equal to NaN, as a failed leg's end is) and hashes a few scalar ones.
"""

from __future__ import annotations

import math
from dataclasses import fields
from typing import Any, ClassVar

import numpy as np

from .frozen_json import MadeAgainOnUnpickling  # (stdlib only: HoldsDocument's too)

__all__ = ["ByValue", "MadeAgainOnUnpickling", "same"]


def same(a: Any, b: Any) -> bool:
    """Whether two field values are equal: arrays by shape and elements (NaN = NaN), tuples
    and lists item by item, NaN floats equal, anything else by `==`."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        if a.shape != b.shape:
            return False
        numeric = a.dtype.kind in "fc" and b.dtype.kind in "fc"
        return bool(np.array_equal(a, b, equal_nan=numeric))
    if isinstance(a, tuple | list) and isinstance(b, tuple | list):
        return type(a) is type(b) and len(a) == len(b) and all(map(same, a, b))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return bool(a == b)


class ByValue(MadeAgainOnUnpickling):
    """Equality of a (frozen) dataclass by the values of all its fields; hash by the fields
    named in `_hashed` (equal values hash alike)."""

    _hashed: ClassVar[tuple[str, ...]] = ()

    def __eq__(self, other: object) -> bool:
        if self is other:
            return True
        if type(other) is not type(self):
            return NotImplemented
        return all(same(getattr(self, f.name), getattr(other, f.name)) for f in fields(self))

    def __hash__(self) -> int:
        return hash((type(self).__name__, *(getattr(self, name) for name in self._hashed)))
