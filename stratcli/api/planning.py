"""Planning use cases: a scenario's legs, and auto mode (comparing and decomposing sequences:
`sequences`)."""

from __future__ import annotations

import dataclasses
import os
import sys
import warnings
from collections.abc import Callable, Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from ..arguments import checked, choice, flag, instance, integer, number, optional, source
from ..compare import CRITERIA
from ..decomposition import STRATEGIES
from ..durations import optimise_durations, timed_as
from ..errors import IllConditionedWarning, InputError, LimitWarning
from ..limit_timing import enforce
from ..objectives import plan_sequence, stalled, with_more_harmonics
from ..records.manifest import Phases, phase, since_start
from ..results import Timings
from ..scenario import Task, load_scenario
from ..sequence import SequencePlan
from ..settings import MAX_TIME_SCALE
from ..time_scaling import retimed, scale_time
from ..urdf_limits import with_limit_notes
from .auto import auto_choice, harmonics_given
from .inspection import controllability_first, limit_warnings
from .outcomes import ComparisonOutcome, PlanOutcome

IMPORTED = since_start()  # the end of the planner's imports: the "import" phase of a run
Progress = Callable[[int, int], None]  # (sequences planned so far, sequences in all)
# a loaded scenario, or what load_scenario takes (a path, TOML text or a dict)
ScenarioLike = Task | str | Path | Mapping[str, Any]

# the arguments of the use cases below, checked before any work (`stratcli.arguments`)
SCENARIO = source("scenario", Task)
JOBS = optional(integer(1))
DASK = optional(instance("an address or file name", str, os.PathLike))
TIME_SCALE = optional(number(1.0 / MAX_TIME_SCALE, MAX_TIME_SCALE))
MAX_LENGTH = optional(integer(1, 8))  # as the [decompose] table allows
STRATEGY = optional(choice(*STRATEGIES, "both"))
CRITERION = optional(choice(*CRITERIA))
CALLBACK = optional(instance("a callable", Callable))  # type: ignore[arg-type]
PROGRESS = CALLBACK  # `progress(...)`, as `warn(sentence)`


def as_task(scenario: ScenarioLike) -> Task:
    """A loaded scenario: `scenario` itself, or `load_scenario(scenario)`."""
    return scenario if isinstance(scenario, Task) else load_scenario(scenario)


# ------------------------------------------------------------------------------------------
# Planning
# ------------------------------------------------------------------------------------------


@checked(scenario=SCENARIO, check=flag, time_scale=TIME_SCALE, jobs=JOBS)
def plan(
    scenario: Task | str | Path | Mapping[str, Any],
    *,
    check: bool = True,
    time_scale: float | None = None,
    jobs: int | None = None,
) -> SequencePlan:
    """Plan a scenario: every leg to tolerance, controls continuous across switches.

    Parameters
    ----------
    scenario : Task, str, Path or Mapping
        A loaded scenario, or what `load_scenario` takes (a path, TOML text or a dict).
        Without legs (a [decompose] table only) it is planned in auto mode: every candidate
        sequence is planned and the best by the table's criterion is returned.
    check : bool
        First check that each leg's stratum spans what the leg steers.
    time_scale : float, optional
        Run the planned path this many times faster; default: `planner.time_scale`.
    jobs : int, optional
        Worker processes in auto mode (default: all cores; at most 4 a core).

    Returns
    -------
    SequencePlan
        The plan value; `.ok` is False when a leg did not reach its goal (`.message` says
        which and what to try), it is not an exception.

    Raises
    ------
    InputError
        Bad input, naming the field.
    NotControllableError
        When `check` finds a stratum that cannot do its leg; nothing is planned.

    Warns
    -----
    IllConditionedWarning
        For each leg the check expects to be ill-conditioned, with what to try instead.
    LimitWarning
        For a limit or angle that looks mistaken (degrees written as numbers, joint limits
        wider than a URDF's own), planned as written.
    """
    task = as_task(scenario)
    if not task.legs:
        outcome = plan_auto(task, check=check, jobs=jobs, time_scale=time_scale)
        best = outcome.best.result
        return dataclasses.replace(best, notes=(auto_choice(outcome), *best.notes))
    limits = set(limit_warnings(task))  # (a limit that looks mistaken: a category of its own)

    def warn(sentence: str) -> None:
        _warn(sentence, LimitWarning if sentence in limits else IllConditionedWarning)

    return plan_run(task, check=check, time_scale=time_scale, warn=warn).result


def warn_of_limits(task: Task, warn: Callable[[str], None] | None) -> None:
    """Each limit of `task` that looks mistaken (`limit_warnings`) to `warn`, or (None) as a
    `LimitWarning` attributed to the caller: auto mode and compare_sequences warned of none
    from Python, where the command line and `plan` with legs did."""
    for sentence in limit_warnings(task):
        if warn is None:
            _warn(sentence, LimitWarning)
        else:
            warn(sentence)


def _said(sentence: str) -> None:
    """A `warn` that says nothing: the caller warned already."""


def _warn(sentence: str, category: type[Warning] = IllConditionedWarning) -> None:
    """The check's warnings (or another `category`) as Python warnings, attributed to the
    caller of the use case: the first frame outside this package (however many of its frames
    are between, the argument checks' `arguments.checked` among them)."""
    package = Path(__file__).resolve().parents[1]
    frame, level = sys._getframe(1), 2
    while frame is not None and Path(frame.f_code.co_filename).resolve().is_relative_to(package):
        frame, level = frame.f_back, level + 1
    warnings.warn(sentence, category, stacklevel=level)


def plan_run(
    task: Task,
    *,
    check: bool = True,
    time_scale: float | None = None,
    progress: Callable[[str], None] | None = None,
    warn: Callable[[str], None] | None = None,
) -> PlanOutcome:
    """Plan a scenario's legs one after another, to tolerance (what `stratplan plan` runs).

    Parameters
    ----------
    task : Task
        A loaded scenario with legs (`load_scenario`); without legs use `plan_auto`.
    check : bool
        First check that each leg's stratum spans what the leg steers.
    time_scale : float, optional
        Run the planned path this many times faster; default: the scenario's
        `planner.time_scale`.
    progress : callable, optional
        Called as `progress(phase)` with a short description of each phase as it begins:
        the check, compiling the model, Newton's pass and each start of the energy search
        (e.g. to show them on a terminal); default: silent.
    warn : callable, optional
        Called as `warn(sentence)`, before any planning, for each leg the check expects to
        be ill-conditioned (see `check_controllability`) and each joint limit past a full
        turn (degrees written as numbers?); default: silent.

    Returns
    -------
    PlanOutcome
        The plan (`.ok` is False when a leg failed), result.json and timings.

    Raises
    ------
    NotControllableError
        When `check` finds a leg its stratum cannot steer; nothing is planned.
    """
    if not task.legs:
        raise InputError("the scenario has no legs: plan it in auto mode (plan_auto)", task.source)
    task = _at_scale(task, time_scale)
    say = progress or (lambda phase: None)
    for sentence in limit_warnings(task) if warn else ():
        warn(sentence)  # before the check and the planning: the limits may be a typo
    phases: Phases = {"import": dict(IMPORTED)}
    with phase(phases, "check"):
        if check:
            say("checking controllability (Lie brackets of each leg's stratum)")
        check_time = controllability_first(task, warn=warn) if check else None
    started = datetime.now(UTC)
    with phase(phases, "compile"):  # generate the numeric functions first: not planning
        say("compiling the model")
        for leg in task.legs:
            task.system.compiled(leg.stratum)
    compile_time = phases["compile"]["wall_s"]  # the check's own time is `check_time`
    with phase(phases, "planning"):
        legs = task.legs
        if task.settings.durations == "optimise":
            total = task.settings.total_duration or sum(leg.duration for leg in task.legs)
            result = optimise_durations(
                task.system, task.start, task.legs, task.settings, total, progress,
                constraints=task.constraints,
            )  # fmt: skip
            legs = timed_as(task.legs, result)  # as chosen: a retry plans these durations
        else:
            result = plan_sequence(
                task.system, task.start, task.legs, task.settings, progress=progress,
                constraints=task.constraints,
            )  # fmt: skip
        if stalled(result) and not harmonics_given(task):
            again = with_more_harmonics(
                task.system, task.start, legs, task.settings, result, task.constraints, progress
            )
            chosen = tuple(n for n in result.notes if n.startswith("durations optimised"))
            if again is not result and chosen and not again.message:  # the durations' note
                again = dataclasses.replace(again, notes=(*chosen, *again.notes))
            result = again
    planning_time = phases["planning"]["wall_s"]
    scale = task.scenario.planner.time_scale
    if task.constraints is not None:  # rate limits by time scaling; every limit verified
        with phase(phases, "constraints"):
            say("verifying the constraints on a dense re-integration")
            result = within_rates(result.with_system(task.system), task, scale)
    else:  # a URDF's joint limits, unless [constraints] verified them: noted (at its speed)
        result = retimed(result, scale) if scale != 1.0 else result
        result = with_limit_notes(result, task)
    result = _with_attitude_notes(result, task)
    result = _named(result, task, Timings(started.isoformat(), compile_time, planning_time))
    doc = result.to_dict()
    return PlanOutcome(task, result, doc, started, compile_time, planning_time, phases, check_time)


@checked(
    scenario=SCENARIO, check=flag, jobs=JOBS, progress=PROGRESS, time_scale=TIME_SCALE,
    warn=CALLBACK,
)  # fmt: skip
def plan_auto(
    scenario: ScenarioLike,
    *,
    check: bool = True,
    jobs: int | None = None,
    progress: Progress | None = None,
    time_scale: float | None = None,
    warn: Callable[[str], None] | None = None,
) -> ComparisonOutcome:
    """Auto mode: plan every candidate sequence of the [decompose] table, keep the best.

    Parameters
    ----------
    scenario : Task, str, Path or Mapping
        A scenario without legs (loaded, or what `load_scenario` takes); its start, goal and
        [decompose] table are used.
    check : bool
        First check that the candidate strata together reach every direction.
    jobs : int, optional
        Worker processes (default: all cores; at most 4 a core, `trie.most_workers`).
    progress : callable, optional
        Called as `progress(done, total)` while sequences are planned.
    time_scale : float, optional
        Run the chosen plan this many times faster; default: the scenario's
        `planner.time_scale`. The candidates are ranked as planned (a time scale changes
        every candidate's energy, peak control and duration by the same factor).
    warn : callable, optional
        Called as `warn(sentence)`, before any planning, for each limit that looks mistaken
        (`limit_warnings`); default: a `LimitWarning` each, as `plan` issues.

    Returns
    -------
    ComparisonOutcome
        The ranking and, in `.best`, the chosen sequence's `PlanOutcome` (its plan, a
        `SequencePlan`: `.best.result`).

    Raises
    ------
    NotControllableError
        When `check` finds the strata cannot reach every direction; nothing is planned.
    InputError
        When no candidate sequence could even be planned.
    """
    task = _at_scale(as_task(scenario), time_scale)
    warn_of_limits(task, warn)  # (before the check: the limits may be a typo)
    if check:
        controllability_first(task)
    from .sequences import compare_sequences  # (which imports this module)

    outcome = compare_sequences(task, jobs=jobs, progress=progress, warn=_said)
    scale = task.scenario.planner.time_scale
    if scale == 1.0:
        return outcome
    chosen = outcome.comparison.best.plan  # re-timed from the plan as compared
    result = _named(chosen_as_run(chosen, task, scale), task, outcome.best.result.timings)
    notes = result.notes[len(chosen.notes) :]  # at this speed, not the one compared at
    best = dataclasses.replace(outcome.best, result=result, document=result.to_dict())
    return dataclasses.replace(outcome, best=best, notes=notes)


def _at_scale(task: Task, time_scale: float | None) -> Task:
    """`task` with `planner.time_scale` set to `time_scale` where one is given (the
    `--time-scale` option): the record then holds the scenario as it was run, and planning
    its scenario.toml again gives the record's plan (as with `--objective`)."""
    if time_scale is None or time_scale == task.scenario.planner.time_scale:
        return task
    return task.with_changes({"planner": {"time_scale": float(time_scale)}})


def chosen_as_run(plan: SequencePlan, task: Task, scale: float = 1.0) -> SequencePlan:
    """Auto mode's chosen plan as it will run: `scale` times faster, under [constraints]
    slowed to its rate limits with every limit verified (`within_rates`) if it reached its
    goals within them (a failed one is only re-timed, its limits measured again), without
    them a URDF's joint limits noted at that speed (`urdf_limits.with_limit_notes`)."""
    plan = plan.with_system(task.system)
    if task.constraints is not None and plan.ok:
        return _with_attitude_notes(within_rates(plan, task, scale), task)
    plan = retimed(plan, scale) if scale != 1.0 else plan
    return _with_attitude_notes(with_limit_notes(plan, task), task)


def _with_attitude_notes(plan: SequencePlan, task: Task) -> SequencePlan:
    """`plan` with a note of each attitude of a URDF task that turns by more than π
    (`spatial_scenario.long_attitudes`): it reaches the shorter rotation vector."""
    from ..models.spatial_scenario import long_attitudes

    notes = [note for note in long_attitudes(task) if note not in plan.notes]
    return dataclasses.replace(plan, notes=(*plan.notes, *notes)) if notes else plan


def within_rates(result: SequencePlan, task: Task, scale: float = 1.0) -> SequencePlan:
    """`result` run `scale` times faster, then slowed to its rate and acceleration limits
    where that was too fast, every limit of `task.constraints` verified (`enforce`); a
    note says when the limits overrode the time scale asked for."""
    scaled = scale_time(result, scale) if scale != 1.0 else result
    try:
        out = enforce(scaled, task.constraints)
    except InputError as exc:  # a rate limit too small to be met by any slowing down
        raise exc.with_source(task.source) from None
    if scale > 1.0 and out.time_scale < scaled.time_scale:
        note = (
            f"the time scale {scale:g} asked for is too fast for the limits: "
            f"{out.time_scale:.4g} in all"
        )
        out = dataclasses.replace(out, notes=(*out.notes, note))
    return out


def _named(plan: SequencePlan, task: Task, timings: Timings) -> SequencePlan:
    """The plan with what its scenario knows: name, paper energy, text and timings."""
    reference = task.scenario.reference.energy if task.scenario.reference else None
    return dataclasses.replace(
        plan,
        scenario=task.scenario.name,
        reference_energy=reference,
        scenario_text=task.text,
        timings=timings,
    )
