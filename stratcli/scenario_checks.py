"""Settings of a scenario that contradict each other across its tables, one problem each:
Lie legs under limits the search keeps, an acceleration limit with controls that may jump,
optimised durations without what they need, a leg of whole basis periods whose controls must
end otherwise than they start."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .errors import Problem
from .node_margins import searchable
from .wording import counted

if TYPE_CHECKING:
    from .constraints import Constraints
    from .scenario import Scenario
    from .stratified import LegSpec

__all__ = ["acceleration_problems", "duration_problems", "lie_problems", "periodic_problems"]


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


def periodic_problems(scenario: Scenario, system, legs: list[LegSpec]) -> list[Problem]:
    """A Newton leg that lasts a whole number of basis periods has controls that end as they
    start (value and slope: every basis function is periodic over it). Continuity then
    contradicts itself where an input must end at 0 (lr-continuity with the next leg not
    using it, or `full_stop` on the last leg) but starts where the previous leg left it, not
    at 0 (at 0 only if it is new on the leg, or at rest from a soft start, or left at 0 by a
    previous leg of whole periods that started it at 0). Leg by leg, Newton would fail with
    "boundary conditions are inconsistent"."""
    p = scenario.planner
    if p.continuity == "none" or scenario.legs is None or len(legs) != len(scenario.legs):
        return []
    if any(leg.stratum not in system.strata for leg in legs):
        return []  # (named by the strata check)
    actives = [system.stratum(leg.stratum).active for leg in legs]
    lr = p.continuity.startswith("lr")
    problems = []
    at_rest: set[int] = set(actives[0]) if p.soft_start else set()  # inputs starting at 0
    free = set() if p.soft_start else set(actives[0])  # (the first leg's start: anything)
    for i, leg in enumerate(legs):
        periods = leg.duration / p.basis.period
        whole = round(periods) >= 1 and abs(periods - round(periods)) <= 1e-9 * periods
        if leg.method == "lie" or (i and legs[i - 1].method == "lie"):
            whole = False  # (a Lie leg's controls are its steps')
        last = i == len(legs) - 1
        if last:
            ends = list(actives[i]) if p.full_stop else []
        else:
            ends = [k for k in actives[i] if lr and k not in actives[i + 1]]
        stuck = [k for k in ends if k not in at_rest | free] if whole else []
        if stuck:
            name = system.inputs[stuck[0]]
            why = "full_stop ends it at 0" if last else f"leg {i + 2} does not use it"
            own = scenario.legs[i].duration is not None
            problems.append(
                Problem(
                    f"legs[{i}].duration" if own else "planner.basis.period",
                    f"leg {i + 1} lasts {leg.duration:g} s, "
                    f"{counted(round(periods), 'whole basis period')} of {p.basis.period:g} s, "
                    f"so its controls end as they start; but under {p.continuity} {name} "
                    f"continues from leg {i} and must end at 0 ({why}); use a period that "
                    "does not divide the leg's duration (the paper's 2.17 s) or another duration",
                )
            )
        if not last:  # which inputs start leg i + 1 at 0
            left = (at_rest if whole else set()) | set(ends)
            at_rest = {k for k in actives[i + 1] if k not in actives[i] or k in left}
            free = set()
    return problems
