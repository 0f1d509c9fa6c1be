"""Objectives of a sequence: the paper's Newton method, or minimum energy over all legs.

`newton`: legs planned one by one (`stratified.chain_legs`). `energy`: Newton first (a
feasible plan), then the minimum-energy controls over all legs together from
`settings.starts` deterministic starts (`planners.energy`), then a final leg-by-leg pass that
re-chains the legs from the configurations they actually reach (Newton polishes a leg only if
it is off by more than the tolerance). Every start is a `chain_legs` call (`newton_starts`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from .controls import embed
from .errors import InputError
from .leg_checks import check_legs
from .lie_notes import far_swings
from .models.system import System
from .newton_starts import LEG_TRIES, lowest_legs, seeded_plans
from .node_margins import searchable
from .planners import PLANNERS
from .planners.energy import LOWEST_LEGS, optimise_energy
from .planners.sqp import FIRST_ORDER_ITERATIONS, LOOSE_ABOVE
from .quadrature_check import ode_checked
from .sequence import SequencePlan
from .settings import PlannerSettings
from .stratified import (
    NUMERICAL_ERRORS,
    LegSpec,
    chain_legs,
    nominal_starts,
)
from .urdf_limits import stalled_too
from .within_limits import STALLED, re_planned, within_limits
from .wording import counted

__all__ = ["plan_sequence", "plan_with_objective", "stalled", "with_more_harmonics"]

# harmonics added when the search stalls in the default basis (`with_more_harmonics`), tried
# in turn: a realistic table (soft start and full stop, ±150°, self-collision, two obstacles)
# stalled on Sim 4 task D's legs with 3 and 4 harmonics and was planned inside with 5 and 6;
# of 12 random tasks under ±2.5 rad and self-collision that stalled with 3 and 5, 5 plan
# inside with 8 (the loops that turn the base fit inside the limits as several smaller ones)
MORE_HARMONICS = (2, 5)


def plan_sequence(
    system: System,
    start: np.ndarray,
    legs: list[LegSpec],
    settings: PlannerSettings,
    warm_start: list[np.ndarray] | None = None,
    progress: Callable[[str], None] | None = None,
    constraints=None,
) -> SequencePlan:
    """Check the legs, then plan them with `settings.objective`.

    Parameters
    ----------
    system : System
        The model.
    start : ndarray
        The start configuration.
    legs : list of LegSpec
        The legs in order (stratum, goal, method, duration).
    settings : PlannerSettings
        How to plan; `objective` is "newton" (leg by leg) or "energy" (all legs together).
    warm_start : list of ndarray, optional
        Feasible flat coefficients per leg, tried as an extra first start of the energy search.
    progress : callable, optional
        Called as `progress(phase)` with a short description of each phase as it begins
        (Newton's leg-by-leg pass, each start of the energy search); default: silent.
    constraints : constraints.Constraints, optional
        The resolved [constraints] table: joint limits, self-collision and obstacles are then
        kept along every leg by the search (`planners.constrained`); default: none.

    Returns
    -------
    SequencePlan
        The plan; `.ok` is False (with `.message`) when a leg did not reach its goal.

    Raises
    ------
    InputError
        When a leg cannot be planned as given (`leg_checks.check_legs`).
    """
    start = np.asarray(start, dtype=float)
    check_legs(system, start, legs, settings)  # once: the passes below plan the same legs
    plan = ode_checked(
        plan_with_objective(system, start, legs, settings, warm_start, progress), system
    )
    if any(leg.method == "lie" for leg in legs):  # a local leg that swung far: said
        plan = replace(plan, notes=(*plan.notes, *far_swings(plan, system))).with_system(system)
    if searchable(constraints) and plan.ok:
        plan = within_limits(system, start, legs, settings, plan, constraints, progress)
    return plan


def plan_with_objective(
    system: System,
    start: np.ndarray,
    legs: list[LegSpec],
    settings: PlannerSettings,
    warm_start: list[np.ndarray] | None = None,
    progress: Callable[[str], None] | None = None,
) -> SequencePlan:
    """Plan checked legs with `settings.objective`; `warm_start` (flat coefficients per leg,
    feasible) is tried as an extra first start of the energy search; `progress(phase)` is
    told each phase as it begins."""
    say = progress or _silent
    lie_legs = [i + 1 for i, leg in enumerate(legs) if not PLANNERS[leg.method].joint_optimisation]
    if lie_legs and settings.objective != "newton":
        return _with_lie_legs(system, start, legs, settings, lie_legs)
    say("planning the legs one by one (Newton)")
    newton = chain_legs(system, start, legs, settings)
    if settings.objective == "newton" or not newton.ok:
        return newton
    # Starts: the Newton plan pulled toward least energy (made by the search,
    # `planners.energy.pulled_start`), the Newton plan itself, then Newton plans from more
    # widely perturbed seeded starts (feasible, and in different basins). Legs without exact
    # second derivatives have no pulled start; on URDF robots the lowest of several Newton
    # plans a leg stands in for it, raced after the Newton plan (`newton_starts`; not on
    # ODE-path legs, whose Newton legs cost seconds each).
    endpoints = _endpoints(system, legs, settings)
    exact = all(hasattr(endpoint, "hessian") for endpoint in endpoints)
    starts = [("newton", newton)]
    magnus = all(endpoint.kind == "magnus" for endpoint in endpoints)
    if magnus and settings.starts > 1:  # (URDF robots' legs, in the pulled start's place)
        say("energy search: a start from the lowest of several Newton plans a leg")
        lowest = lowest_legs(system, start, legs, settings, newton)
        starts += [] if lowest is None else [(LOWEST_LEGS, lowest)]
    starts += [("newton", p) for p in seeded_plans(system, start, legs, settings, newton, say)]
    nominal = nominal_starts(start, legs, newton)
    targets = [np.array(leg.targets, dtype=int) for leg in newton.legs]
    stacked = [
        (kind, np.concatenate([leg.coefficients.ravel() for leg in p.legs])) for kind, p in starts
    ]
    if warm_start is not None:
        stacked.insert(0, ("warm start", np.concatenate([np.ravel(c) for c in warm_start])))
    try:  # it says how many starts it races (the pulled start is made there)
        with np.errstate(all="ignore"):
            coefficients, search = optimise_energy(
                system, nominal, legs, settings, targets, stacked, progress=progress
            )
    except NUMERICAL_ERRORS as exc:
        note = (
            f"the energy search stopped on a numerical failure ({type(exc).__name__}: "
            f"{exc}); the plan is plain Newton's"
        )
        return replace(newton, notes=(*newton.notes, note[:400]))
    search = replace(search, newton_energy=newton.total_energy)
    newton = replace(newton, optimisation=search)
    if coefficients is None:  # said: the plan is not the minimum-energy one it was asked for
        why = "; ".join(
            f"{start.kind}: {start.stopped}"
            + (f", {start.goal_error:.2g} off the goals" if np.isfinite(start.goal_error) else "")
            for start in search.starts
        )
        note = (
            f"the energy search ended on the goals from none of its "
            f"{len(search.starts)} start{'s' if len(search.starts) != 1 else ''} ({why}): the "
            "plan is plain Newton's, its energy not minimised"
        )
        return replace(newton, notes=(*newton.notes, note))
    say("energy search: re-chaining the legs from the best start")
    final = chain_legs(system, start, legs, settings, initial=coefficients)
    held = _held_note(system, legs, targets, endpoints, nominal)
    final = replace(
        final, optimisation=search, notes=(*final.notes, *_re_planned(final, legs), *held)
    )
    chosen = final if final.ok and final.total_energy <= newton.total_energy else newton
    return _short_of_a_minimum(chosen, search) if exact else _one_start(chosen, settings)


def _held_note(system, legs, targets, endpoints, nominal) -> list[str]:
    """The note of the free via coordinates the energy search held where the Newton plan put
    them (`stacked.held_coordinates`): a new user found a via with q2 free cost more than
    one that gives it, with nothing saying q2 had not been optimised."""
    from .planners.stacked import HELD_NOTE, held_coordinates

    held = held_coordinates(system, legs, targets, endpoints)
    parts = [
        f"leg {i + 1}'s via "
        + ", ".join(f"{system.states[c]} {nominal[i + 1][c]:.4g}" for c in coordinates)
        for i, coordinates in enumerate(held)
        if coordinates.size
    ]
    if not parts:
        return []
    return [
        f"{HELD_NOTE}{'; '.join(parts)} where the Newton plan put "
        f"{'them' if sum(map(len, held)) > 1 else 'it'} (a joint left free at a via is not "
        "optimised: the legs after it would move; give it a value to choose it)"
    ]


def _re_planned(plan: SequencePlan, legs: list[LegSpec]) -> list[str]:
    """Why the plan's energy differs from the search's ("re-chained: ..." beside it) where
    re-chaining the search's controls re-planned a leg after a via with free coordinates:
    the search starts each leg where the Newton plan left that via, and the search's legs
    before it may end elsewhere."""
    again = [str(k) for k in re_planned(plan, legs)]
    if not again:
        return []
    return [
        f"re-chained: {'legs' if len(again) > 1 else 'leg'} {', '.join(again)} re-planned "
        'from where the leg before ends; a via leaves coordinates free ("*"), and the energy '
        "search starts each leg where the Newton plan left them"
    ]


def _one_start(plan, settings: PlannerSettings):
    """`plan` with a note when the scenario asks for the legwise search, which a search
    without exact second derivatives does not make (`optimise_energy`): said, not silently
    ignored. (`starts` above 2 it does make: seeded Newton plans raced after the Newton
    plan's own search.)"""
    if settings.search != "legwise":
        return plan
    return _noted(
        plan,
        'planner.search = "legwise" made no difference here: these legs\' end-point maps '
        "have no second derivatives (URDF models, ODE-path legs), so the energy search runs "
        f"from the Newton plan, on URDF robots the lowest of {LEG_TRIES} Newton plans a leg, "
        f"and planner.starts - 2 seeded Newton plans (at most {FIRST_ORDER_ITERATIONS} steps "
        "each, the goals' curvature estimated from their Jacobians), without pulled, loop or "
        "legwise starts",
    )


def _short_of_a_minimum(plan, search):
    """`plan` with a note when the search's best start stopped far from a minimum (its
    projected gradient above the SQP's `LOOSE_ABOVE`): its energy may be far above the least.
    Not for searches without exact second derivatives (URDF and ODE-path legs: the Newton
    plan, a URDF robot's lowest legs, at most `sqp.FIRST_ORDER_ITERATIONS` steps each;
    result.json says whether they converged)."""
    best = search.starts[search.best] if search.best is not None else None
    if best is None or best.converged or not best.projected_gradient > LOOSE_ABOVE:
        return plan
    count = len(search.starts)
    note = (
        f"the energy search stopped short of a minimum: its best start ({best.kind}, of "
        f"{count} start{'s' if count != 1 else ''}) ended at its {best.stopped} after "
        f"{counted(best.iterations, 'SQP iteration')} with projected gradient "
        f"{best.projected_gradient:.1g}"
        ", so the energy may be far above the least; more starts (planner.starts), other "
        "strata or auto mode ([decompose]) may find lower"
    )
    return replace(plan, notes=(*plan.notes, note))


def _exact_hessians(system: System, legs: list[LegSpec], settings: PlannerSettings) -> bool:
    """Whether every leg's end-point map has exact second derivatives; if not (ODE-path
    legs, URDF models) the energy search makes no pulled, loop or legwise start
    (`optimise_energy`): the Newton plan, a URDF robot's lowest legs (`newton_starts`) and
    the seeded Newton plans `starts` asks for."""
    return all(hasattr(endpoint, "hessian") for endpoint in _endpoints(system, legs, settings))


def _endpoints(system: System, legs: list[LegSpec], settings: PlannerSettings) -> list:
    """Each leg's end-point map as its planner makes it (the evaluator resolved)."""
    from .endpoint import make_endpoint

    return [
        make_endpoint(
            system.compiled(leg.stratum),
            np.zeros(system.n),
            settings.basis,
            leg.duration,
            settings.evaluator,
            settings.tolerance,
        )
        for leg in legs
    ]


def _with_lie_legs(system, start, legs, settings, lie_legs) -> SequencePlan:
    """The energy objective for a sequence with Lie legs (or legs of another planner without
    `joint_optimisation`), which it cannot optimise itself.

    Lie legs are built step by step from where the system actually is, so there is no fixed
    set of their coefficients to optimise jointly: the sequence is planned leg by leg. The
    Newton legs of that pass are seeded with the minimum-energy plan of the same sequence
    with a Newton stand-in for every Lie leg (Newton legs after a Lie leg are re-polished
    from where it ends; Lie legs are planned as usual). If that fails, the plain leg-by-leg
    plan (the paper's Newton method) is returned. A note says which.
    """
    stand_in = [leg if leg.method == "newton" else replace(leg, method="newton") for leg in legs]
    which = ", ".join(map(str, lie_legs))
    objective = settings.objective
    # the method those legs use: "lie", or a planner of the user's own (`planners.PLANNERS`)
    methods = list(dict.fromkeys(legs[i - 1].method for i in lie_legs))  # in leg order
    lie = methods == ["lie"]
    named = f"method {', '.join(map(repr, methods))}, not optimised jointly"
    if len(lie_legs) == len(legs):
        plain = chain_legs(system, start, legs, settings)
        how = "the Lie-algebraic method (local steps of least energy, planned where the system is)"
        return _noted(
            plain, f"objective {objective!r} does not apply: every leg uses {how if lie else named}"
        )
    try:
        check_legs(system, start, stand_in, settings)
        proxy = plan_with_objective(system, start, stand_in, settings)
    except (InputError, *NUMERICAL_ERRORS):  # the stand-in is only a helper
        proxy = None
    seeded = None
    if proxy is not None and proxy.ok and proxy.optimisation is not None:
        initial = [np.ravel(leg.coefficients) for leg in proxy.legs]
        seeded = chain_legs(system, start, legs, settings, initial=initial)
        how = "the Lie-algebraic method (local steps, planned where the system is)"
        applied = _noted(
            seeded,
            f"objective {objective!r} applied to the Newton legs only: leg(s) {which} use "
            f"{how if lie else named}; the Newton legs come from the minimum-energy plan "
            f"with a Newton stand-in for each {'Lie leg' if lie else 'of them'}, then the "
            "sequence was planned leg by leg (a Newton leg's iterations are its polish from "
            "there: 0 where it reached its goal as it was)",
        )
        if seeded.ok:
            return applied
    plain = chain_legs(system, start, legs, settings)
    if seeded is not None and not plain.ok:  # failed both ways: the plan the objective made
        return applied  # (a new user's failed Lie leg swapped it for the paper's legs)
    why = (
        f"from the minimum-energy Newton legs {seeded.message[0].lower()}{seeded.message[1:]}"
        if seeded is not None
        else f"leg(s) {which} use {'the Lie-algebraic method' if lie else named}"
    )
    return _noted(
        plain,
        f"objective {objective!r} not applied: {why}, so the sequence was planned leg by "
        "leg (Newton legs with the paper's Newton method)",
    )


def _silent(phase: str) -> None:
    """No progress shown."""


def _noted(plan: SequencePlan, note: str) -> SequencePlan:
    return replace(plan, notes=(*plan.notes, note))


def stalled(plan) -> bool:
    """Whether `within_limits` left `plan` outside the limits (its message says where the
    search stalled), its legs having reached their goals."""
    return plan.message.startswith(STALLED) and all(leg.converged for leg in plan.legs)


def with_more_harmonics(
    system, start, legs, settings, plan, constraints, progress=None, more=MORE_HARMONICS
):
    """The legs planned again within the limits with more harmonics (the same period; `more`:
    how many more, each in turn until one gets inside), for a plan whose search stalled
    (`stalled`): the whole plan again (Newton, the energy search, the constrained search),
    with `plan`'s controls (the plan found without the limits, which the stalled search
    returns) in the larger basis as one more start of the energy search (`controls.embed`:
    the same controls). The plan returned says in a note how many harmonics it took; where
    every count stalls too, the first plan is returned with a note saying so."""
    if not more:
        return plan
    h = settings.basis.harmonics
    say = progress or _silent
    tried = [h]
    for extra in more:
        n = h + extra
        again = "" if len(tried) == 1 else f" with {tried[-1]} too"
        say(f"constrained search: stalled{again}; planning again with {n} harmonics")
        richer = replace(settings, basis=replace(settings.basis, harmonics=n))
        warm = [np.ravel(embed(leg.coefficients, h, n)) for leg in plan.legs]
        found = plan_sequence(system, start, legs, richer, warm, progress, constraints)
        if not found.message and all(leg.converged for leg in found.legs):
            first = f"{h} (the default{_where(plan.message)})"
            return _noted(
                found,
                f"planned with {n} harmonics: the search within the limits stalled with "
                f"{_counts([first, *tried[1:]])}; planner.basis.harmonics = {n} asks for "
                "these from the start",
            )
        tried.append(n)
    return _noted(  # (the advice then asks for more than the counts tried: `stalled_too`)
        replace(plan, message=plan.message + stalled_too(h, _counts(tried[1:]))),
        f"with {_counts(tried[1:])} harmonics the plan did not get inside the limits either",
    )


def _where(message: str) -> str:
    """'; on leg 2: the joint limits of q1 still violated by 0.2 rad at its nodes' from a
    stall message (`within_limits.STALLED`), for the note of a retry that got inside."""
    head = f"{STALLED[0]} "
    return f"; {message.removeprefix(head)}" if message.startswith(head) else ""


def _counts(numbers: list) -> str:
    """[3] -> "3", [3, 5] -> "3 and 5", [3, 5, 8] -> "3, 5 and 8"."""
    words = [str(n) for n in numbers]
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} and {words[-1]}"
