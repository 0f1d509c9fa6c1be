"""Settings of a scenario that contradict each other across its tables, one problem each:
Lie legs under limits the search keeps, an acceleration limit with controls that may jump,
optimised durations without what they need, a leg of whole basis periods whose controls must
end otherwise than they start."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .continuity import eliminate, leg_constraints
from .errors import Problem
from .node_margins import CUSHION, searchable
from .settings import MIN_DURATION
from .wording import counted

if TYPE_CHECKING:
    from .constraints import Constraints
    from .scenario import Scenario
    from .stratified import LegSpec

__all__ = [
    "acceleration_problems",
    "attitude_problems",
    "duration_problems",
    "lie_problems",
    "lie_step_problems",
    "periodic_problems",
]


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


def attitude_problems(system, places: list[tuple[str, np.ndarray | None]]) -> list[Problem]:
    """A URDF robot's partly free goal or via attitude (some rotation-vector components "*")
    is reached component by component on the rotation vector log(R), which is never longer
    than π: fixed components longer than that can never be reached (a goal [*, *, 4] planned
    for 35 s and failed with advice to try more harmonics). A whole attitude longer than π
    is the same rotation as a shorter one, which the plan reaches (a note says so)."""
    from .models.spatial_scenario import attitudes

    out = []
    for where, phi in attitudes(system, places):
        if np.all(np.isfinite(phi)) or not np.any(np.isfinite(phi)):
            continue
        length = float(np.linalg.norm(phi[np.isfinite(phi)]))
        if length > np.pi + 1e-9:
            shown = ", ".join("*" if v != v else f"{v:.4g}" for v in phi)
            out.append(
                Problem(
                    where,
                    f"its partly free attitude [{shown}] cannot be reached: it is compared "
                    "component by component on the rotation vector log(R), never longer than "
                    f"pi, and its fixed components are {length:.4g} long; give the whole "
                    "attitude, or fixed components within pi",
                )
            )
    return out


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
    others = list(dict.fromkeys(leg.method for leg in legs if leg.method != "newton"))
    if others:
        why = "a Lie leg sets its own" if others == ["lie"] else f"not {', '.join(others)}"
        problems.append(Problem("planner.durations", f'"optimise" needs Newton legs ({why})'))
    least = len(legs) * MIN_DURATION  # every leg lasts at least MIN_DURATION
    if p.total_duration is not None and legs and p.total_duration < least * (1 - 1e-12):
        problems.append(
            Problem(
                "planner.total_duration",
                f"{counted(len(legs), 'leg')} need at least {least:g} s ({MIN_DURATION:g} s "
                f"each, the shortest leg there is; got {p.total_duration:g})",
            )
        )
    return problems


def periodic_problems(scenario: Scenario, system, legs: list[LegSpec]) -> list[Problem]:
    """A Newton leg whose continuity conditions contradict each other, as leg-by-leg Newton
    would find them ("boundary conditions are inconsistent"), the first one named: over a
    whole number of basis periods (or nearly) every control ends as it starts, so an input
    that continues from the leg before and must end at 0 (lr-continuity with the next leg
    not using it, `full_stop` on the last leg) cannot. The conditions are the planner's own
    (`continuity.leg_constraints`, `eliminate`), leg after leg, with each control's end
    value where they fix it (at 0, say) and any other value (a stand-in) where they do not.
    Not checked with Lie legs (their steps are planned where the system is) or with
    `durations = "optimise"` (the durations are then chosen)."""
    p = scenario.planner
    if (
        p.continuity == "none"
        or p.durations == "optimise"
        or scenario.legs is None
        or len(legs) != len(scenario.legs)
        or any(leg.method == "lie" or leg.stratum not in system.strata for leg in legs)
    ):
        return []
    basis, m, size = p.basis, len(system.inputs), p.basis.size
    stand_in = _stand_in(m)  # an end not fixed: any
    previous = None
    for i, leg in enumerate(legs):
        active = system.stratum(leg.stratum).active
        last = i == len(legs) - 1
        after = None if last else system.stratum(legs[i + 1].stratum).active
        cons = leg_constraints(
            basis, leg.duration, active, system.inputs, p.continuity, previous=previous,
            next_active=after, soft_start=p.soft_start, full_stop=p.full_stop,
        )  # fmt: skip
        try:
            elim = eliminate(cons)
        except ValueError:
            return [_periodic_problem(scenario, system, legs, i, cons)]
        end = np.zeros((2, m))  # inputs the leg does not use end it at 0
        for d, phi in enumerate((basis.values(leg.duration), basis.derivatives(leg.duration))):
            for a, k in enumerate(active):
                row = np.zeros(len(active) * size)
                row[a * size : (a + 1) * size] = phi
                fixed = np.linalg.norm(elim.null.T @ row) <= 1e-8 * np.linalg.norm(row)
                end[d, k] = row @ elim.particular if fixed else stand_in[d, k]
        previous = (end[0], end[1])
    return []


def lie_step_problems(scenario: Scenario, system, legs: list[LegSpec]) -> list[Problem]:
    """A Lie leg after another leg whose first step's conditions contradict each other, as the
    planner's own (`continuity.leg_constraints`, `eliminate`) find them: its steps end at rest
    (`rest`, the default), and a step of a whole number of basis periods, or nearly, ends its
    controls as it starts them, so the first cannot continue the leg before and end at 0
    ("boundary conditions are inconsistent" at planning time, and the advice to move a via)."""
    p = scenario.planner
    if p.continuity == "none":
        return []
    stand_in = _stand_in(len(system.inputs))  # the controls the leg before ends with
    problems = []
    for i, leg in enumerate(legs):
        lie = leg.lie or p.lie
        if (
            leg.method != "lie"
            or i == 0
            or not lie.rest
            or legs[i - 1].stratum not in system.strata
        ):
            continue
        before = np.zeros((2, len(system.inputs)))  # the inputs the leg before hands over
        used = list(system.stratum(legs[i - 1].stratum).active)
        before[:, used] = stand_in[:, used]
        cons = leg_constraints(
            p.basis, lie.step_duration, system.stratum(leg.stratum).active, system.inputs,
            p.continuity, previous=(before[0], before[1]), next_active=None, soft_start=False,
            full_stop=True,
        )  # fmt: skip
        if _consistent(cons):
            continue
        periods = lie.step_duration / p.basis.period
        own = scenario.legs is not None and i < len(scenario.legs) and scenario.legs[i].lie
        where = f"legs[{i}].lie.step_duration" if own else "planner.lie.step_duration"
        problems.append(
            Problem(
                where,
                f"leg {i + 1}'s Lie steps last {lie.step_duration:g} s, {periods:.6g} basis "
                f"period{'' if periods == 1 else 's'} of {p.basis.period:g} s: over a whole "
                f"number of them, or nearly, a step's controls end as they start, so its first "
                f"cannot continue leg {i}'s under {p.continuity} and end at rest (lie.rest); use "
                "a step further from a whole number of periods (the paper's 0.51 s)",
            )
        )
    return problems


def _stand_in(m: int) -> np.ndarray:
    """Values and derivatives (2, m) of controls a check does not know: any nonzero ones."""
    return np.random.default_rng(0).uniform(1.0, 2.0, (2, m))


def _consistent(cons) -> bool:
    """Whether conditions `cons` hold together (`eliminate` finds a solution)."""
    try:
        eliminate(cons)
    except ValueError:
        return False
    return True


def _periodic_problem(scenario, system, legs, i, cons) -> Problem:
    """The problem of leg `i`, whose conditions `cons` contradict each other: named by the
    first input whose own rows do (each row is on one input's coefficients)."""
    p, leg = scenario.planner, legs[i]
    size = p.basis.size
    active = system.stratum(leg.stratum).active
    name = system.inputs[active[0]]
    for a, k in enumerate(active):
        rows = np.flatnonzero(np.abs(cons.C[:, a * size : (a + 1) * size]).sum(axis=1) > 0)
        block = type(cons)(cons.C[rows], cons.c[rows], tuple(cons.labels[r] for r in rows))
        try:
            eliminate(block)
        except ValueError:
            name = system.inputs[k]
            break
    last = i == len(legs) - 1
    why = f"leg {i + 2} does not use it"
    if last:  # (without full_stop nothing fixes its end but a degenerate basis)
        why = "full_stop ends it at 0" if p.full_stop else "its conditions fix its end"
    periods = leg.duration / p.basis.period
    own = scenario.legs[i].duration is not None
    return Problem(
        f"legs[{i}].duration" if own else "planner.basis.period",
        f"leg {i + 1} lasts {leg.duration:g} s, {periods:.6g} basis "
        f"period{'' if periods == 1 else 's'} of "
        f"{p.basis.period:g} s: over a whole number of them (or nearly) its controls end as "
        f"they start; but under {p.continuity} {name} continues from leg {i} and must end at "
        f"0 ({why}); use a period that does not divide the leg's duration (the paper's "
        "2.17 s) or another duration",
    )


def cushion_problems(system, legs: list[LegSpec], constraints) -> list[Problem]:
    """A leg's goal on (or within `CUSHION` of) a joint limit of a coordinate the leg moves:
    the constrained search keeps every margin `CUSHION` inside at its nodes, the leg's end
    among them, so no plan exists (a goal y = 1 under limits ±1 took 4.4 s to stall)."""
    problems = []
    lower, upper = constraints.lower, constraints.upper
    for i, leg in enumerate(legs):
        where = "task.goal" if i == len(legs) - 1 else f"legs[{i}].goal"
        for j in system.stratum(leg.stratum).free(system.n):
            q = leg.goal[j]
            for bound in (lower[j], upper[j]):
                if np.isfinite(q) and np.isfinite(bound) and abs(q - bound) < CUSHION:
                    problems.append(
                        Problem(
                            where,
                            f"{system.states[j]} = {q:.6g} is {abs(q - bound):.3g} from its "
                            f"limit {bound:g}: a plan keeps {CUSHION:g} inside the limits along "
                            f"the leg that ends there (leg {i + 1}), so it cannot end there; put "
                            f"it at least {CUSHION:g} inside",
                        )
                    )
    return problems
