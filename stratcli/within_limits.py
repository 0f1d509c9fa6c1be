"""Plans moved inside the joint limits, clear of themselves and of the obstacles, along every
leg (issue 17): the constrained search (`planners.constrained`) from the plan found without
them (and, where its energy search kept a loop or legwise start, from the minimum of its own
starts), then from further seeded Newton plans; for auto mode, a candidate's plan so moved and
verified (no I/O)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .node_margins import searchable
from .planners import PLANNERS
from .planners.constrained import NotSearchable, constrained_search
from .planners.energy import SEARCHED
from .planners.stacked import HELD_NOTE
from .stratified import NUMERICAL_ERRORS, chain_legs, held_vias, nominal_starts, seeded

__all__ = ["STALLED", "candidate_within_limits", "re_planned", "within_limits"]

CONSTRAINED_SEEDS = 3  # further starts of the constrained search when the plan's own stalls
PLAIN = "plain"  # the start from the minimum of the energy search's own starts
AUXILIARY_LIMIT = 2.5  # rad: joint limits of the start for self-collision alone
NOT_RECHAINED = "the constrained plan did not re-chain onto the goals; "  # + chain's message
MORE_STARTS_ABOVE = 3.0  # energy inside the limits / without them that suggests more starts
STALLED = (  # the messages of a search that did not get inside (`objectives.stalled`)
    "the constrained search stalled",
    "the constrained search stopped",
    "the constrained search kept dipping",  # below a margin between its nodes (refinements)
)


def within_limits(system, start, legs, settings, plan, constraints, progress=None):
    """`plan` (which reaches every goal) moved inside the joint limits, clear of itself and of
    the obstacles along every leg (`planners.constrained`): from the plan itself, then from
    its energy search's Newton plan. The energy objective then lowers the energy inside the
    limits. If no start leads inside, `plan` is returned with a message naming the limit and
    the leg where the search stalled (the verification then fails it)."""
    say = progress or (lambda phase: None)
    if not all(PLANNERS[leg.method].joint_optimisation for leg in legs):
        return plan  # Lie legs are refused with [constraints] limits (scenario loading)
    nominal = nominal_starts(start, legs, plan)
    targets = [np.array(leg.targets, dtype=int) for leg in plan.legs]
    seeds = [
        (
            "Newton" if settings.objective == "newton" else "minimum-energy",
            np.concatenate([leg.coefficients.ravel() for leg in plan.legs]),
        )
    ]
    say("constrained search: moving the plan inside the limits")
    tried = []  # every start, for `_folding_start`
    coefficients, notes, stalled, iterations, searched = None, [], "", 0, 0
    inside = []  # (energy, coefficients, notes, iterations) of each start that got inside
    settled = 0  # of those, the ones not kept after dips (`Searched.kept`): what `wanted` counts
    wanted = settings.constrained_starts
    plain = [PLAIN] if _from_a_later_start(plan) else []
    for k in [0, *plain, *range(1, CONSTRAINED_SEEDS + wanted)]:
        if k == PLAIN:  # the minimum of the search's own starts (`_plain_minimum`)
            say("constrained search: from the minimum the energy search's own starts reach")
            lam = _plain_minimum(system, start, legs, settings)
            if lam is None:
                continue
            seeds = [("minimum-energy (without loop starts)", lam)]
        elif k:  # another start: a Newton plan from a seed, as the energy search's starts
            say(f"constrained search: start {k + 1} (a Newton plan from a seed)")
            other = chain_legs(system, start, legs, settings, **seeded(settings, k))
            if not other.ok:
                continue
            seeds = [
                ("seeded Newton", np.concatenate([g.coefficients.ravel() for g in other.legs]))
            ]
        tried += seeds
        coefficients = None
        searched += 1
        try:
            coefficients, notes, stalled, energy, iterations, kept = constrained_search(
                system, nominal, legs, settings, targets, seeds, constraints,
                lower_energy=settings.objective == "energy", first=k == 0,
            )  # fmt: skip
        except NotSearchable:
            note = (
                "the limits were verified, not searched for: the constrained search needs "
                "joints in closed form (not ODE-path legs)"
            )
            return replace(plan, notes=(*plan.notes, note))
        except NUMERICAL_ERRORS as exc:
            stalled = (
                f"the constrained search stopped on a numerical failure ({type(exc).__name__})"
            )
        if coefficients is None and not stalled:
            break  # (k = 0) inside the limits already
        if coefficients is not None:  # (a start kept after dips between the nodes: one
            inside.append((energy, coefficients, notes, iterations))  # more, not counted)
            settled += not kept
            if settled >= wanted:
                break
    if inside:  # the lowest of the starts that got inside (`constrained_starts`, and any kept)
        _, coefficients, notes, iterations = min(inside, key=lambda found: found[0])
        if wanted > 1:
            energies = ", ".join(f"{e:.6g}" for e, _, _, _ in inside)
            notes = [
                *notes,
                f"lowest of {len(inside)} constrained starts inside the limits ({energies})",
            ]
    if coefficients is None and not stalled:
        return plan  # inside the limits already (then it is also the constrained minimum)
    if coefficients is None:  # self-collision without joint limits: a start within some
        found = _folding_start(system, nominal, legs, settings, targets, tried, constraints)
        if found is not None:
            say("constrained search: from a plan within auxiliary joint limits")
            searched += 1
            coefficients, notes, _, _, iterations, _ = constrained_search(
                system, nominal, legs, settings, targets, found, constraints,
                lower_energy=settings.objective == "energy", first=False,
            )  # fmt: skip
    if coefficients is None:
        return replace(plan, message=stalled, notes=(*plan.notes, stalled))
    final = chain_legs(system, start, legs, settings, initial=coefficients)
    if not final.ok:
        note = NOT_RECHAINED + final.message
        return replace(plan, message=note, notes=(*plan.notes, note))
    if re_planned(final, legs):  # after a via with free coordinates, which the search held
        say("constrained search: again, with the vias' free coordinates held")
        final, again, more, stalled = _rechained_within(
            system, start, legs, settings, final, constraints
        )
        if stalled:
            return replace(plan, message=stalled, notes=(*plan.notes, stalled))
        if again:  # searched again: its note replaces the first search's (another plan)
            kept = [n for n in notes if not n.startswith("constrained search from")]
            notes, iterations, searched = [*again, *kept], iterations + more, searched + 1
    # The legs are the search's (re-chaining polishes a leg only if it is off by more than the
    # tolerance): their work is its iterations and starts, over all legs together.
    legs_found = tuple(
        replace(
            leg,
            strategy="constrained",
            iterations=iterations + leg.iterations,
            attempts=searched,
        )
        for leg in final.legs
    )
    hint = _more_starts_hint(settings, plan.total_energy, final.total_energy)
    hint += _below_free(settings, plan.total_energy, final.total_energy)
    held = [n for n in plan.notes if n.startswith(HELD_NOTE)]  # (held by this search too)
    return replace(
        final,
        legs=legs_found,
        optimisation=plan.optimisation,
        notes=(*final.notes, *held, *notes, *hint),
    )


def _from_a_later_start(plan) -> bool:
    """The plan's energy search kept a loop or legwise start (`planners.energy.SEARCHED`):
    not the lowest legs, which a search without them (`_plain_minimum`) would make again."""
    opt = plan.optimisation
    return bool(opt and opt.best is not None and opt.starts[opt.best].kind in SEARCHED)


def _plain_minimum(system, start, legs, settings) -> np.ndarray | None:
    """The stacked coefficients of the plan the energy search's own starts reach (without
    loop or legwise starts), or None if it fails. A later start's loop, cheaper without the
    limits, can run farther outside them than the loop it replaced: the constrained search
    tries that one too before seeded Newton plans."""
    from .objectives import plan_with_objective  # (which the objectives call this module from)

    plain = plan_with_objective(system, start, legs, replace(settings, search="starts"))
    return np.concatenate([leg.coefficients.ravel() for leg in plain.legs]) if plain.ok else None


def re_planned(plan, legs) -> list[int]:
    """The legs (from 1) that re-chaining re-planned after a via with free coordinates ("*"):
    the stacked searches start each leg where the plan they started from left that via, so
    the legs before it may end elsewhere (`objectives`' note, `_rechained_within`)."""
    return [
        i + 1
        for i, leg in enumerate(plan.legs)
        if i and leg.iterations and np.isnan(legs[i - 1].goal).any()
    ]


def _rechained_within(system, start, legs, settings, final, constraints):
    """`final` (re-chained from the constrained search's controls) within the limits again
    where re-chaining re-planned a leg after a via with free coordinates (`re_planned`),
    possibly outside the limits (a plan the search found inside ended 0.24 rad past a joint
    limit): the search again from `final`, each via's free coordinates held where `final`
    puts them (`held_vias`). Returns the plan, the search's notes and iterations (none where
    `final` is inside already) and a message where the search stalled or stopped or its plan
    did not re-chain (else "")."""
    held, targets, nominal = held_vias(system, start, legs, final)
    seeds = [("re-chained", np.concatenate([leg.coefficients.ravel() for leg in final.legs]))]
    try:
        found, notes, stalled, _, iterations, _ = constrained_search(
            system, nominal, held, settings, targets, seeds, constraints,
            lower_energy=settings.objective == "energy", first=True,
        )  # fmt: skip
    except (NotSearchable, *NUMERICAL_ERRORS) as exc:
        why = type(exc).__name__
        return final, [], 0, f"the constrained search stopped on a numerical failure ({why})"
    if found is None:
        return final, [], 0, stalled  # inside already (""), or stalled
    again = chain_legs(system, start, legs, settings, initial=found)
    if not again.ok:
        return final, [], 0, NOT_RECHAINED + again.message
    return again, notes, iterations, ""


def _more_starts_hint(settings, free: float, inside: float) -> list[str]:
    """A note where the first plan inside the limits (`constrained_starts = 1`) costs
    `MORE_STARTS_ABOVE` times the energy of the plan without them or more: a second start
    often gets inside lower (Sim 4 C 545.99 -> 317.23, D 280.92 -> 224.55, README)."""
    if settings.constrained_starts > 1 or settings.objective != "energy" or not free > 0:
        return []
    ratio = inside / free
    if not ratio >= MORE_STARTS_ABOVE:
        return []
    return [
        f"inside the limits the plan costs {ratio:.3g}x the energy of the plan without them "
        f"({inside:.2f} against {free:.2f}); with planner.constrained_starts = 2 the search "
        "goes on to a second start that gets inside and keeps the lower (at least twice the "
        "search's time)"
    ]


def _below_free(settings, free: float, inside: float) -> list[str]:
    """A note where the plan inside the limits costs less than the energy search's minimum
    without them (it is a plan of the free problem too): that search stopped in a higher
    minimum (a URDF task: 58.88 inside, 687.34 without, nothing said)."""
    if settings.objective != "energy" or not inside < (1.0 - 1e-6) * free:
        return []
    return [
        f"inside the limits the plan costs less than the minimum found without them "
        f"({inside:.2f} against {free:.2f}), and it is a plan without them too: that search "
        "stopped in a higher minimum"
    ]


def _folding_start(system, nominal, legs, settings, targets, seeds, constraints):
    """A start for self-collision without joint limits: the constrained search with
    auxiliary joint limits of ±`AUXILIARY_LIMIT` rad added, which keep an arm from folding
    through the base (the free plans of Sim 4 C and D do; the way out of that overlap leads
    away from the goals). Its plan is inside the original limits too. None if it does not
    apply or fails."""
    robot = getattr(system, "robot", None)
    if robot is None or not constraints.self_collision:
        return None
    joints = np.arange(robot.n_joints)
    if np.isfinite(constraints.lower[joints]).any() or np.isfinite(constraints.upper[joints]).any():
        return None
    if any(np.abs(np.asarray(q)[joints]).max() >= AUXILIARY_LIMIT for q in nominal):
        return None
    lower, upper = constraints.lower.copy(), constraints.upper.copy()
    lower[joints], upper[joints] = -AUXILIARY_LIMIT, AUXILIARY_LIMIT
    auxiliary = replace(constraints, lower=lower, upper=upper)
    try:
        coefficients = constrained_search(
            system, nominal, legs, settings, targets, seeds, auxiliary, lower_energy=False,
            first=False,
        ).coefficients  # fmt: skip
    except NUMERICAL_ERRORS:
        return None
    if coefficients is None:
        return None
    return [("joint-limited", np.concatenate([np.ravel(c) for c in coefficients]))]


def candidate_within_limits(system, start, legs, settings, plan, constraints, searched=False):
    """A candidate sequence's plan for auto mode under `constraints`: moved inside the joint
    limits, clear of itself and of the obstacles (`within_limits`, unless `searched`: planned
    by `plan_sequence` with them already), then verified on a dense re-integration and failed
    if it still breaks one, so that the comparison cannot choose it. Rate and acceleration
    limits are not checked here: time scaling meets them exactly on whichever plan is chosen
    (`limit_timing.enforce`), and at equal total duration they change no ranking."""
    from .limit_timing import enforce  # (re-integration and figures' geometry: not needed above)

    if not searchable(constraints) or not plan.ok:  # (rate limits alone: nothing to do here)
        return plan
    plan = plan.with_system(system)
    if not searched:
        plan = within_limits(system, start, legs, settings, plan, constraints)
    geometric = replace(constraints, max_rate=None, max_acceleration=None)
    return enforce(plan, geometric)
