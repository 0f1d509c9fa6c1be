"""Settings of a scenario that contradict each other across its tables, one problem each:
Lie legs under limits the search keeps, an acceleration limit with controls that may jump,
optimised durations without what they need."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .errors import Problem
from .node_margins import searchable

if TYPE_CHECKING:
    from .constraints import Constraints
    from .scenario import Scenario
    from .stratified import LegSpec

__all__ = ["acceleration_problems", "duration_problems", "lie_problems"]


def lie_problems(constraints: Constraints, legs: list[LegSpec]) -> list[Problem]:
    """Lie legs are refused when [constraints] asks the search for joint limits,
    self-collision or obstacles (rate limits are met by time scaling, which applies to them)."""
    if not searchable(constraints):
        return []
    return [
        Problem(
            f"legs[{i}].method",
            "a Lie leg cannot keep [constraints] joint limits, self-collision or obstacles "
            '(its steps are planned where the system is); use method = "newton"',
        )
        for i, leg in enumerate(legs)
        if leg.method == "lie"
    ]


def acceleration_problems(scenario: Scenario) -> list[Problem]:
    """An acceleration limit holds only if the controls never jump: from rest at the start
    (`soft_start`), to rest at the end (`full_stop`) and at the switches (lr-continuity)."""
    c, planner = scenario.constraints, scenario.planner
    if c is None or c.max_acceleration is None:
        return []
    missing = [
        f"planner.{key} = {value}"
        for key, value, ok in (
            ("soft_start", "true", planner.soft_start),
            ("full_stop", "true", planner.full_stop),
            ("continuity", '"lr-C1" (or "lr-C0")', planner.continuity.startswith("lr-")),
        )
        if not ok
    ]
    if not missing:
        return []
    message = (
        f"holds only if the controls never jump (a jump is an unbounded acceleration): set "
        f"{' and '.join(missing)}; otherwise they jump from rest at the start, to rest at the "
        "end or at a switch"
    )
    return [Problem("constraints.max_acceleration", message)]


def duration_problems(scenario: Scenario, legs: list[LegSpec]) -> list[Problem]:
    """`durations = "optimise"` needs the energy objective, Newton legs and [[legs]]."""
    p = scenario.planner
    if p.durations == "fixed":
        if p.total_duration is not None:
            return [Problem("planner.total_duration", 'only with durations = "optimise"')]
        return []
    problems = []
    if p.objective != "energy":
        problems.append(
            Problem("planner.durations", '"optimise" needs objective = "energy" (the default)')
        )
    if scenario.legs is None:
        problems.append(Problem("planner.durations", '"optimise" needs [[legs]] (not auto mode)'))
    if any(leg.method != "newton" for leg in legs):
        problems.append(
            Problem("planner.durations", '"optimise" needs Newton legs (a Lie leg sets its own)')
        )
    return problems
