"""The values of a sweep file's [sweep.grid], [sweep.random] and [[sweep.task]], checked.

Each function adds the problems of its table to `Base.problems` and checks what it can: a
value's form always (a number, a count), its key if the base scenario's coordinates are
known, the scenario it makes only if the base (with `set`) loads. A value the schema refused
is not looked at (`Base.pruned`): its problem is reported already.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import Problem
from ..models.specs import model_states
from .keys import (
    MAX_TASKS,
    axis_values,
    check_value,
    check_values,
    is_coordinate,
    key_problem,
    number,
    valid_key,
    value_of,
)

MAX_CHECKED = 200  # values of one axis checked by loading the scenario with them
LISTED = 3  # values of one axis whose problems are listed; the others are counted


@dataclass
class Base:
    """What the values are checked against, and the problems found so far."""

    scenario: dict[str, Any] | None  # the base scenario with `set` applied (None: unknown)
    states: tuple[str, ...] | None  # its model's coordinates (None: unknown)
    loads: bool  # whether it loads: a value's scenario can be checked by loading it
    pruned: set[tuple] = field(default_factory=set)  # file locations the schema refused
    problems: list[Problem] = field(default_factory=list)
    hidden: tuple[str, ...] = ()  # scenario paths with problems: keys there are not checked
    text: str | None = None  # the base scenario file's text (None: an inline [scenario])

    def key_problem(self, key: str, where: str) -> bool:
        """Whether `key` names no place in the base scenario (reported); False if unknown."""
        if self.states is None or self.scenario is None or not valid_key(key):
            return False
        path = key.removeprefix("task.")
        path = f"task.{path}" if path.split(".")[0] in ("start", "goal") else path
        if any(path.startswith(h) or h.startswith(path.rsplit(".", 1)[0]) for h in self.hidden):
            name = key.rsplit(".", 1)[-1]  # the base is wrong there: its problem says so
            if is_coordinate(key) and name not in self.states:
                known = ", ".join(self.states)
                self.problems.append(
                    Problem(where, f"unknown coordinate {name!r} (this model has: {known})")
                )
            return True
        return key_problem(self.scenario, key, self.states, where, self.problems)

    def check(self, values: dict[str, Any], where: str) -> None:
        """The base scenario loaded with `values` (only when it loads without them)."""
        if self.loads:
            check_values(self.scenario, values, self.states, where, self.problems)


def base_states(base: dict[str, Any]) -> tuple[str, ...] | None:
    """The coordinates of a base scenario that does not load, if its model can be built."""
    return model_states(base.get("model"))


def grid_axes(grid: dict[str, Any], base: Base) -> list[tuple[Any, ...]]:
    """The values of each axis of [sweep.grid], checked."""
    axes = []
    for key, axis in grid.items():
        where = f'sweep.grid."{key}"'
        if ("sweep", "grid", key) in base.pruned:
            continue
        values = axis_values(key, axis, where, base.problems)
        axes.append(values)
        if base.key_problem(key, where):
            continue
        found: list[list[Problem]] = []  # each value's problems
        for i, value in enumerate(values[:MAX_CHECKED]):
            if base.loads:
                found.append([])
                check_value(base.scenario, key, value, base.states, f"{where}[{i}]", found[-1])
        base.problems += _once(found, where)
    total = int(np.prod([max(1, len(a)) for a in axes]))
    if total > MAX_TASKS and len(axes) == len(grid):
        base.problems.append(Problem("sweep.grid", f"{total} tasks (at most {MAX_TASKS})"))
    return axes


def _once(found: list[list[Problem]], where: str, every: str = "every value") -> list[Problem]:
    """The problems of an axis's values, one line at the axis for a problem every value has
    (an unknown setting such as "planner.harmonics" is not a problem of each value)."""
    if len(found) > 1 and found[0]:
        shared = {p.message for p in found[0]}
        for problems in found[1:]:
            shared &= {p.message for p in problems}
        if shared:
            kept = [p for problems in found for p in problems if p.message not in shared]
            common = [Problem(where, f"{m} ({every})") for m in sorted(shared)]
            return common + kept
    return _first(found, where)


def _first(found: list[list[Problem]], where: str) -> list[Problem]:
    """The problems of the first `LISTED` values that have any, and a count of the others:
    a leg's goal locked against the axis made one line per value (200 on a long axis)."""
    bad = [problems for problems in found if problems]
    if len(bad) <= LISTED + 1:
        return [p for problems in bad for p in problems]
    more = f"{len(bad) - LISTED} more of its {len(found)} values checked have problems too"
    return [p for problems in bad[:LISTED] for p in problems] + [Problem(where, more)]


def random_ranges(ranges: dict[str, list[Any]], base: Base) -> dict[str, list[Any]]:
    """The [low, high] of each key of [sweep.random], checked: a coordinate's and a real
    setting's as floats (drawn uniformly, whatever the bounds are written as), an integer
    setting's (`planner.seed`, `decompose.max_length`: the scenario refuses a value between
    integers) as integers, drawn from low to high inclusive."""
    out = {}
    for key, pair in ranges.items():
        where = f'sweep.random.ranges."{key}"'
        if ("sweep", "random", "ranges", key) in base.pruned:
            continue
        known = not base.key_problem(key, where)  # whatever the bounds are: every problem
        if known and base.loads and pair and _takes_names(base, key, pair[0]):
            why = (
                f"a random range draws a number between two bounds, and {key} takes names "
                f"({pair[0]!r}): vary it over a list in [sweep.grid] or [[sweep.task]]"
            )
            base.problems.append(Problem(where, why))
            continue
        bounds = [number(v, f"{where}[{i}]", base.problems) for i, v in enumerate(pair)]
        if known and len(pair) == 2 and _integer_setting(base, key, pair):
            bounds = [int(v) for v in pair]
        if len(pair) != 2:
            base.problems.append(Problem(where, f"needs [low, high] (got {len(pair)} values)"))
        elif None not in bounds and not bounds[0] < bounds[1]:
            base.problems.append(Problem(where, f"low must be below high (got {pair})"))
        elif None not in bounds and known and base.loads:  # a problem of both: once
            found: list[list[Problem]] = [[], []]
            for i, b in enumerate(bounds):
                check_value(base.scenario, key, b, base.states, f"{where}[{i}]", found[i])
            base.problems += _once(found, where, "both bounds")
        out[key] = bounds
    return out


def _takes_names(base: Base, key: str, value: Any) -> bool:
    """Whether `value` is a name (no number) that the scenario takes at `key`
    (planner.continuity = "l-C0"): a random range of names was read as two expressions."""
    if not isinstance(value, str) or number(value, "", []) is not None:
        return False
    found: list[Problem] = []
    check_value(base.scenario, key, value, base.states, "", found)
    return not found


def _integer_setting(base: Base, key: str, pair: list[Any]) -> bool:
    """Whether a range with integer bounds is of an integer setting: the scenario refuses the
    value halfway between them as no integer (an obstacle's centre [-1, 1] is drawn from the
    reals; a new user's obstacles were drawn at -1, 0 and 1 alone)."""
    whole = all(isinstance(v, int) and not isinstance(v, bool) for v in pair)
    if not whole or (valid_key(key) and is_coordinate(key)) or not base.loads:
        return False
    refused: list[Problem] = []
    check_value(base.scenario, key, (pair[0] + pair[1]) / 2 + 0.25, base.states, "", refused)
    return any("integer" in p.message for p in refused)


def task_rows(rows: list[dict[str, Any]], base: Base) -> tuple[tuple[str, ...], list[dict]]:
    """The keys of [[sweep.task]] (in order of appearance) and its rows, checked."""
    kept = [i for i in range(len(rows)) if ("sweep", "task", i) not in base.pruned]
    keys = tuple(dict.fromkeys(k for i in kept for k in rows[i]))
    first = {k: next(i for i in kept if k in rows[i]) for k in keys}  # where a key came from
    bad = {k for k in keys if base.key_problem(k, f'sweep.task[{first[k]}]."{k}"')}
    out = []
    for i in kept:
        row = rows[i]
        values = {
            k: value_of(k, v, f'sweep.task[{i}]."{k}"', base.problems) for k, v in row.items()
        }
        if missing := [k for k in keys if k not in row]:
            setters = ", ".join(f"{k} (set by sweep.task[{first[k]}])" for k in missing)
            why = f"misses {setters}: every [[sweep.task]] sets the same keys"
            base.problems.append(Problem(f"sweep.task[{i}]", why))
            continue
        out.append(values)
        if i < MAX_CHECKED and not bad & set(row):
            base.check(values, f"sweep.task[{i}]")
    return keys, out
