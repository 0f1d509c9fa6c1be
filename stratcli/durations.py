"""Leg durations as decision variables: the energy objective shares a time budget among legs.

With free durations the energy of a driftless plan falls as time grows (a path run s times
slower costs 1/s of the energy), so the problem is posed with a budget: the durations sum to
`total_duration`. They are parametrised by softmax weights `T_i = total · e^{y_i} / Σ e^{y_j}`
(y_0 = 0), so every choice meets the budget exactly and every leg keeps a positive duration;
for each choice the energy objective plans the whole sequence (its starts, its continuity at
every switch), and Nelder–Mead minimises the resulting energy over y. The search starts from
equal durations, whose energy the note reports beside the optimum's.

Under a `[constraints]` table the durations are chosen without the limits (each of the
tens of plans searched within them would cost as much as a whole constrained plan), then the
plan at the chosen durations is searched within them (`within_limits.within_limits`), as
at fixed durations; where that search stalls, the equal durations are searched within them
too and the better plan inside is kept.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from .models.system import System
from .node_margins import searchable
from .objectives import plan_sequence
from .sequence import SequencePlan
from .settings import MIN_DURATION, PlannerSettings
from .stratified import LegSpec

__all__ = ["optimise_durations", "shares", "timed_as"]

EVALUATIONS_PER_LEG = 25  # Nelder–Mead budget: plans of the sequence per free duration
X_TOL = 2e-3  # in the softmax weights: durations to ~0.1 % of the budget
F_TOL = 1e-6  # relative energy


def shares(y: np.ndarray, total: float) -> np.ndarray:
    """Durations (k,) summing to `total` from softmax weights y (k − 1,) (the first is 0)."""
    w = np.concatenate([[0.0], np.asarray(y, dtype=float)])
    e = np.exp(w - w.max())
    return total * e / e.sum()


def optimise_durations(
    system: System,
    start: np.ndarray,
    legs: list[LegSpec],
    settings: PlannerSettings,
    total: float,
    progress: Callable[[str], None] | None = None,
    constraints=None,
) -> SequencePlan:
    """The minimum-energy plan over the legs' controls and their durations, which sum to
    `total` (s).

    Parameters
    ----------
    system, start, legs, settings
        As for `objectives.plan_sequence` (the energy objective is used whatever
        `settings.objective` says).
    total : float
        The time budget, s.
    progress : callable, optional
        Told each evaluation as it begins.
    constraints : constraints.Constraints, optional
        The resolved [constraints] table: the plan at the chosen durations is then searched
        within its limits (the module docstring).

    Returns
    -------
    SequencePlan
        The best plan found, with a note giving the chosen durations and the energy at equal
        durations; the plan at equal durations if no other choice could be planned.
    """
    from scipy.optimize import minimize  # only this opt-in search needs scipy (start-up)

    settings = replace(settings, objective="energy")
    plans: dict[tuple[float, ...], SequencePlan] = {}
    say = progress or (lambda phase: None)

    def planned(y: np.ndarray) -> SequencePlan | None:
        durations = shares(y, total)
        key = tuple(np.round(durations, 12))
        if key not in plans:
            if durations.min() < MIN_DURATION:
                return None
            say(f"durations: plan {len(plans) + 1} ({', '.join(f'{d:.3g}' for d in durations)} s)")
            timed = [
                replace(leg, duration=float(d)) for leg, d in zip(legs, durations, strict=True)
            ]
            plans[key] = plan_sequence(system, start, timed, settings)
        return plans[key]

    def energy(y: np.ndarray) -> float:
        plan = planned(y)
        return plan.total_energy if plan is not None and plan.ok else np.inf

    k = len(legs)
    equal = planned(np.zeros(k - 1))
    if k == 1:
        return _budget_advice(
            _inside(system, start, legs, [equal], settings, constraints, progress)[0]
        )
    scale = equal.total_energy if equal.ok else 1.0
    minimize(
        energy,
        np.zeros(k - 1),
        method="Nelder-Mead",
        options={
            "xatol": X_TOL,
            "fatol": F_TOL * scale,
            "maxfev": EVALUATIONS_PER_LEG * (k - 1),
            "initial_simplex": np.vstack([np.zeros(k - 1), 0.5 * np.eye(k - 1)]),
        },
    )
    ok = [p for p in plans.values() if p.ok]
    if not ok:
        return _budget_advice(equal)
    optimum = min(ok, key=lambda p: p.total_energy)
    free = optimum.total_energy
    best, inside = _inside(system, start, legs, [optimum, equal], settings, constraints, progress)
    chosen = ", ".join(f"{leg.duration:.4g}" for leg in optimum.legs)
    reference = (
        f"{equal.total_energy:.6g} at equal durations ({total / k:.4g} s each), "
        f"{100 * (1 - free / equal.total_energy):.1f} % less"
        if equal.ok
        else f"none at equal durations ({total / k:.4g} s each: that plan failed)"
    )
    budget = (  # a budget given is a limit (`limit_timing`); the legs' own sum is not
        f"the {total:g} s budget"
        if settings.total_duration is not None
        else f"the legs' {total:g} s in all (no planner.total_duration: rate limits may slow "
        "the plan past it)"
    )
    note = (
        f"durations optimised within {budget} over {len(plans)} plans of the "
        f"sequence: {chosen} s; energy {free:.6g}, against {reference}"
    )
    if best is not optimum and not best.message:  # searched within the [constraints] limits
        kept = ", ".join(f"{leg.duration:.4g}" for leg in best.legs)
        found = ", ".join(
            f"{energy:.6g} at {'those' if which == 0 else 'equal'} durations"
            for which, energy in inside
        )
        note += (
            "; chosen without the limits, then searched within them at those durations and at "
            f"equal ones (inside: {found}): kept {kept} s, energy {best.total_energy:.6g}"
        )
    return replace(best, notes=(*best.notes, note))


def _budget_advice(plan: SequencePlan) -> SequencePlan:
    """A failed plan's advice of "a longer leg" as what sets the legs' durations here."""
    longer = "a longer leg"
    if plan.ok or longer not in (plan.message or ""):
        return plan
    message = plan.message.replace(longer, "a larger planner.total_duration (the legs share it)")
    return replace(plan, message=message)


def timed_as(legs: list[LegSpec], plan: SequencePlan) -> list[LegSpec]:
    """`legs` with the durations `plan` gave them (its legs planned so far)."""
    return [replace(leg, duration=p.duration) for leg, p in zip(legs, plan.legs, strict=False)]


def _inside(
    system, start, legs, choices, settings, constraints, progress
) -> tuple[SequencePlan, list[tuple[int, float]]]:
    """The lowest-energy plan that the constrained search gets inside the limits of
    `constraints` from each of `choices` (plans of `legs` at other durations: the chosen
    ones, the equal ones), else the first as searched (`within_limits`: with the message
    naming where it stalled); the first unchanged without limits to search
    (`node_margins.searchable`). Also (index among `choices`, energy) of each plan that got
    inside."""
    from .within_limits import within_limits

    first = choices[0]
    if not searchable(constraints) or not first.ok:
        return first, []
    searched, inside = None, []  # the first plan as searched, and those inside
    for which, plan in enumerate(dict.fromkeys(choices)):  # equal may be the chosen ones
        if not plan.ok:
            continue
        timed = timed_as(legs, plan)
        found = within_limits(system, start, timed, settings, plan, constraints, progress)
        if found.ok and not found.message:
            inside.append((which, found))
        searched = searched or found
    if not inside:
        return searched, []
    best = min((plan for _, plan in inside), key=lambda p: p.total_energy)
    return best, [(which, plan.total_energy) for which, plan in inside]
