"""Newton plans as starts of the energy search: seeded whole plans, and the lowest legs.

The energy search descends from feasible plans, and which minimum it reaches depends on the
basin it starts in. Two kinds of start come from Newton's method itself:

* **Seeded plans** (`seeded_plans`, `planner.starts` above 2): the whole sequence planned
  again from more widely perturbed seeded Newton starts.
* **The lowest legs** (`lowest_legs`, for URDF robots, whose legs have no exact second
  derivatives and so no pulled or loop start; not for ODE-path legs, which have none either,
  but whose Newton legs cost seconds each: six a leg took arm3_reorient on the ODE path from
  30.6 s to 229 s of Newton legs, for the same minimum). Leg by leg, the lowest-energy of
  `LEG_TRIES` Newton plans (the plain one and seeded ones), each leg started where the one
  chosen before it ends. A Newton leg's minimum-norm steps from a small random start find
  any of many solutions, and their energies differ by orders of magnitude: on arm3 reoriented
  by 30° about x, then y, then z (soft start, full stop), the plain Newton plan's legs cost
  45.6, 385.4 and 2162.2 and its search ended at 1401.94 with j2 swinging 2.5 turns; the
  lowest of six a leg (24.5, 34.7 and 99.1) lead the search to 68.80. A Newton leg costs far
  less than a search from it: raced after the Newton plan's search, this start took 1.0-2.0x
  its CPU time on eleven URDF tasks (`benchmarks/bench_urdf_starts.py`) and ended lower on
  six, where a seeded plan costs a search of its own.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .models.system import System
from .planners.base import ENERGY_RUNAWAY
from .sequence import SequencePlan
from .settings import PlannerSettings
from .stratified import (
    LegSpec,
    LegStart,
    assemble,
    chain_legs,
    plan_next_leg,
    planner_for,
    seeded,
)

__all__ = ["LEG_TRIES", "lowest_legs", "seeded_plans"]

# Newton iterations per leg over all attempts of an extra start (`stratified.SEED_RESTARTS`
# restarts): a seed that needs more is dropped
# (on the paper's scenarios the seeds that win need at most 34; failing ones ran 39-48)
SEED_BUDGET = 36
# Newton plans per leg of the lowest legs (the plain one and LEG_TRIES - 1 seeded ones, each
# from a perturbation of LEG_SPREAD times the goal's scale): on the URDF tasks tried, four
# found arm3's 30° task's 68.80 only with a spread of 1 and six with 0.1 to 1
LEG_TRIES, LEG_SPREAD = 6, 0.3


def _budgeted(settings: PlannerSettings, k: int, spread: float | None = None) -> dict:
    """The k-th seeded Newton start's options (`stratified.seeded`) within `SEED_BUDGET`."""
    return {**seeded(settings, k, spread), "budget": SEED_BUDGET}


def seeded_plans(
    system: System,
    start: np.ndarray,
    legs: list[LegSpec],
    settings: PlannerSettings,
    newton: SequencePlan,
    say: Callable[[str], None],
) -> list[SequencePlan]:
    """The `settings.starts - 2` seeded Newton plans (more widely perturbed as k grows) that
    reach the goals; a seed whose plan needs many restarts, or whose energy runs away
    (`ENERGY_RUNAWAY` times `newton`'s), is not worth its time and is skipped."""
    plans = []
    count = settings.starts - 2  # (the pulled start and the Newton plan come first)
    for k in range(1, count + 1):
        say(f"energy search: a start from a seeded Newton plan ({k} of {count})")
        other = chain_legs(system, start, legs, settings, **_budgeted(settings, k))
        if other.ok and other.total_energy <= ENERGY_RUNAWAY * newton.total_energy:
            plans.append(other)
    return plans


def lowest_legs(
    system: System,
    start: np.ndarray,
    legs: list[LegSpec],
    settings: PlannerSettings,
    newton: SequencePlan,
    tries: int = LEG_TRIES,
) -> SequencePlan | None:
    """Each leg the lowest-energy of `tries` Newton plans that reach its goal (module
    docstring), from where the leg chosen before it ends; `newton`'s own legs are reused
    while the choices follow it. None where every choice is `newton`'s leg (nothing new) or
    a leg has no plan that reaches its goal."""
    at = LegStart(np.asarray(start, dtype=float))
    planned = []
    same = True  # every leg chosen so far is newton's: its next leg starts here too
    for i, leg in enumerate(legs):
        next_leg = legs[i + 1] if i + 1 < len(legs) else None
        plain = [newton.legs[i]] if same else []
        # (the plain planner again from elsewhere, but with a seed's budget: a leg on a
        # nearly singular stratum can take the plain planner's every restart)
        kinds = [_budgeted(settings, 0, 0.02)] if not same else []
        kinds += [_budgeted(settings, k, LEG_SPREAD) for k in range(1, tries)]
        found = plain + [
            plan_next_leg(system, settings, leg, at, next_leg, planner_for(leg, settings, **kw))
            for kw in kinds
        ]
        reached = [plan for plan in found if plan.converged]
        if not reached:
            return None
        best = min(reached, key=lambda plan: plan.energy)
        same = same and best is found[0] and bool(plain)
        planned.append(best)
        at = LegStart(best.end, best.end_controls(), at.t0 + best.duration, i + 1)
    if same:
        return None
    plan = assemble(system, settings, start, legs, planned)
    return plan if plan.ok else None
