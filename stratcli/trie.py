"""The prefix trie of candidate sequences and the processes that plan it.

Planning work is shared, not repeated. With the paper's Newton method legs are planned one
after the other, and a leg's outcome depends only on what came before it (its start
configuration and the previous leg's final controls), on its own stratum and goal, and on its
boundary conditions at the end (the next stratum's active inputs under lr-continuity, full
stop on the last leg). The candidates' legs therefore form a trie of prefixes: two sequences
that agree on their first k legs *and on these end conditions* share those k planned legs
exactly (the same seeds, the same numbers). Each node of the trie is planned once.

Other objectives (e.g. the energy-optimal one) optimise all legs of a sequence together;
there only identical sequences are shared, and `plan_sequence` is called as it is, with the
planner settings passed through untouched.

Sequences are independent, so whole sub-tries (all candidates with the same first leg) are
planned in parallel processes. Workers are forked after the model's numeric functions are
compiled, so no process compiles anything; results are assembled in the candidates' order and
do not depend on the number of processes.

Workers never outlive the command: on Linux each asks the kernel for SIGKILL when its parent
dies (`prctl(PR_SET_PDEATHSIG)`), so even a SIGKILL of the parent takes them along; they
ignore SIGINT (a Ctrl-C reaches the whole process group: the parent alone decides); and when
the parent stops waiting for any reason (an interrupt, a worker's error), it cancels what is
queued and terminates the workers instead of waiting for them.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .interrupts import checkpoint, release_signals, signals_held
from .models.system import System
from .node_margins import searchable
from .objectives import MORE_HARMONICS, plan_sequence, stalled, with_more_harmonics
from .results import LegPlan
from .sequence import SequencePlan
from .settings import PlannerSettings
from .stratified import LegSpec, LegStart, assemble, plan_next_leg, planner_for
from .within_limits import candidate_within_limits, within_limits

__all__ = [
    "STATE",
    "build_trie",
    "compare_shared",
    "compare_whole",
    "default_jobs",
    "most_workers",
    "workers_for",
]


def default_jobs() -> int:
    """Processes to use by default: every core this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


PER_CORE = 4  # worker processes a core at most, whatever `jobs` asks


def most_workers() -> int:
    """The most worker processes a pool here starts (`PER_CORE` a core): planning is CPU
    work, and `--jobs 1000` on 2 cores had forked 816 processes for a sweep of 4 tasks."""
    return PER_CORE * default_jobs()


def workers_for(jobs: int, units: int) -> int:
    """Worker processes of a local pool for `units` pieces of work at `jobs`: no more than
    there is work for, nor than `most_workers` (a pool that forks starts all of them)."""
    return max(1, min(jobs, units, most_workers()))


# ------------------------------------------------------------------------------------------
# The trie of prefixes
# ------------------------------------------------------------------------------------------


@dataclass
class _Node:
    id: int
    parent: int | None  # None: a first leg
    depth: int
    leg: LegSpec
    next_leg: LegSpec | None  # what follows (its inputs enter the leg's end conditions)
    children: list[int] = field(default_factory=list)


def _end_key(system: System, settings: PlannerSettings, legs: Sequence[LegSpec], i: int):
    """What of the next leg enters leg i's boundary conditions (and nothing else)."""
    if i + 1 == len(legs):
        return ("last", settings.full_stop)
    if settings.continuity.startswith("lr"):
        return ("next", system.stratum(legs[i + 1].stratum).active)
    return ("next",)


def _leg_key(leg: LegSpec) -> tuple:
    goal = np.asarray(leg.goal, dtype=float)
    return (leg.stratum, leg.method, float(leg.duration), goal.tobytes())


def build_trie(
    system: System, settings: PlannerSettings, sequences: Sequence[Sequence[LegSpec]]
) -> tuple[list[_Node], list[list[int]]]:
    """Nodes (each a leg to plan once) and, per sequence, the node ids of its legs."""
    nodes: list[_Node] = []
    index: dict[tuple, int] = {}
    paths: list[list[int]] = []
    for legs in sequences:
        parent: int | None = None
        path: list[int] = []
        for i, leg in enumerate(legs):
            key = (parent, _leg_key(leg), _end_key(system, settings, legs, i))
            node = index.get(key)
            if node is None:
                node = len(nodes)
                next_leg = legs[i + 1] if i + 1 < len(legs) else None
                nodes.append(_Node(node, parent, i, leg, next_leg))
                if parent is not None:
                    nodes[parent].children.append(node)
                index[key] = node
            path.append(node)
            parent = node
        paths.append(path)
    return nodes, paths


@dataclass
class _NodeResult:
    leg: LegPlan | None
    seconds: float
    error: str = ""  # an exception while planning (reported, never raised)


# Worker state: set in the parent before the pool forks, inherited by the workers.
STATE: dict[str, Any] = {}


def _plan_subtree(node_specs: list[tuple[int, int | None, LegSpec, Any]]) -> dict[int, Any]:
    """Plan a sub-trie given in depth-first order (parents before children): each node is
    one `stratified.plan_next_leg` from where its parent ended."""
    system: System = STATE["system"]
    settings: PlannerSettings = STATE["settings"]
    start: np.ndarray = STATE["start"]
    done: dict[int, _NodeResult] = {}
    after: dict[int, LegStart] = {}  # where each converged node's children start
    for node_id, parent, leg, next_leg in node_specs:
        if parent is None:
            at = LegStart(start)
        elif parent in after:
            at = after[parent]
        else:  # the parent failed: nothing to plan after it
            continue
        clock = time.perf_counter()
        try:
            result = plan_next_leg(system, settings, leg, at, next_leg, planner_for(leg, settings))
        except Exception as exc:  # a breakdown fails this sequence, not the comparison
            done[node_id] = _NodeResult(None, time.perf_counter() - clock, f"{exc}")
            continue
        done[node_id] = _NodeResult(result, time.perf_counter() - clock)
        if result.converged:
            after[node_id] = LegStart(
                result.end, result.end_controls(), at.t0 + result.duration, at.index + 1
            )
    return done


def plan_whole(items: list[tuple[int, list[LegSpec]]]) -> dict[int, Any]:
    """Plan whole sequences with `plan_sequence` (objectives that couple all legs)."""
    system: System = STATE["system"]
    settings: PlannerSettings = STATE["settings"]
    start: np.ndarray = STATE["start"]
    constraints = STATE.get("constraints")  # auto mode under [constraints]
    out = {}
    for key, legs in items:
        clock = time.perf_counter()
        try:
            plan = plan_sequence(system, start, legs, settings, constraints=constraints)
            plan = _retried(system, start, legs, settings, plan, constraints)
            plan = candidate_within_limits(
                system, start, legs, settings, plan, constraints, searched=True
            )
            out[key] = (plan, time.perf_counter() - clock, "")  # pickles without its model
        except Exception as exc:
            out[key] = (None, time.perf_counter() - clock, f"{exc}")
    return out


PR_SET_PDEATHSIG = 1  # linux/prctl.h


def worker_init(parent: int) -> None:
    """In each worker: die with the parent, leave SIGINT to it, default SIGTERM, write to the
    real stdout and stderr (a forked worker inherits whatever the parent had put there: a
    progress bar's redirection, which its output would then redraw)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    sys.stdout, sys.stderr = sys.__stdout__, sys.__stderr__
    if sys.platform.startswith("linux"):
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:  # the parent died before prctl took effect
        os._exit(1)
    release_signals()  # held while it was forked (`submit`): now they reach these handlers


def submit(pool: ProcessPoolExecutor, func: Callable, *args) -> Any:
    """`pool.submit(func, *args)`, SIGINT and SIGTERM held while it forks the workers: one
    that came before a worker's `worker_init` reached the parent's handler in the worker
    (a traceback on the terminal) or was lost (SIGTERM: `stop_workers` waited 2 s for it)."""
    with signals_held():
        return pool.submit(func, *args)


def stop_workers(pool: ProcessPoolExecutor, futures) -> None:
    """Cancel what is queued and end the workers now (not after their current unit)."""
    for future in futures:
        future.cancel()
    workers = list((getattr(pool, "_processes", None) or {}).values())
    manager = getattr(pool, "_executor_manager_thread", None)
    pool.shutdown(wait=False, cancel_futures=True)
    for worker in workers:
        worker.terminate()
    for worker in workers:
        worker.join(timeout=2.0)
        if worker.is_alive():  # pragma: no cover - SIGTERM is not ignored by workers
            worker.kill()
    if manager is not None:  # let it close its wake-up pipe now: on Python 3.11 the exit
        manager.join(timeout=2.0)  # handler could write to it as it closes (EBADF traceback)


def _remote(func: Callable, state: dict[str, Any], unit: Any) -> Any:
    """`func(unit)` on another executor's worker: the parent's STATE, with the model rebuilt
    from its `[model]` table once per process (`models.specs.system_from_ref`)."""
    if state["parent"] != os.getpid():  # in the parent's own process (threads): STATE is set
        from .models.specs import system_from_ref

        STATE.update(state, system=system_from_ref(state["model"]))
    return func(unit)


def _run_on(executor, func: Callable, units, on_unit: Callable[[int], None]) -> list[Any]:
    """Run `func(unit)` for every (unit, weight) on a given `concurrent.futures.Executor`
    (`STATE["executor"]`: e.g. a Dask cluster's), the state passed along with each unit."""
    from .models.specs import system_from_ref
    from .results import ModelRef

    system = STATE["system"]
    model = ModelRef(system.name, getattr(system, "spec", None))
    system_from_ref(model)  # ValueError here, not in a worker, for a model made in Python
    state = {k: v for k, v in STATE.items() if k not in ("system", "executor")}
    state.update(model=model, parent=os.getpid())
    results: list[Any] = [None] * len(units)
    futures = {executor.submit(_remote, func, state, unit): k for k, (unit, _) in enumerate(units)}
    try:
        for future in as_completed(futures):
            k = futures[future]
            results[k] = future.result()
            on_unit(units[k][1])
            checkpoint()
    except BaseException:
        for future in futures:
            future.cancel()
        raise
    return results


def run_units(
    func: Callable,
    units: list[tuple[Any, int]],
    jobs: int,
    on_unit: Callable[[int], None],
) -> list[Any]:
    """Run `func(unit)` for every (unit, weight): on `STATE["executor"]` when one is set,
    else in forked processes when jobs > 1."""
    if STATE.get("executor") is not None:
        return _run_on(STATE["executor"], func, units, on_unit)
    results: list[Any] = [None] * len(units)
    if jobs <= 1 or len(units) <= 1 or "fork" not in multiprocessing.get_all_start_methods():
        for k, (unit, weight) in enumerate(units):
            results[k] = func(unit)
            on_unit(weight)
        return results
    context = multiprocessing.get_context("fork")
    order = sorted(range(len(units)), key=lambda k: -units[k][1])  # big sub-tries first
    pool = ProcessPoolExecutor(
        max_workers=workers_for(jobs, len(units)),
        mp_context=context,
        initializer=worker_init,
        initargs=(os.getpid(),),
    )
    futures: dict = {}
    try:
        for k in order:
            futures[submit(pool, func, units[k][0])] = k
        for future in as_completed(futures):
            k = futures[future]
            results[k] = future.result()
            on_unit(units[k][1])
            checkpoint()  # a signal that arrived inside the pool's weakref callbacks
    except BaseException:  # an interrupt, or a worker's error: stop the workers, re-raise
        stop_workers(pool, futures)
        raise
    pool.shutdown(wait=True)
    checkpoint()
    return results


def compare_shared(system, settings, start, candidates, valid, jobs, advance):
    """Plan the `valid` candidates with their shared leg prefixes planned once (a trie of
    legs, one sub-trie a unit of work on `jobs` workers); `advance(k)` as k finish."""
    nodes, paths = build_trie(system, settings, [list(candidates[k].legs) for k in valid])
    roots = [n.id for n in nodes if n.parent is None]
    # The candidates finished with each sub-trie (for the progress bar).
    per_root: dict[int, int] = {r: 0 for r in roots}
    for path in paths:
        per_root[path[0]] += 1
    units = []
    for r in roots:
        specs, stack = [], [r]
        while stack:  # depth first, parents before children, children in insertion order
            n = nodes[stack.pop()]
            specs.append((n.id, n.parent, n.leg, n.next_leg))
            stack.extend(reversed(n.children))
        units.append((specs, per_root[r]))
    within = searchable(STATE.get("constraints"))  # auto mode within limits: two passes
    results = run_units(_plan_subtree, units, jobs, (lambda w: None) if within else advance)
    done: dict[int, _NodeResult] = {}
    for part in results:
        done.update(part)
    plans: dict[int, SequencePlan | str] = {}
    times: dict[int, float] = {}
    requested = 0
    for k, path in zip(valid, paths, strict=True):
        cand = candidates[k]
        legs: list[LegPlan] = []
        seconds = 0.0
        error = ""
        for node_id in path:
            node = done.get(node_id)
            if node is None:
                break
            seconds += node.seconds
            if node.leg is None:
                error = node.error
                requested += 1
                break
            legs.append(node.leg)
            requested += 1
            if not node.leg.converged:
                break
        plans[k] = error or assemble(system, settings, start, list(cand.legs), legs)
        times[k] = seconds
    if within:  # the second pass: each plan that reached its goals moved inside the limits
        units = [
            ((k, list(candidates[k].legs), plan), 1)
            for k, plan in plans.items()
            if isinstance(plan, SequencePlan) and plan.ok
        ]
        advance(len(valid) - len(units))  # the others are done (the progress counts these)
        for k, plan, seconds in run_units(_plan_within_limits, units, jobs, advance):
            plans[k] = plan.with_system(system)
            times[k] += seconds
    planned = len(done)
    return planned, requested, plans, times


def _plan_within_limits(unit: tuple[int, list[LegSpec], SequencePlan]) -> tuple:
    """One candidate's Newton plan moved inside its limits and verified
    (`within_limits.candidate_within_limits`): (index, plan, seconds)."""
    k, legs, plan = unit
    clock = time.perf_counter()
    system, settings, start = STATE["system"], STATE["settings"], STATE["start"]
    constraints = STATE["constraints"]
    if searchable(constraints) and plan.ok:  # searched here, retried where it stalls
        plan = within_limits(system, start, legs, settings, plan.with_system(system), constraints)
        plan = _retried(system, start, legs, settings, plan, constraints)
    plan = candidate_within_limits(system, start, legs, settings, plan, constraints, searched=True)
    return k, plan, time.perf_counter() - clock


def _retried(system, start, legs, settings, plan, constraints) -> SequencePlan:
    """`plan` planned again with more harmonics where its constrained search stalled and the
    scenario left the basis to the default (`objectives.with_more_harmonics`, the first
    count only: a candidate that needs more has others beside it, and each count costs
    seconds; STATE["more_harmonics"], set by `compare.compare`)."""
    if STATE.get("more_harmonics") and stalled(plan):
        more = MORE_HARMONICS[:1]
        return with_more_harmonics(system, start, legs, settings, plan, constraints, more=more)
    return plan


def compare_whole(system, settings, candidates, valid, jobs, advance):
    """Plan the `valid` candidates whole (the energy objective optimises all legs together:
    no prefix can be shared), each distinct sequence once; `advance(k)` as k finish."""
    distinct: dict[tuple, int] = {}
    owner: dict[int, int] = {}
    for k in valid:
        legs = candidates[k].legs
        key = tuple(
            (_leg_key(leg), _end_key(system, settings, legs, i)) for i, leg in enumerate(legs)
        )
        owner[k] = distinct.setdefault(key, k)
    firsts = sorted(set(owner.values()))
    weight = {f: sum(1 for k in valid if owner[k] == f) for f in firsts}
    units = [([(f, list(candidates[f].legs))], weight[f]) for f in firsts]
    results = run_units(plan_whole, units, jobs, advance)
    done: dict[int, Any] = {}
    for part in results:
        done.update(part)
    plans, times = {}, {}
    requested = planned = 0
    for k in valid:
        plan, seconds, error = done[owner[k]]
        if plan is not None:
            plan = plan.with_system(system)
            requested += len(plan.legs)
            if owner[k] == k:
                planned += len(plan.legs)
        plans[k] = error or plan
        times[k] = seconds
    return planned, requested, plans, times
