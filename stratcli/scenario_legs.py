"""A scenario's legs resolved into `LegSpec`s, with every problem of theirs (`scenario._resolve`):
the choice of [[legs]] or [decompose], each leg's method, stratum, via and duration."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from pydantic import ValidationError

from .controls import MAX_PERIODS_PER_LEG
from .errors import InputError, Problem
from .models.system import System
from .planners import PLANNERS
from .planners.plugins import ENTRY_POINTS, PLUGINS
from .schema_problems import suggested, validation_problems
from .settings import LieSettings, PlannerSettings
from .stratified import LegSpec

if TYPE_CHECKING:
    from .scenario import LegEntry, Scenario

__all__ = ["MANY_PLANNERS", "leg_specs", "mode_problems", "unknown_method"]

MANY_PLANNERS = 6  # an unknown method's message lists the planners up to this many


def mode_problems(scenario: Scenario, system: System) -> list[Problem]:
    """[[legs]] or [decompose] (one of them), and [decompose]'s strata known to the model."""
    problems: list[Problem] = []
    if scenario.legs is None and scenario.decompose is None:
        problems.append(
            Problem(
                "legs",
                "give either [[legs]] (the strata in order) or a [decompose] table (auto "
                "mode: stratplan finds the sequence); the scenario has neither",
            )
        )
    elif scenario.legs is not None and scenario.decompose is not None:
        problems.append(
            Problem(
                "decompose",
                "give either [[legs]] (the strata in order) or a [decompose] table (auto "
                "mode), not both",
            )
        )
    for i, name in enumerate((scenario.decompose.strata or []) if scenario.decompose else []):
        if name not in system.strata:
            problems.append(
                Problem(
                    f"decompose.strata[{i}]",
                    f"unknown stratum {name!r} (this model has: {', '.join(system.strata)})",
                )
            )
    return problems


def unknown_method(method: str, plugins: list[Problem]) -> str:
    """What a leg's unknown `method` is told: the planners it may name (stratplan's two and a
    count of one's own beyond `MANY_PLANNERS`), a close name, and how one's own is found
    (`plugins`: problems of importing them, whose module may be the one missing)."""
    known = " or ".join(repr(m) for m in PLANNERS)
    if len(PLANNERS) > MANY_PLANNERS:  # (a message of 30 names said nothing)
        own = [m for m in PLANNERS if m not in ("newton", "lie")]
        known = f"'lie', 'newton' or one of {len(own)} of your own ({own[0]!r}, ...)"
    message = suggested(f"must be {known} (got {method!r})", method)
    if plugins:  # (its module may be the one that failed)
        return message + f"; a module of {PLUGINS} or {ENTRY_POINTS} failed to import"
    if "did you mean" not in message:  # no name close to it: how one's own is found
        message += (
            f"; a planner of your own: import its module first, or name the module in "
            f"{PLUGINS} or under the entry points {ENTRY_POINTS}"
        )
    return message


def leg_specs(
    scenario: Scenario,
    system: System,
    goal: np.ndarray | None,
    vector: Callable,
    plugins: list[Problem],
    problems: list[Problem],
) -> tuple[list[LegSpec], bool]:
    """The [[legs]] as `LegSpec`s (the last leg's goal is task.goal), their problems added to
    `problems`; and whether a leg spans more basis periods than the basis can take (its
    periodic conditions then say nothing). `vector(values, where)`: a configuration of the
    model's size, or None with a problem."""
    p = scenario.planner
    legs: list[LegSpec] = []
    spans = False  # a leg of more basis periods than the basis can take
    for i, entry in enumerate(scenario.legs or []):
        where = f"legs[{i}]"
        if entry.method not in PLANNERS:
            problems.append(Problem(f"{where}.method", unknown_method(entry.method, plugins)))
            continue
        if entry.stratum not in system.strata:
            problems.append(
                Problem(
                    f"{where}.stratum",
                    f"unknown stratum {entry.stratum!r} (this model has: "
                    f"{', '.join(system.strata)})",
                )
            )
        last = i == len(scenario.legs) - 1
        leg_goal = vector(entry.goal, f"{where}.goal")
        if leg_goal is None and entry.goal is None:
            if not last:
                problems.append(
                    Problem(
                        f"{where}.goal",
                        "a via configuration is required (only the last "
                        "leg may omit its goal, which is then task.goal)",
                    )
                )
            leg_goal = goal
        elif last and goal is not None and leg_goal is not None:
            if not np.allclose(leg_goal, goal, rtol=0.0, atol=1e-12, equal_nan=True):
                problems.append(
                    Problem(
                        f"{where}.goal",
                        "the last leg's goal differs from task.goal; omit it or make them equal",
                    )
                )
        if leg_goal is not None:
            legs.append(
                LegSpec(
                    stratum=entry.stratum,
                    goal=leg_goal,
                    method=entry.method,
                    duration=entry.duration or p.leg_duration,
                    lie=_leg_lie(entry, i, p, problems),
                )
            )
            duration = (
                (legs[-1].lie or p.lie).step_duration
                if entry.method == "lie"
                else (legs[-1].duration)
            )
            if duration / p.basis.period > MAX_PERIODS_PER_LEG:
                spans = True  # (one line for every such leg of the same duration)
                problems.append(
                    Problem(
                        f"{where}.duration" if entry.duration else "planner.basis.period",
                        f"a leg of {duration:g} s spans {duration / p.basis.period:.3g} basis "
                        f"periods (at most {MAX_PERIODS_PER_LEG}); use a longer period or "
                        "a shorter leg",
                    )
                )
        if entry.method == "lie" and entry.duration is not None:
            problems.append(
                Problem(
                    f"{where}.duration",
                    "a Lie leg lasts (number of steps) x lie.step_duration; set "
                    "lie = { step_duration = ... } instead",
                )
            )
        if entry.method != "lie" and entry.lie is not None:
            problems.append(Problem(f"{where}.lie", 'only legs with method = "lie" take it'))
    return legs, spans


def _leg_lie(entry: LegEntry, i: int, planner: PlannerSettings, problems: list[Problem]):
    """A Lie leg's settings: [planner.lie] with the leg's own `lie` keys on top."""
    if entry.method != "lie" or entry.lie is None:
        return None
    where = f"legs[{i}].lie"
    try:
        return dataclasses.replace(planner.lie, **entry.lie)
    except ValidationError as exc:  # an unknown key lists those of [planner.lie]
        found = validation_problems(exc, root=LieSettings)
        problems.extend(InputError(found).prefixed(where).problems)
    except TypeError:  # an unknown key (dataclasses.replace refuses it before pydantic)
        names = [f.name for f in dataclasses.fields(LieSettings)]
        known, unknown = ", ".join(names), ", ".join(sorted(set(entry.lie) - set(names)))
        problems.append(Problem(where, f"unknown key {unknown} (allowed: {known})"))
    return None
