"""Keys of a sweep file: checking them and their values against the base scenario.

Where a key puts its value is `stratcli.scenario_keys` (`Task.with_changes` takes the same
keys). A value is checked by loading the base scenario with it (`stratcli.load_scenario`); its
problems are named by the sweep file's field.
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from ..errors import InputError, Problem
from ..models.numbers import parse_number
from ..planner_contract import fault
from ..scenario import load_scenario
from ..scenario_keys import assign, is_coordinate
from ..scenario_keys import key_parts as _parts

MAX_TASKS = 1_000_000


def key_problem(base, key: str, states, field: str, problems: list[Problem]) -> bool:
    """Whether `key` names no place in the base scenario (then reported, once)."""
    try:
        assign(copy.deepcopy(base), key, 0.0, states)
    except ValueError as exc:
        problems.append(Problem(field, str(exc)))
        return True
    return False


def valid_key(key: str) -> bool:
    """Whether `key` is a dotted scenario key a sweep may vary (`task.goal[1]`, ...)."""
    try:
        _parts(key)
        return True
    except ValueError:
        return False


def number(value: Any, field: str, problems: list[Problem]) -> float | None:
    """`value` as a number (`parse_number`: "pi/3", "45deg"), or None with a problem on
    `field` appended."""
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
            count = f"must be a whole count of points from 1 to {MAX_TASKS} (got {n!r})"
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
    """Append to `problems` what `values` (key -> number) set into the scenario `base` does
    not pass (a task of the sweep that could not be loaded), on `field`."""
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
    """Append each problem `load_scenario` finds in `scenario` to `problems`, on `field`
    (once each); a planner of one's own that broke while its legs were checked is one such
    problem (its exception ended the whole sweep with a traceback, naming no task)."""
    try:
        load_scenario(scenario)
    except InputError as exc:
        for p in exc.problems:
            problem = Problem(field, f"{p.path}: {p.message}" if p.path else p.message)
            if problem not in problems:
                problems.append(problem)
    except Exception as exc:
        line = fault(exc, traceback_shown=False)
        if line is None:
            raise
        problems.append(Problem(field, line))


_ANGLES = ("preset", "planar-manipulator", "urdf")  # model kinds whose coordinates are angles
_UNIT_OF = (  # the last part of a key that is no coordinate -> its unit
    (("duration", "leg_duration", "total_duration", "period", "step_duration"), "s"),
    (("clearance", "link_radius", "centre", "radius", "size", "mount"), "m"),
    (("joint_limits", "rotation", "tolerance"), "rad"),  # tolerance: of the goal error
    (("max_rate",), "rad/s"),
    (("max_acceleration",), "rad/s²"),
)


def energy_unit(model_kind: str | None) -> str:
    """The energy's unit (∫|u|² dt of joint rates: rad²/s), or "" for a custom model's."""
    return "rad²/s" if model_kind in _ANGLES else ""


def unit_of(key: str, model_kind: str | None) -> str:
    """The unit of the values at `key` for an axis label ("rad", "s", "m"), or "" where it is
    not known (a custom model's coordinates, a dimensionless setting)."""
    robot = model_kind in _ANGLES  # else the model's own units, unknown here
    if is_coordinate(key):
        return "rad" if robot else ""
    # the nearest part that names a quantity: "constraints.joint_limits.q2[0]" is in rad as
    # "constraints.joint_limits[1]" is (its last part, a joint's name, named no unit)
    names = [p for p in reversed(_parts(key)) if isinstance(p, str)]
    unit = next((unit for part in names for known, unit in _UNIT_OF if part in known), "")
    return unit if unit == "s" or robot else ""
