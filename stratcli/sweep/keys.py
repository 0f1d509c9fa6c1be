"""Keys of a sweep file: where a value goes in a scenario dict, and checking values there.

A key names a scenario value: ``start.NAME``, ``goal.NAME`` and ``legs[i].goal.NAME`` are
coordinates (NAME a coordinate of the model; ``task.`` may be written in front), anything else
a dotted path into the scenario (``planner.tolerance``), whose lists are indexed
(``constraints.obstacles[0].centre[1]``). A URDF configuration given by name
(joints, then ``attitude`` or ``rpy``) takes ``rx``, ``ry``, ``rz`` as components of its
attitude, a rotation vector (``rpy`` converted to one). A value is checked by loading the base
scenario with it (`stratcli.load_scenario`); its problems are named by the sweep file's field.
"""

from __future__ import annotations

import copy
import re
from typing import Any

import numpy as np

from ..errors import InputError, Problem
from ..models.numbers import parse_number
from ..scenario import load_scenario

MAX_TASKS = 1_000_000
VECTORS = ("start", "goal")
ATTITUDE = ("rx", "ry", "rz")  # a URDF model's attitude: components of `attitude` by name
_PART = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:\[(\d+)\])?$")


def _parts(key: str) -> list[str | int]:
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
    parts = _parts(key)
    return (len(parts) == 3 and parts[0] == "task") or (
        len(parts) == 4 and parts[0] == "legs" and parts[2] == "goal"
    )


def changes_task(key: str) -> bool:
    """Whether `key` changes the task itself (its start, goal, legs or model), so that the
    base scenario's [reference] energy (the paper's, for its task) is not this task's."""
    return _parts(key)[0] in ("task", "legs", "model")


def assign(scenario: dict[str, Any], key: str, value: Any, states: tuple[str, ...]) -> None:
    """Put `value` at `key` in `scenario` (a coordinate name indexes its vector)."""
    parts = _parts(key)
    node: Any = scenario
    for i, part in enumerate(parts[:-1]):
        if isinstance(part, int):
            if not isinstance(node, list) or part >= len(node):
                where = ".".join(str(p) for p in parts[:i])
                raise ValueError(f"the scenario has no {where}[{part}]")
            node = node[part]
            continue
        if not isinstance(node, dict):
            raise ValueError(f"{part} is not inside a table")
        if part not in node:
            if parts[i + 1] in states or isinstance(parts[i + 1], int):
                raise ValueError(f"the scenario has no {'.'.join(map(str, parts[: i + 1]))}")
            node[part] = {}
        node = node[part]
    last = parts[-1]
    if isinstance(node, dict) and last in ATTITUDE and is_coordinate(key):
        node["attitude"] = _attitude(node, key)  # a URDF configuration given by name
        node.pop("rpy", None)
        node["attitude"][ATTITUDE.index(last)] = value
        return
    if isinstance(node, list) and isinstance(last, int) and not is_coordinate(key):
        if last >= len(node):  # an entry of a list setting: an obstacle's centre[0], say
            raise ValueError(f"the scenario has no {_dotted(parts)}")
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


def _dotted(parts: list[str | int]) -> str:
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
    from .. import so3

    return [float(x) for x in so3.log(so3.rpy_to_matrix(angles))]


def key_problem(base, key: str, states, field: str, problems: list[Problem]) -> bool:
    """Whether `key` names no place in the base scenario (then reported, once)."""
    try:
        assign(copy.deepcopy(base), key, 0.0, states)
    except ValueError as exc:
        problems.append(Problem(field, str(exc)))
        return True
    return False


def valid_key(key: str) -> bool:
    try:
        _parts(key)
        return True
    except ValueError:
        return False


def number(value: Any, field: str, problems: list[Problem]) -> float | None:
    try:
        return parse_number(value)
    except (ValueError, InputError) as exc:
        got = "" if "(got " in str(exc) else f" (got {value!r})"  # parse_number's may show it
        problems.append(Problem(field, f"{exc}{got}"))
        return None


def value_of(key: str, value: Any, field: str, problems: list[Problem]) -> Any:
    """A coordinate's value as a float ("pi/3" allowed); a setting's as it is."""
    if valid_key(key) and is_coordinate(key):
        return number(value, field, problems)
    return value


def axis_values(key: str, axis: Any, field: str, problems: list[Problem]) -> tuple:
    """A grid axis: its list of values, or `linspace = [a, b, n]` (a table with it)."""
    if hasattr(axis, "linspace"):
        a, b, n = axis.linspace
        lo = number(a, f"{field}.linspace[0]", problems)
        hi = number(b, f"{field}.linspace[1]", problems)
        if not isinstance(n, int) or isinstance(n, bool) or not 1 <= n <= MAX_TASKS:
            count = f"a count from 1 to {MAX_TASKS} (got {n!r})"
            problems.append(Problem(f"{field}.linspace[2]", count))
            return ()
        if lo is None or hi is None:
            return ()
        points = np.linspace(lo, hi, n)
        # a point that is 0 but for rounding is 0 (-pi/4 to pi/12 in 5 wrote 1.1e-16)
        points[np.abs(points) <= 1e-12 * max(abs(lo), abs(hi))] = 0.0
        ints = all(isinstance(v, int) and not isinstance(v, bool) for v in (a, b))
        if ints and not is_coordinate(key) and np.all(points == np.round(points)):
            return tuple(int(x) for x in np.round(points))  # an integer setting: seed, restarts
        return tuple(float(x) for x in points)
    if not axis:
        problems.append(Problem(field, "needs at least one value"))
    return tuple(value_of(key, v, f"{field}[{i}]", problems) for i, v in enumerate(axis))


def check_value(base, key, value, states, field, problems) -> None:
    """Load the base scenario with `key` = `value`; its problems, named `field`."""
    check_values(base, {key: value}, states, field, problems)


def check_values(base, values: dict[str, Any], states, field, problems) -> None:
    if value_missing := [k for k, v in values.items() if v is None]:
        del value_missing  # already reported (not a number)
        return
    scenario = copy.deepcopy(base)
    for key, value in values.items():
        try:
            assign(scenario, key, value, states)
        except ValueError as exc:
            problems.append(Problem(f'{field}."{key}"' if len(values) > 1 else field, str(exc)))
            return
    check_scenario(scenario, field, problems)


def check_scenario(scenario: dict[str, Any], field: str, problems: list[Problem]) -> None:
    try:
        load_scenario(scenario)
    except InputError as exc:
        for p in exc.problems:
            problem = Problem(field, f"{p.path}: {p.message}" if p.path else p.message)
            if problem not in problems:
                problems.append(problem)


_ANGLES = ("preset", "planar-manipulator", "urdf")  # model kinds whose coordinates are angles
_UNIT_OF = (  # the last part of a key that is no coordinate -> its unit
    (("duration", "leg_duration", "total_duration", "period", "step_duration"), "s"),
    (("clearance", "link_radius", "centre", "radius", "size", "mount"), "m"),
    (("joint_limits", "rotation"), "rad"),
    (("max_rate",), "rad/s"),
    (("max_acceleration",), "rad/s²"),
)


def unit_of(key: str, model_kind: str | None) -> str:
    """The unit of the values at `key` for an axis label ("rad", "s", "m"), or "" where it is
    not known (a custom model's coordinates, a dimensionless setting)."""
    robot = model_kind in _ANGLES  # else the model's own units, unknown here
    if is_coordinate(key):
        return "rad" if robot else ""
    last = next(p for p in reversed(_parts(key)) if isinstance(p, str))
    unit = next((unit for names, unit in _UNIT_OF if last in names), "")
    return unit if unit == "s" or robot else ""
