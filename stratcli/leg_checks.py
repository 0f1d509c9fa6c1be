"""Checks of a sequence's legs before planning (no I/O): locked coordinates asked to move,
too few free coefficients for a leg's goal, a planner of one's own that cannot be made or
checked (`check_legs`); a via's free coordinate pinned where the legs after it keep it
locked (`pinned_vias`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .errors import InputError, Problem
from .models.system import System
from .planner_contract import checked_duration, is_own, noted
from .planners import PLANNERS
from .settings import PlannerSettings
from .stratified import LegSpec, LegStart, leg_problem, planner_for

__all__ = ["check_legs", "pinned_vias"]


def _checked_planner(system, settings, leg, at, next_leg):
    """The leg's planner and its free and needed coefficients (`check_legs`); an
    exception of a planner of one's own (its `from_settings`, `__init__` or
    `missing_coefficients`, an abstract method left out) carries a note naming it, as one
    from its `plan` does: the command line's one line, not stratplan's traceback."""
    cls, call = PLANNERS[leg.method], "from_settings"
    try:
        planner = planner_for(leg, settings)
        call = "problem_duration"
        problem = leg_problem(system, settings, leg, at, next_leg, planner)
        checked_duration(problem.duration, planner, leg.method)
        call = "missing_coefficients"
        return planner, *planner.missing_coefficients(problem)
    except Exception as exc:
        if is_own(cls):
            noted(exc, cls, leg.method, f"checking leg {at.index + 1} on {leg.stratum}", call)
        raise


def _distinct(a: float, b: float) -> tuple[str, str]:
    """a and b with the fewest digits (at least 6) that tell them apart: -pi/3 and -1.0472
    differ only in the sixth digit."""
    for digits in range(6, 18):
        shown = f"{a:.{digits}g}", f"{b:.{digits}g}"
        if shown[0] != shown[1]:
            return shown
    return repr(a), repr(b)


def pinned_vias(system: System, legs: list[LegSpec]) -> list[LegSpec]:
    """`legs` with a via's free ("*") coordinate set where the legs after it keep that
    coordinate locked up to a goal that gives it: the one value that reaches that goal (a
    free q1 before an S1 leg ended where leg 1 left it, 1.24 rad from the goal, status ok).
    A given value that differs is `check_legs`' to refuse."""
    out = list(legs)
    n = system.n
    for j in range(len(out) - 1, 0, -1):  # from the last leg back: its start is via j - 1
        goal = np.asarray(out[j].goal, dtype=float)  # (a via pinned a step before included)
        moved = set(system.stratum(out[j].stratum).free(n))
        kept = [c for c in range(n) if c not in moved and np.isfinite(goal[c])]
        before = np.array(out[j - 1].goal, dtype=float)
        free = [c for c in kept if np.isnan(before[c])]  # locked on leg j: start = end
        if free:
            before[free] = goal[free]
            out[j - 1] = replace(out[j - 1], goal=before)
    return out


def check_legs(system: System, start: np.ndarray, legs: list[LegSpec], settings: PlannerSettings):
    """Problems found before planning: locked coordinates asked to move, too few coefficients.

    Raises
    ------
    InputError
        Naming every leg that cannot be planned as given.
    """
    problems: list[Problem] = []
    previous = np.asarray(start, dtype=float)
    zero = (np.zeros(system.m), np.zeros(system.m))
    for i, leg in enumerate(legs):
        stratum = system.stratum(leg.stratum)
        for k in stratum.locked:
            if np.isnan(leg.goal[k]) or np.isnan(previous[k]):
                continue  # not prescribed, or only known once the previous leg is planned
            if abs(leg.goal[k] - previous[k]) > 1e-9:
                name, (was, goal) = system.states[k], _distinct(previous[k], leg.goal[k])
                problems.append(
                    Problem(
                        f"legs[{i}].goal",
                        f"leg {i + 1} on {leg.stratum}: {name} is locked at {was} on this "
                        f"stratum but its goal is {goal}; use a stratum that "
                        f"moves {name} or keep it at {was}",
                    )
                )
        at = LegStart(previous, None if i == 0 else zero, 0.0, i)
        next_leg = legs[i + 1] if i + 1 < len(legs) else None
        planner, free, needed = _checked_planner(system, settings, leg, at, next_leg)
        if free < needed:
            where = f"leg {i + 1} on {leg.stratum}"
            problems.append(Problem(f"legs[{i}]", planner.shortfall(where, settings, free, needed)))
        unlocked = np.isin(np.arange(system.n), stratum.locked, invert=True)
        previous = np.where(unlocked, leg.goal, previous)
    if problems:
        raise InputError(problems)
