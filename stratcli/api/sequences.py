"""Use cases on sequences of strata: comparing every candidate sequence (planned and ranked)
and decomposing a task into candidates without planning them."""

from __future__ import annotations

import dataclasses
import os
import sys
from collections.abc import Callable, Iterator
from concurrent.futures import Executor
from contextlib import contextmanager
from datetime import UTC, datetime

import numpy as np

from ..arguments import checked, flag
from ..decomposition import moved_coordinates
from ..errors import UnusedLegsWarning
from ..format import pi_fraction
from ..records.comparison import comparison_document
from ..records.manifest import Phases, phase
from ..results import Timings
from ..scenario import LegEntry, Task
from ..trie import default_jobs, most_workers
from .auto import auto_settings, compare_decomposition, decompose_task
from .outcomes import ComparisonOutcome, DecompositionOutcome, PlanOutcome
from .planning import (
    CALLBACK,
    CRITERION,
    DASK,
    IMPORTED,
    JOBS,
    MAX_LENGTH,
    PROGRESS,
    SCENARIO,
    STRATEGY,
    Progress,
    ScenarioLike,
    _named,
    _warn,
    as_task,
    chosen_as_run,
    warn_of_limits,
)

__all__ = ["compare_sequences", "decompose", "with_legs"]


@checked(
    scenario=SCENARIO, max_length=MAX_LENGTH, strategy=STRATEGY, criterion=CRITERION, jobs=JOBS,
    progress=PROGRESS, exhaustive=flag, dask=DASK, warn=CALLBACK,
)  # fmt: skip
def compare_sequences(
    scenario: ScenarioLike,
    *,
    max_length: int | None = None,
    strategy: str | None = None,
    criterion: str | None = None,
    jobs: int | None = None,
    progress: Progress | None = None,
    exhaustive: bool = False,
    executor: Executor | None = None,
    dask: str | os.PathLike | None = None,
    warn: Callable[[str], None] | None = None,
) -> ComparisonOutcome:
    """Plan every candidate sequence of strata in parallel and rank them.

    Parameters
    ----------
    scenario : Task, str, Path or Mapping
        A scenario (loaded, or what `load_scenario` takes); its start and goal are decomposed.
    max_length : int, optional
        Longest sequence of strata (default: decompose table, else 3; at most 8).
    strategy : str, optional
        conservative | postponed | both (default: decompose table, else conservative).
    criterion : str, optional
        energy | peak-control | excursion | duration (default: decompose table, else energy).
    jobs : int, optional
        Worker processes (default: all cores; at most 4 a core, `trie.most_workers`);
        ignored with `dask` or `executor`.
    progress : callable, optional
        Called as `progress(done, total)` while sequences are planned.
    exhaustive : bool
        With the energy objective and criterion: search every candidate to its minimum
        instead of screening them (`compare.compare`, `screen`; the rows not searched, only
        bounded, are marked `screened` in comparison.json).
    executor, dask : concurrent.futures.Executor or str, optional
        Plan on this executor, or on the Dask cluster of this scheduler address or file,
        instead of `jobs` forked processes (the same results; a scenario's model only).
    warn : callable, optional
        Called as `warn(sentence)`, before any planning, for each limit that looks mistaken
        (`limit_warnings`); default: a `LimitWarning` each, as `plan` issues.

    Returns
    -------
    ComparisonOutcome
        Outcomes, ranking, comparison.json and, in `.best`, the best sequence's
        `PlanOutcome` (its plan: `.best.result`).

    Raises
    ------
    InputError
        Bad input, naming the field or the argument (`max_length`, `strategy`, ...), or no
        candidate sequence could even be planned.
    TypeError
        An argument of the wrong type, named.
    """
    task = as_task(scenario)
    auto, dec = _decomposition(task, max_length, strategy, criterion)
    warn_of_limits(task, warn)
    started = datetime.now(UTC)
    total, done = len(dec.candidates), 0

    def advance(k: int) -> None:
        nonlocal done
        done += k
        if progress is not None:
            progress(done, total)

    phases: Phases = {"import": dict(IMPORTED)}
    jobs = jobs or default_jobs()
    with _cluster(dask, executor, jobs) as chosen:  # connected before any progress is shown
        if progress is not None:
            progress(0, total)
        with phase(phases, "planning"):  # the whole comparison (CPU: this process's only)
            comparison, compile_time = compare_decomposition(
                task, auto, dec, jobs=jobs, progress=advance,
                exhaustive=exhaustive, executor=chosen,
            )  # fmt: skip
    doc = comparison_document(
        comparison,
        dec,
        scenario=task.scenario.name,
        model=task.model_name,
        states=task.system.states,
        start=task.start,
        goal=task.goal,
        settings={
            k: getattr(task.settings, k)
            for k in ("continuity", "soft_start", "full_stop", "tolerance", "seed", "objective")
            if hasattr(task.settings, k)
        },
        compile_time=compile_time,
    )
    best = comparison.best
    best_task = with_legs(task, best.candidate.legs)
    timings = Timings(started.isoformat(), compile_time, comparison.wall_time)
    result = chosen_as_run(best.plan, task)  # rate limits met, or a URDF's limits noted
    notes = result.notes[len(best.plan.notes) :]  # what the ranking does not show: both
    result = _named(result, task, timings)
    plan = PlanOutcome(
        best_task, result, result.to_dict(), started, compile_time, comparison.wall_time, phases
    )
    return ComparisonOutcome(task, auto, dec, comparison, doc, plan, notes)


@contextmanager
def _cluster(
    dask: str | os.PathLike | None, executor: Executor | None, jobs: int
) -> Iterator[Executor | None]:
    """`executor`, or the executor of the Dask cluster at `dask` (InputError when it cannot
    be reached: `sweep.executors.dask_executor`); else None (the comparison forks its own
    workers), except off Linux with `jobs` > 1: there a pool of spawned workers
    (`sweep.executors.local_executor`), as a sweep's. The comparison forked wherever "fork"
    exists, macOS included, whose system libraries (Accelerate) are not fork-safe; spawned
    workers give the same comparison.json (a test compares the two on Linux)."""
    if dask is None and executor is None and jobs > 1 and not sys.platform.startswith("linux"):
        from ..sweep.executors import local_executor

        pool = local_executor(min(jobs, most_workers()))  # (as `compare` caps its jobs)
        try:
            yield pool
        finally:
            pool.shutdown(cancel_futures=True)
        return
    if dask is None or executor is not None:
        yield executor
        return
    from ..sweep.executors import dask_executor

    with dask_executor(os.fspath(dask)) as (cluster, _):
        yield cluster


@checked(scenario=SCENARIO, max_length=MAX_LENGTH, strategy=STRATEGY)
def decompose(
    scenario: ScenarioLike, *, max_length: int | None = None, strategy: str | None = None
) -> DecompositionOutcome:
    """The candidate sequences of strata and their via configurations, without planning.

    Parameters
    ----------
    scenario : Task, str, Path or Mapping
        A scenario (loaded, or what `load_scenario` takes); its start and goal are decomposed.
    max_length : int, optional
        Longest sequence of strata (default: decompose table, else 3; at most 8).
    strategy : str, optional
        conservative | postponed | both (default: decompose table, else conservative).

    Returns
    -------
    DecompositionOutcome
        The decomposition and its JSON document.
    """
    task = as_task(scenario)
    auto, dec = _decomposition(task, max_length, strategy)
    system = task.system
    rows = [
        {
            "index": k + 1,
            "sequence": list(cand.sequence),
            "strategy": cand.strategy,
            "vias": [[None if x != x else float(x) for x in v] for v in cand.vias],
            "vias_pi": [[pi_fraction(float(x)) for x in v] for v in cand.vias],
            "loops": list(cand.redundant_legs(task.start)),
        }
        for k, cand in enumerate(dec.candidates)
    ]
    # a URDF attitude past a half turn: the rotation the vias and plans use is the shorter
    # one (said by `plan` alone, where decompose listed rz = 4 as the goal)
    from ..models.spatial_scenario import long_attitudes

    notes = tuple(long_attitudes(task))
    doc = {
        "scenario": task.scenario.name,
        "coordinates": list(system.states),
        "essential": [system.states[i] for i in dec.essential],
        "candidate_strata": list(dec.candidates_strata),
        "moves": {  # what each candidate stratum can change
            s: [system.states[i] for i in moved_coordinates(system, s)]
            for s in dec.candidates_strata
        },
        "max_length": dec.max_length,
        "strategies": list(dec.strategies),
        "sequences": rows,
        "notes": list(notes),
    }
    return DecompositionOutcome(task, auto, dec, doc, notes)


def _decomposition(task: Task, max_length, strategy, criterion=None):
    """[decompose] settings with overrides (checked by the use cases: `MAX_LENGTH`, ...), and
    the decomposition; InputError naming the field or argument to change."""
    auto = auto_settings(task, max_length=max_length, strategy=strategy, criterion=criterion)
    for note in auto.notes:  # the legs it does not use: in Python too (the CLI prints notes)
        _warn(note, UnusedLegsWarning)
    return auto, decompose_task(task, auto)


def with_legs(task: Task, legs) -> Task:
    """The scenario rewritten with a chosen sequence's legs (what resolved.json records): a
    plain scenario that plans that sequence again. The [decompose] table that chose it is
    left out (a scenario gives one or the other); comparison.json keeps its settings."""
    entries = [
        LegEntry(
            stratum=leg.stratum,
            method=leg.method,
            goal=[float(g) if np.isfinite(g) else "*" for g in leg.goal],  # NaN: free, "*"
            duration=leg.duration,
        )
        for leg in legs
    ]
    scenario = task.scenario.model_copy(update={"legs": entries, "decompose": None})
    return dataclasses.replace(task, scenario=scenario, legs=list(legs))
