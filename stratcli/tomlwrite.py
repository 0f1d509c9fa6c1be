"""A small TOML writer for scenario dictionaries (the standard library only reads TOML).

A scenario given as a plain `dict` is recorded as `scenario.toml` like one read from a file,
so every record can be re-planned with `stratplan plan`. Supports what scenarios hold:
tables, arrays of tables, arrays, strings, booleans, integers and finite floats.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

__all__ = ["dumps"]


def _key(key: str) -> str:
    bare = key and all(c.isalnum() or c in "-_" for c in key) and key.isascii()
    return key if bare else json.dumps(key)


def _value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"not a finite number: {value!r}")
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a valid TOML basic string
    if isinstance(value, Mapping):
        items = ", ".join(f"{_key(str(k))} = {_value(v)}" for k, v in value.items())
        return "{ " + items + " }" if items else "{}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if hasattr(value, "tolist"):  # numpy arrays and scalars
        return _value(value.tolist())
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def _is_table_array(value: Any) -> bool:
    return (
        isinstance(value, list | tuple)
        and bool(value)
        and all(isinstance(v, Mapping) for v in value)
    )


def _table(data: Mapping, path: list[str], out: list[str]) -> None:
    plain = [(k, v) for k, v in data.items() if v is not None and not _nested(v)]
    for k, v in plain:
        out.append(f"{_key(str(k))} = {_value(v)}")
    for k, v in data.items():
        if isinstance(v, Mapping):
            name = ".".join(_key(p) for p in [*path, str(k)])
            out.extend(["", f"[{name}]"])
            _table(v, [*path, str(k)], out)
        elif _is_table_array(v):
            name = ".".join(_key(p) for p in [*path, str(k)])
            for item in v:
                out.extend(["", f"[[{name}]]"])
                _table(item, [*path, str(k)], out)


def _nested(value: Any) -> bool:
    return isinstance(value, Mapping) or _is_table_array(value)


def dumps(data: Mapping[str, Any]) -> str:
    """TOML text of `data` (None values are left out: TOML has no null)."""
    out: list[str] = []
    _table(data, [], out)
    return "\n".join(out).lstrip("\n") + "\n"
