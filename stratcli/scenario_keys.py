"""Keys that name a value in a scenario dict: where a sweep's keys and `Task.with_changes`'
dotted keys put a value.

A key names a scenario value: ``start.NAME``, ``goal.NAME`` and ``legs[i].goal.NAME`` are
coordinates (NAME a coordinate of the model; ``task.`` may be written in front), anything else
a dotted path into the scenario (``planner.tolerance``), whose lists are indexed
(``constraints.obstacles[0].centre[1]``). A URDF configuration given by name
(joints, then ``attitude`` or ``rpy``) takes ``rx``, ``ry``, ``rz`` as components of its
attitude, a rotation vector (``rpy`` converted to one).
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from .errors import InputError
from .models.numbers import parse_number

__all__ = [
    "ATTITUDE",
    "VECTORS",
    "assign",
    "changes_task",
    "dotted",
    "holds",
    "is_coordinate",
    "key_parts",
]

VECTORS = ("start", "goal")
ATTITUDE = ("rx", "ry", "rz")  # a URDF model's attitude: components of `attitude` by name
_PART = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:\[(\d+)\])?$")


def key_parts(key: str) -> list[str | int]:
    """`key`'s names and indices in order (`goal.q1` -> ["task", "goal", "q1"]); raises
    `ValueError` for a key that is no dotted name."""
    parts: list[str | int] = []
    for piece in key.split("."):
        match = _PART.match(piece)
        if not match:
            raise ValueError(f"not a dotted name such as goal.q1 or planner.tolerance ({piece!r})")
        parts.append(match.group(1))
        if match.group(2) is not None:
            parts.append(int(match.group(2)))
    if parts[0] in VECTORS:
        parts.insert(0, "task")
    return parts


def is_coordinate(key: str) -> bool:
    """Whether `key` names one coordinate of a start, goal or via (a number)."""
    parts = key_parts(key)
    return (len(parts) == 3 and parts[0] == "task") or (
        len(parts) == 4 and parts[0] == "legs" and parts[2] == "goal"
    )


def changes_task(key: str) -> bool:
    """Whether `key` changes the task itself (its start, goal, legs or model), so that the
    base scenario's [reference] energy (the paper's, for its task) is not this task's."""
    return key_parts(key)[0] in ("task", "legs", "model")


def assign(scenario: dict[str, Any], key: str, value: Any, states: tuple[str, ...]) -> None:
    """Put `value` at `key` in `scenario` (a coordinate name indexes its vector)."""
    parts = key_parts(key)
    node: Any = scenario
    for i, part in enumerate(parts[:-1]):
        if isinstance(part, int):
            if not isinstance(node, list) or part >= len(node):
                raise ValueError(f"the scenario has no {dotted(parts[: i + 1])}")
            node = node[part]
            continue
        if not isinstance(node, dict):
            raise ValueError(f"{part} is not inside a table")
        if part not in node:
            if parts[i + 1] in states or isinstance(parts[i + 1], int):
                last_leg = parts[0] == "legs" and part == "goal"  # the last leg's is task.goal
                hint = " (the last leg's goal is task.goal)" if last_leg else ""
                raise ValueError(f"the scenario has no {dotted(parts[: i + 1])}{hint}")
            node[part] = {}
        node = node[part]
    last = parts[-1]
    if isinstance(node, dict) and last in ("attitude", "rpy") and is_coordinate(key):
        node.pop("rpy" if last == "attitude" else "attitude", None)  # a URDF attitude, whole
        node[last] = value
        return
    if isinstance(node, dict) and last in ATTITUDE and is_coordinate(key):
        node["attitude"] = _attitude(node, key)  # a URDF configuration given by name
        node.pop("rpy", None)
        node["attitude"][ATTITUDE.index(last)] = value
        return
    if isinstance(node, list) and isinstance(last, int) and not is_coordinate(key):
        if last >= len(node):  # an entry of a list setting: an obstacle's centre[0], say
            raise ValueError(f"the scenario has no {dotted(parts)}")
        node[last] = value
    elif isinstance(node, list):
        if last not in states:
            raise ValueError(f"unknown coordinate {last!r} (this model has: {', '.join(states)})")
        node[states.index(last)] = value
    elif isinstance(node, dict) and is_coordinate(key) and states and last not in states:
        # a URDF configuration by name: its keys are the joints and rx, ry, rz (the names
        # the scenario takes, attitude and rpy, are vectors, no key of a sweep)
        raise ValueError(f"unknown coordinate {last!r} (this model has: {', '.join(states)})")
    elif isinstance(node, dict) and not isinstance(last, int):
        node[last] = value
    else:
        raise ValueError(f"cannot set {key} in the scenario")


def dotted(parts: list[str | int]) -> str:
    """`parts` as a key is written: `constraints.obstacles[0].centre[2]`."""
    return "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in parts).lstrip(".")


def _attitude(table: dict[str, Any], key: str) -> list:
    """A URDF configuration table's attitude as a rotation vector (a list, copied): its
    `attitude`, or its `rpy` converted (one component of it set by `key`, the others kept)."""
    if "rpy" not in table:
        value = table.get("attitude", [0.0, 0.0, 0.0])  # (the default of a URDF table)
        if value == "*":
            return ["*"] * 3
        if not isinstance(value, list) or len(value) != 3:
            raise ValueError(f"cannot set {key}: the scenario's attitude is not three angles")
        return list(value)
    rpy = table["rpy"]
    if rpy == "*" or (isinstance(rpy, list) and "*" in rpy):
        return ["*"] * 3
    try:
        angles = np.array([parse_number(a) for a in rpy], dtype=float)
    except (TypeError, ValueError, InputError):
        raise ValueError(f"cannot set {key}: the scenario's rpy is not three angles") from None
    from . import so3

    return [float(x) for x in so3.log(so3.rpy_to_matrix(angles))]


def holds(node: Any, part: str | int) -> bool:
    """Whether `node[part]` is there: a table's key, a list's index."""
    if isinstance(node, dict):
        return part in node
    return isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node)
