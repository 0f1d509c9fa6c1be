"""Plan every candidate sequence of a decomposition and rank them.

`compare` plans the candidates (sharing work through `trie`: prefixes once with the Newton
objective, identical sequences once otherwise, sub-tries in parallel processes), measures
each (energy, peak |u|, joint excursion, duration) and ranks them by a criterion.

The screen (`screen=K`, energy objective and criterion; auto mode's default, `SCREEN_TOP`):
branch and bound (`stratcli.screen`). Every distinct leg of the candidates is planned alone
at minimum energy, without the continuity conditions that couple it to its neighbours; a
sequence's minimum is at least the sum of its legs' (its `energy_bound`). Candidates are
then searched fully in the order of their bounds until the next bound is not below the best
value found (at least K of them); the others are *bounded* (status "bounded", `screened`):
not planned, their minimum is at least their bound, which is at least the best's. They rank
after the searched ones, by bound. `screen=None` plans every candidate to its minimum
(exhaustive), and so does a screen where no two candidates share a leg (its bounds would
each serve one candidate: `screen.legs_shared`). The bound is exact for exact leg minima
and the legs' searches are local, so a searched sequence whose leg costs less than that
leg's bound lowers it before anything more is pruned (tests/test_screen.py and
benchmarks/bench_screen.py compare the choice with the exhaustive search's).

Equal duration. A sequence's energy falls as its duration grows (time-scaling a path by s
multiplies its energy by s and its duration by 1/s, so energy × duration is a property of the
path), and candidates of different lengths have different total durations. The energy
criterion therefore compares every sequence at one total duration, the shortest candidate's
`reference_duration` T: `energy_equal_time = energy · duration / T`, the energy its path would
take if run in T. The screen compares the same quantity. The raw energy of each plan (as
planned, at its own duration) is reported beside it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import replace

import numpy as np

from .comparison_values import (  # (the values, here where callers look for them)
    CRITERIA,
    Comparison,
    Outcome,
    _show,
    rank,
)
from .decomposition import Candidate
from .errors import InputError
from .leg_checks import check_legs
from .metrics import as_run, peak_and_excursion
from .models.system import System
from .screen import legs_shared, screen_candidates
from .settings import PlannerSettings
from .trie import STATE, compare_shared, compare_whole, most_workers

SCREEN_TOP = 1  # candidates fully searched (lowest bounds) before any is pruned


def is_newton(settings: PlannerSettings) -> bool:
    """True for the paper's leg-by-leg Newton method (the only one before `objective`)."""
    return getattr(settings, "objective", "newton") == "newton"


# ------------------------------------------------------------------------------------------
# Comparison
# ------------------------------------------------------------------------------------------


def compare(
    system: System,
    start: np.ndarray,
    candidates: Sequence[Candidate],
    settings: PlannerSettings,
    *,
    criterion: str = "energy",
    jobs: int = 1,
    progress: Callable[[int], None] | None = None,
    screen: int | None = None,
    executor: Executor | None = None,
    constraints=None,
    more_harmonics: bool = False,
) -> Comparison:
    """Plan every candidate (sharing work), measure it, rank by `criterion`.

    `progress(k)` is called whenever k more candidates are finished. Compile the candidates'
    strata first (`system.compiled`) so that forked workers inherit them. `screen` (K, used
    with the energy objective and criterion only): the K best by Newton energy are searched
    fully, the others against their minimum (see the module's docstring); None: all fully.
    `executor` (any `concurrent.futures.Executor`, e.g. a Dask cluster's): plan the sub-tries
    there instead of in forked processes; its workers rebuild the model from its `[model]`
    table (a model made in Python has none: use `jobs`). `constraints` (a resolved
    [constraints] table): every candidate planned within its joint limits, self-collision and
    obstacles, and failed where it still breaks one (`within_limits.candidate_within_limits`);
    with `more_harmonics` (the scenario leaves the basis to the default) a candidate whose
    constrained search stalls is planned again with more (`objectives.with_more_harmonics`,
    its first count: `trie._retried`).
    """
    if criterion not in CRITERIA:
        raise ValueError(f"unknown criterion {criterion!r} (known: {', '.join(CRITERIA)})")
    jobs = max(1, min(jobs, most_workers()))  # (a pool that forks starts every worker at once)
    start = np.asarray(start, dtype=float)
    advance = progress or (lambda k: None)
    clock = time.perf_counter()
    outcomes: list[Outcome | None] = [None] * len(candidates)
    screen_result = None  # the screen's bounds (energy objective and criterion)
    valid: list[int] = []
    for k, cand in enumerate(candidates):
        try:
            check_legs(system, start, list(cand.legs), settings)
        except InputError as exc:
            reason = exc.problems[0].message
            outcomes[k] = Outcome(k, cand, None, "failed", reason, str(exc))
            advance(1)
            continue
        if outside := _vias_outside(system, cand, constraints):
            outcomes[k] = Outcome(k, cand, None, "failed", outside[0], "; ".join(outside))
            advance(1)
            continue
        valid.append(k)
    for cand in candidates:
        for leg in cand.legs:
            cs = system.compiled(leg.stratum)  # before forking: workers inherit the functions
            if settings.evaluator == "ode":
                _ = cs.G, cs.dG  # the general path's functions are generated on first use
    durations = [sum(leg.duration for leg in cand.legs) for cand in candidates]
    reference = min((d for d in durations if d > 0), default=math.nan)
    STATE.update(
        system=system, settings=settings, start=start, executor=executor, constraints=constraints,
        more_harmonics=more_harmonics,
    )  # fmt: skip
    try:
        if is_newton(settings):
            planned, requested, plans, times = compare_shared(
                system, settings, start, candidates, valid, jobs, advance
            )
        elif (
            screen is not None
            and criterion == "energy"
            and legs_shared(system, candidates, valid, start)
        ):
            planned, requested, plans, times, screen_result = screen_candidates(
                system, settings, start, candidates, valid, jobs, advance, screen, reference
            )
        else:
            planned, requested, plans, times = compare_whole(
                system, settings, candidates, valid, jobs, advance
            )
    finally:
        STATE.clear()
    for k in valid:
        if k in plans:
            outcomes[k] = _outcome(k, candidates[k], plans[k], times[k], system, settings)
            outcomes[k] = as_run(outcomes[k], constraints)
        else:  # pruned by the screen: not planned
            outcomes[k] = _bounded(k, candidates[k], screen_result.bounds[k])
        if screen_result is not None:
            outcomes[k] = replace(
                outcomes[k],
                energy_bound=screen_result.bounds[k],
                leg_bounds=screen_result.leg_bounds.get(k, ()),
            )
    outcomes = [replace(o, reference_duration=reference) for o in outcomes]
    wall = time.perf_counter() - clock
    ranking = rank([o for o in outcomes if o is not None], criterion)
    for r, k in enumerate(ranking):
        outcomes[k] = replace(outcomes[k], rank=r + 1)
    return Comparison(
        outcomes=list(outcomes),
        ranking=ranking,
        criterion=criterion,
        jobs=jobs,
        on=_where(executor),
        legs_requested=requested,
        legs_planned=planned,
        wall_time=wall,
        shared=is_newton(settings),
        reference_duration=reference,
        screen=screen_result,
    )


def _vias_outside(system: System, cand: Candidate, constraints) -> list[str]:
    """Where a candidate's via breaks a joint limit or a clearance, one line each: no plan
    of it exists (a via on an obstacle was searched for 3.4 s, its stall advising more
    harmonics, and a candidate with the same via bounded as if it could win), as a
    scenario's own vias are refused before planning."""
    if constraints is None:
        return []
    from .body_clearances import check_configuration

    return [
        f"{p.path}: {p.message}"
        for i, leg in enumerate(cand.legs[:-1])
        for p in check_configuration(
            system, leg.goal, constraints, f"via {i + 1} (after {leg.stratum})"
        )
    ]


def _bounded(k, cand, bound) -> Outcome:
    """A candidate the screen pruned: its lower bound is at least the best's value."""
    duration = sum(leg.duration for leg in cand.legs)
    reason = "not searched: its lower bound is at least the best's value"
    message = (
        f"not searched: its energy is at least {_show(bound, 'energy')} (the sum of its legs' "
        "minima, each leg planned alone without the conditions that tie it to its "
        "neighbours or bounded below by the joints' travel and the stratum's curvature), which "
        "cannot beat the best sequence"
    )
    return Outcome(k, cand, None, "bounded", reason, message, duration=duration, screened=True)


def _where(executor) -> str:
    """Where a comparison given an executor ran (`Comparison.on`); "" for local processes."""
    if executor is None:
        return ""
    module = type(executor).__module__.split(".")[0]
    return "a Dask cluster" if module in ("distributed", "dask") else "the executor given"


def first_clause(message: str) -> str:
    """`message` up to its first ";" outside parentheses: the reason, without the advice
    ("... violated by 0.484 rad at its nodes (with 3 harmonics; it stalled with 5 and 8 too)"
    was cut inside its parenthesis)."""
    depth = 0
    for i, c in enumerate(message):
        depth += (c == "(") - (c == ")")
        if c == ";" and depth <= 0:
            return message[:i]
    return message


def _outcome(k, cand, plan, seconds, system, settings) -> Outcome:
    if isinstance(plan, str):  # an exception while planning
        return Outcome(k, cand, None, "failed", plan, plan, planning_time=seconds)
    peak, excursion = peak_and_excursion(plan, system)
    reason = ""
    if not plan.ok:
        last = plan.legs[-1] if plan.legs else None
        # why, where the leg's planner knows: a URDF stratum that cannot move a goal's
        # direction there (`reachability.out_of_reach`), a continuation that fell short
        why = f" ({last.message})" if last is not None and last.message else ""
        reason = (
            f"leg {last.index + 1} on {last.stratum}: error {last.error:.3g} > "
            f"tolerance {settings.tolerance:g}{why}"
            if last is not None and not last.converged
            else first_clause(plan.message)
        )
    return Outcome(
        k,
        cand,
        plan,
        "ok" if plan.ok else "failed",
        reason,
        plan.message if not plan.ok else "",
        energy=plan.total_energy,
        peak_control=peak,
        excursion=excursion,
        duration=plan.duration,
        planning_time=seconds,
    )


def compile_strata(system: System, names) -> float:
    """Generate the numeric functions of `names` (start-up, not planning); seconds taken."""
    clock = time.perf_counter()
    for name in names:
        system.compiled(name)
    return time.perf_counter() - clock


__all__ = [
    "CRITERIA",
    "SCREEN_TOP",
    "Comparison",
    "Outcome",
    "compare",
    "compile_strata",
    "rank",
]
