"""Plan every candidate sequence of a decomposition and rank them (DESIGN §5.5).

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
"""

from __future__ import annotations

import math
import multiprocessing
import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .decompose import Candidate
from .errors import InputError
from .models.system import System
from .results import LegPlan
from .sequence import SequencePlan
from .settings import PlannerSettings
from .stratified import (
    LegSpec,
    LegStart,
    assemble,
    check_legs,
    plan_next_leg,
    plan_sequence,
    planner_for,
)

CRITERIA = ("energy", "peak-control", "excursion", "duration")
CRITERION_LABELS = {
    "energy": "total energy",
    "peak-control": "peak |u|",
    "excursion": "largest joint excursion",
    "duration": "total duration",
}
SAMPLES_PER_LEG = 1001  # for peak |u| and joint excursions


def default_jobs() -> int:
    """Processes to use by default: every core this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


@dataclass
class Outcome:
    """One candidate, planned (or not), with the quantities it is ranked by."""

    index: int  # position among the candidates (enumeration order)
    candidate: Candidate
    plan: SequencePlan | None  # None when the legs were rejected before planning
    status: str  # "ok" | "failed"
    reason: str  # short, for tables; "" when ok
    message: str  # full message (as in result.json), "" when ok
    energy: float = math.nan
    peak_control: float = math.nan
    excursion: float = math.nan
    duration: float = math.nan
    planning_time: float = 0.0  # seconds: this sequence's legs (shared ones included)
    rank: int | None = None

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def value(self, criterion: str) -> float:
        return {
            "energy": self.energy,
            "peak-control": self.peak_control,
            "excursion": self.excursion,
            "duration": self.duration,
        }[criterion]


@dataclass
class Comparison:
    """All outcomes, their ranking and what sharing and parallelism did."""

    outcomes: list[Outcome]  # enumeration order
    ranking: list[int]  # outcome indices, best first (failed ones last)
    criterion: str
    jobs: int
    legs_requested: int  # legs the candidates' plans hold (what planning each alone costs)
    legs_planned: int  # legs actually planned
    wall_time: float
    shared: bool  # prefix sharing used (Newton objective)

    @property
    def best(self) -> Outcome | None:
        return self.outcomes[self.ranking[0]] if self.ranking else None

    @property
    def legs_saved(self) -> int:
        return self.legs_requested - self.legs_planned

    def choice(self) -> str:
        """Which sequence is best and why, in one sentence."""
        best = self.best
        if best is None:
            return "no candidate sequences"
        ok = [self.outcomes[i] for i in self.ranking if self.outcomes[i].ok]
        label = CRITERION_LABELS[self.criterion]
        if not best.ok:
            return (
                "no sequence reached the goal; the one that got furthest was "
                f"{best.candidate.label} {best.candidate.strategy} ({best.reason})"
            )
        text = (
            f"{best.candidate.label} {best.candidate.strategy}: lowest {label} "
            f"({_show(best.value(self.criterion), self.criterion)}) of {len(ok)} sequences "
            "that reached the goal"
        )
        if len(ok) > 1:
            runner = ok[1]
            text += (
                f"; next {runner.candidate.label} {runner.candidate.strategy} at "
                f"{_show(runner.value(self.criterion), self.criterion)}"
            )
            if runner.value(self.criterion) == best.value(self.criterion):
                text += " (a tie, broken by total energy)"
        return text


def _show(x: float, criterion: str) -> str:
    if criterion == "duration":
        return f"{x:g}"
    return f"{x:,.2f}" if abs(x) < 1e6 else f"{x:.3e}"


def is_newton(settings: PlannerSettings) -> bool:
    """True for the paper's leg-by-leg Newton method (the only one before `objective`)."""
    return getattr(settings, "objective", "newton") == "newton"


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
_STATE: dict[str, Any] = {}


def _plan_subtree(node_specs: list[tuple[int, int | None, LegSpec, Any]]) -> dict[int, Any]:
    """Plan a sub-trie given in depth-first order (parents before children): each node is
    one `stratified.plan_next_leg` from where its parent ended."""
    system: System = _STATE["system"]
    settings: PlannerSettings = _STATE["settings"]
    start: np.ndarray = _STATE["start"]
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


def _plan_whole(items: list[tuple[int, list[LegSpec]]]) -> dict[int, Any]:
    """Plan whole sequences with `plan_sequence` (objectives that couple all legs)."""
    system: System = _STATE["system"]
    settings: PlannerSettings = _STATE["settings"]
    start: np.ndarray = _STATE["start"]
    out = {}
    for key, legs in items:
        clock = time.perf_counter()
        try:
            plan = plan_sequence(system, start, legs, settings)
            out[key] = (plan, time.perf_counter() - clock, "")  # pickles without its model
        except Exception as exc:
            out[key] = (None, time.perf_counter() - clock, f"{exc}")
    return out


def _run(
    func: Callable,
    units: list[tuple[Any, int]],
    jobs: int,
    on_unit: Callable[[int], None],
) -> list[Any]:
    """Run `func(unit)` for every (unit, weight); in processes when jobs > 1."""
    results: list[Any] = [None] * len(units)
    if jobs <= 1 or len(units) <= 1 or "fork" not in multiprocessing.get_all_start_methods():
        for k, (unit, weight) in enumerate(units):
            results[k] = func(unit)
            on_unit(weight)
        return results
    context = multiprocessing.get_context("fork")
    order = sorted(range(len(units)), key=lambda k: -units[k][1])  # big sub-tries first
    with ProcessPoolExecutor(max_workers=min(jobs, len(units)), mp_context=context) as pool:
        futures = {pool.submit(func, units[k][0]): k for k in order}
        for future in as_completed(futures):
            k = futures[future]
            results[k] = future.result()
            on_unit(units[k][1])
    return results


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
) -> Comparison:
    """Plan every candidate (sharing work), measure it, rank by `criterion`.

    `progress(k)` is called whenever k more candidates are finished. Compile the candidates'
    strata first (`system.compiled`) so that forked workers inherit them.
    """
    if criterion not in CRITERIA:
        raise ValueError(f"unknown criterion {criterion!r} (known: {', '.join(CRITERIA)})")
    start = np.asarray(start, dtype=float)
    advance = progress or (lambda k: None)
    clock = time.perf_counter()
    outcomes: list[Outcome | None] = [None] * len(candidates)
    valid: list[int] = []
    for k, cand in enumerate(candidates):
        try:
            check_legs(system, start, list(cand.legs), settings)
        except InputError as exc:
            reason = exc.problems[0].message
            outcomes[k] = Outcome(k, cand, None, "failed", reason, str(exc))
            advance(1)
            continue
        valid.append(k)
    for cand in candidates:
        for leg in cand.legs:
            cs = system.compiled(leg.stratum)  # before forking: workers inherit the functions
            if settings.evaluator == "ode":
                _ = cs.G, cs.dG  # the general path's functions are generated on first use
    _STATE.update(system=system, settings=settings, start=start)
    try:
        if is_newton(settings):
            planned, requested, plans, times = _compare_shared(
                system, settings, start, candidates, valid, jobs, advance
            )
        else:
            planned, requested, plans, times = _compare_whole(
                system, settings, candidates, valid, jobs, advance
            )
    finally:
        _STATE.clear()
    for k in valid:
        outcomes[k] = _outcome(k, candidates[k], plans[k], times[k], system, settings)
    wall = time.perf_counter() - clock
    ranking = rank([o for o in outcomes if o is not None], criterion)
    for r, k in enumerate(ranking):
        outcomes[k].rank = r + 1
    return Comparison(
        outcomes=list(outcomes),
        ranking=ranking,
        criterion=criterion,
        jobs=jobs,
        legs_requested=requested,
        legs_planned=planned,
        wall_time=wall,
        shared=is_newton(settings),
    )


def _compare_shared(system, settings, start, candidates, valid, jobs, advance):
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
    results = _run(_plan_subtree, units, jobs, advance)
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
    planned = len(done)
    return planned, requested, plans, times


def _compare_whole(system, settings, candidates, valid, jobs, advance):
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
    results = _run(_plan_whole, units, jobs, advance)
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


def _outcome(k, cand, plan, seconds, system, settings) -> Outcome:
    if isinstance(plan, str):  # an exception while planning
        return Outcome(k, cand, None, "failed", plan, plan, planning_time=seconds)
    out = Outcome(k, cand, plan, "ok" if plan.ok else "failed", "", "", planning_time=seconds)
    out.energy = plan.total_energy
    out.duration = plan.duration
    out.peak_control, out.excursion = _peak_and_excursion(plan, system, settings)
    if not plan.ok:
        out.message = plan.message
        last = plan.legs[-1] if plan.legs else None
        out.reason = (
            f"leg {last.index + 1} on {last.stratum}: error {last.error:.2g} > "
            f"tolerance {settings.tolerance:g}"
            if last is not None and not last.converged
            else plan.message.split(";")[0]
        )
    return out


def joint_coordinates(system: System, strata: Sequence[str]) -> tuple[int, ...]:
    """Coordinates that are closed-form integrals of the controls on every given stratum."""
    sets = [set(system.compiled(s).explicit) for s in strata]
    return tuple(sorted(set.intersection(*sets))) if sets else ()


def _peak_and_excursion(plan: SequencePlan, system, settings) -> tuple[float, float]:
    """max |u_k(t)| and the largest range max_t q_j − min_t q_j over the joints, sampled."""
    basis = settings.basis
    joints = joint_coordinates(system, [leg.stratum for leg in plan.legs])
    peak = 0.0
    lo = np.full(len(joints), np.inf)
    hi = np.full(len(joints), -np.inf)
    for leg in plan.legs:
        t = np.linspace(0.0, leg.duration, SAMPLES_PER_LEG)
        u = np.atleast_2d(basis.values(t)) @ leg.coefficients.T  # (samples, m_active)
        peak = max(peak, float(np.abs(u).max(initial=0.0)))
        if joints:
            cs = system.compiled(leg.stratum)
            rows = [cs.explicit.index(j) for j in joints]
            q = leg.start[list(joints)] + (basis.integrals(t) @ leg.coefficients.T) @ (
                cs.C_explicit[rows].T
            )
            lo = np.minimum(lo, q.min(axis=0))
            hi = np.maximum(hi, q.max(axis=0))
    excursion = float((hi - lo).max()) if joints and plan.legs else math.nan
    return peak, excursion


def rank(outcomes: Sequence[Outcome], criterion: str) -> list[int]:
    """Outcome indices, best first.

    Sequences that reached the goal by `criterion`, then total energy, then fewer legs, then
    enumeration order; failed ones after them: more legs planned first, then the smaller
    error of the leg that failed, then enumeration order (rejected before planning: last).
    """

    def ok_key(o: Outcome):
        value = o.value(criterion)
        return (math.inf if math.isnan(value) else value, o.energy, len(o.candidate.legs), o.index)

    def failed_key(o: Outcome):
        if o.plan is None or not o.plan.legs:
            return (1, 0, math.inf, o.index)
        reached = sum(leg.converged for leg in o.plan.legs)
        return (0, -reached, o.plan.legs[-1].error, o.index)

    ok = sorted((o for o in outcomes if o.ok), key=ok_key)
    failed = sorted((o for o in outcomes if not o.ok), key=failed_key)
    return [o.index for o in (*ok, *failed)]


def compile_strata(system: System, names) -> float:
    """Generate the numeric functions of `names` (start-up, not planning); seconds taken."""
    clock = time.perf_counter()
    for name in names:
        system.compiled(name)
    return time.perf_counter() - clock


__all__ = [
    "CRITERIA",
    "Comparison",
    "Outcome",
    "build_trie",
    "compare",
    "compile_strata",
    "default_jobs",
    "joint_coordinates",
    "rank",
]
