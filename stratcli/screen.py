"""Auto mode's screen (energy objective and criterion): lower bounds, then branch and bound.

The energy objective plans a sequence with its via configurations fixed: it minimises
Σ_i ∫|u_i|² subject to every leg i reaching its via from the previous one, and to the
continuity conditions that couple neighbouring legs. Dropping the coupling (continuity
"none", no soft start, no full stop) leaves independent legs, so the sequence's minimum is at
least the sum of its legs' minima, each leg planned *alone*:

    E*(sequence) ≥ Σ_i e*(leg i),  e*(leg) = min ∫|u|² from its start via to its goal via.

The candidates of a decomposition share most of their legs (a leg is its stratum, its start
and goal configurations and its duration: a 708-candidate two-arm task has about 110
distinct legs), so the bounds cost one small energy search per distinct leg, shared by all
candidates. At equal total duration (`compare`) the bound scales like the energy:
`bound · duration / T`.

Branch and bound: candidates are fully searched (`plan_sequence`, the energy objective as
configured, the same search as the exhaustive comparison's) in the order of their bounds,
each unless its bound is not below the best value found before it (the first `top` always).
Every candidate not searched is *bounded*: its minimum is at least its bound, which is at least
the best's value, so it cannot win. Its row reports the bound, not an energy (status
"bounded", `screened`). Worker processes search ahead of that order (speculatively), and a
result is used only where the serial algorithm would search: what is searched, and so the
whole outcome, does not depend on the number of processes.

The bound is exact for exact leg minima; the leg searches are the same multi-start local
search as the sequence's, so a leg's search may miss its global minimum. Safeguard: whenever a
searched sequence's leg costs less than that leg's bound, the bound is lowered to it (and every
candidate's bound recomputed) before the next candidate is pruned; `Screen.corrections`
counts them. Legs that cannot be bounded (a start left to the planner, a Lie-algebraic leg, a
leg whose search failed) contribute 0.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .interrupts import checkpoint
from .objectives import SEED_RESTARTS, _exact_hessians
from .planners.energy import optimise_energy
from .stratified import NUMERICAL_ERRORS, LegSpec, chain_legs
from .trie import STATE, _plan_whole, _run, _stop, _worker_init

__all__ = ["Screen", "leg_bounds", "leg_minimum", "screen_candidates"]

START_RATIO = 100.0  # a leg's start this many times above its lowest start is not raced


@dataclass(frozen=True)
class Screen:
    """What the screen did: every candidate's bound, which were searched, the corrections."""

    bounds: dict[int, float]  # candidate -> lower bound on its energy (at its own duration)
    searched: tuple[int, ...]  # fully searched, in the order they were started
    legs: int  # distinct legs bounded (each one energy search)
    corrections: int  # leg bounds lowered by a searched sequence's own leg energy
    seconds: float  # time spent on the leg bounds


def _relaxed(settings):
    """The leg alone: no continuity with neighbours, free at both ends."""
    return replace(settings, continuity="none", soft_start=False, full_stop=False)


def _leg_items(candidates, valid, start) -> tuple[dict[tuple, Any], dict[int, list[tuple]]]:
    """Distinct legs (key -> (start, leg) or None when it gets no bound) and each candidate's
    leg keys."""
    legs: dict[tuple, Any] = {}
    keys: dict[int, list[tuple]] = {}
    for k in valid:
        at = np.asarray(start, dtype=float)
        path = []
        for leg in candidates[k].legs:
            goal = np.asarray(leg.goal, dtype=float)
            key = (leg.stratum, leg.method, float(leg.duration), at.tobytes(), goal.tobytes())
            if key not in legs:
                unknown = bool(np.isnan(at).any())  # a start left to the planner
                loop = not np.isnan(goal).any() and np.array_equal(goal, at)  # u = 0 reaches it
                legs[key] = None if unknown or loop or leg.method != "newton" else (at, leg)
            path.append(key)
            at = np.where(np.isnan(goal), np.nan, goal)
        keys[k] = path
    return legs, keys


def leg_minimum(system, at: np.ndarray, leg: LegSpec, settings) -> float:
    """The least energy found for one leg planned alone (`settings` as given: pass them
    relaxed for a bound); 0.0 when no start reaches its goal.

    The energy objective's multi-start search (`objectives.plan_with_objective`: the Newton
    plan and `starts - 1` seeded Newton plans, raced by the feasible SQP), except that starts
    `START_RATIO` times above the lowest are not raced (their iterations are the costliest:
    the quadrature's nodes grow with the controls) and nothing is re-chained at the end."""
    legs = [leg]
    newton = chain_legs(system, at, legs, settings)
    if not newton.ok:
        return 0.0
    seeds = [newton]
    for k in range(1, settings.starts if _exact_hessians(system, legs, settings) else 1):
        other = chain_legs(
            system, at, legs, settings,
            restarts=min(settings.restarts, SEED_RESTARTS),
            seed=settings.seed + 7919 * k,
            spread=0.02 + 0.3 * k,
        )  # fmt: skip
        if other.ok:
            seeds.append(other)
    low = min(p.total_energy for p in seeds)
    stacked = [
        ("newton", p.legs[0].coefficients.ravel())
        for p in seeds
        if p.total_energy <= START_RATIO * low
    ]
    targets = [np.array(newton.legs[0].targets, dtype=int)]
    with np.errstate(all="ignore"):
        _, search = optimise_energy(system, [at], legs, settings, targets, stacked)
    found = [s.energy for s in search.starts if s.converged and np.isfinite(s.energy)]
    return float(min([low, *found]))


def _plan_alone(items: list[tuple[tuple, np.ndarray, LegSpec]]) -> dict[tuple, float]:
    """Each leg's minimum energy planned alone (0.0 when its search fails)."""
    system, settings = STATE["system"], _relaxed(STATE["settings"])
    out = {}
    for key, at, leg in items:
        try:
            out[key] = leg_minimum(system, at, leg, settings)
        except (*NUMERICAL_ERRORS, ValueError):  # no bound from this leg
            out[key] = 0.0
    return out


def _pool(jobs: int):
    """One pool of forked workers for the whole screen (None: plan in this process or on
    `STATE["executor"]`, one candidate at a time)."""
    if jobs <= 1 or STATE.get("executor") is not None:
        return None
    if "fork" not in multiprocessing.get_all_start_methods():  # pragma: no cover
        return None
    return ProcessPoolExecutor(
        max_workers=jobs,
        mp_context=multiprocessing.get_context("fork"),
        initializer=_worker_init,
        initargs=(os.getpid(),),
    )


def leg_bounds(legs: dict[tuple, Any], jobs: int, pool=None) -> dict[tuple, float]:
    """Every distinct leg's bound, planned in `pool` or `jobs` processes (`trie._run`)."""
    todo = [(key, *item) for key, item in legs.items() if item is not None]
    chunks = max(1, min(len(todo), 4 * jobs))  # several units per process: balanced load
    units = [todo[c::chunks] for c in range(chunks)] if todo else []
    found: dict[tuple, float] = {key: 0.0 for key in legs}
    if pool is None:
        parts = _run(_plan_alone, [(u, 0) for u in units], jobs, lambda k: None)
    else:
        futures = [pool.submit(_plan_alone, u) for u in units]
        parts = []
        for future in futures:
            parts.append(future.result())
            checkpoint()
    for part in parts:
        found.update(part)
    return found


def screen_candidates(system, settings, start, candidates, valid, jobs, advance, top, reference):
    """Branch and bound over `valid` (see the module's docstring).

    Returns (planned, requested, plans, times, screen): the legs planned and requested, the
    plans and planning times of the searched candidates only, and the `Screen`.

    The outcome is that of the serial algorithm (candidates in the order of their bounds, each
    searched unless its bound, lowered by the corrections so far, is not below the best value
    so far): with a pool, candidates are searched ahead of that order, speculatively, and a
    result is used only when the serial algorithm reaches its candidate and would search it.
    So the outcome does not depend on the number of processes."""
    pool = _pool(jobs)
    futures: dict[int, Any] = {}
    try:
        return _branch_and_bound(
            system, candidates, valid, jobs, advance, top, reference, start, pool, futures
        )
    finally:  # done, interrupted or a worker's error: speculative searches are not waited for
        if pool is not None:
            _stop(pool, futures.values())


def _branch_and_bound(system, candidates, valid, jobs, advance, top, reference, start, pool,
                      futures):  # fmt: skip
    clock = time.perf_counter()
    legs, keys = _leg_items(candidates, valid, start)
    leg_bound = leg_bounds(legs, jobs, pool)
    seconds = time.perf_counter() - clock

    def scale(k: int) -> float:  # energy -> energy at the comparison's total duration
        duration = sum(leg.duration for leg in candidates[k].legs)
        return duration / reference if math.isfinite(reference) and reference > 0 else 1.0

    def bound(k: int) -> float:  # on the energy at the comparison's total duration
        return sum(leg_bound[key] for key in keys[k]) * scale(k)

    order = sorted(valid, key=lambda k: (bound(k), k))
    plans: dict[int, Any] = {}
    times: dict[int, float] = {}
    planned = requested = corrections = 0
    searched: list[int] = []
    best = math.inf

    def submit(k: int) -> None:
        futures[k] = pool.submit(_plan_whole, [(k, list(candidates[k].legs))])

    def running() -> int:
        return sum(not f.done() for f in futures.values())

    for i, k in enumerate(order):
        if len(searched) >= max(1, top) and bound(k) >= best:
            advance(1)  # pruned
            continue
        if pool is None:  # here, or on STATE["executor"]
            unit = [(k, list(candidates[k].legs))]
            result = _run(_plan_whole, [(unit, 1)], jobs, lambda n: None)[0][k]
        else:
            for j in order[i:]:  # ahead of the serial order, as far as the workers allow
                if running() >= jobs:
                    break
                if j not in futures and (j == k or bound(j) < best):
                    submit(j)
            result = futures[k].result()[k]
            checkpoint()
        plan, elapsed, error = result
        searched.append(k)
        times[k] = elapsed
        advance(1)
        if plan is None:
            plans[k] = error
            continue
        plans[k] = plan = plan.with_system(system)
        requested += len(plan.legs)
        planned += len(plan.legs)
        if not plan.ok:
            continue
        best = min(best, plan.total_energy * scale(k))
        for key, leg in zip(keys[k], plan.legs, strict=True):
            if leg.energy < leg_bound[key] * (1 - 1e-9):  # the leg's search missed this
                leg_bound[key] = float(leg.energy)
                corrections += 1
    bounds = {k: bound(k) / scale(k) for k in valid}
    screen = Screen(bounds, tuple(searched), sum(v is not None for v in legs.values()),
                    corrections, seconds)  # fmt: skip
    return planned, requested, plans, times, screen
