"""Auto mode's screen (energy objective and criterion): lower bounds, then branch and bound.

The energy objective plans a sequence with its via configurations fixed: it minimises
Σ_i ∫|u_i|² subject to every leg i reaching its via from the previous one, and to the
boundary conditions of the sequence's continuity mode. Some of those involve one leg alone
(an input not active on the next leg stops at its end under lr-continuity; soft start, full
stop), the others tie neighbouring legs together (an input active on both sides continues).
Dropping the ties leaves independent legs, so the sequence's minimum is at least the sum of
its legs' minima, each leg planned *alone*:

    E*(sequence) ≥ Σ_i e*(leg i),  e*(leg) = min ∫|u|² from its start via to its goal via.

Two such bounds per leg, the larger counts: *loose*, the leg free at both ends (it depends
only on the leg: its stratum, start and goal configurations and duration, so it is shared by
every candidate with that leg; a 708-candidate two-arm task has 88 of them), and *tight*,
under the conditions that involve the leg alone (these depend on its neighbours' strata
too). The tight bound is needed where stopping matters: a two-arm leg that costs 43 free at
its end costs 5,681 when four of its inputs must stop there. At equal total duration
(`compare`) a bound scales like the energy: `bound · duration / T`.

Before any search every leg gets a *floor* (`leg_floors`): a certified lower bound from the
joints it must move and, on a stratum of two inputs, the curvature of the connection it must
turn the base with (milliseconds a leg, no search). On Sim 4 the floors of the four S2 legs
that turn the base far (79-108) already exceed the best sequence's 64.80, so no sequence
with one is ever searched or has that leg searched alone (20 legs searched alone before
floors, 14 with them: the comparison's planning 1.28 -> 0.81 s on 2 processes).

Branch and bound, best first: a candidate's bound counts the legs bounded so far (their
floors for the others, still a lower bound), and candidates are taken in the order of their
current bounds.
The one at the front gets its first leg without a loose bound bounded, else its first leg
without a tight bound, else it is fully searched (`plan_sequence`, the energy objective as
configured, the same search as the exhaustive comparison's). It stops when the front's bound
is not below the best value found (after at least `top` searches). Every candidate not
searched is *bounded*: its minimum is at least its bound, which is at least the best's value,
so it cannot win. Its row reports the bound, not an energy (status "bounded", `screened`).
Legs are bounded only when some candidate near the front needs them (on the two-arm tasks of
benchmarks/bench_screen.py 42-59 bounds of 88 loose and 510 tight ones).

Work goes in rounds, each run in parallel (one pool of forked workers for the whole screen):
up to `SEARCH_BATCH` searches (the very first alone) and up to `LEG_BATCH` legs of the
candidates behind them, from candidates within `ROUND_SPAN` of the front's bound (or any, to
keep two processes busy); a candidate is searched only when no candidate before it in the
round has a leg still to bound. Rounds depend only on what earlier rounds found, never on the
number of processes, so neither does the outcome. A worker that would wait idle for a
round's slowest leg (a hard leg's Newton plan can take seconds) bounds a leg the next rounds
are likely to ask for; the round that asks for it takes the result.

The bound is exact for exact leg minima; the leg searches are the same multi-start local
search as the sequence's, so a leg's search may miss its global minimum. Safeguard: whenever a
searched sequence's leg costs less than that leg's bound, the bound is lowered to it (and every
candidate's bound recomputed) before the next candidate is pruned; `Screen.corrections`
counts them (never below a leg's floor, which holds for every plan of it). Legs that cannot
be bounded (a start left to the planner, a Lie-algebraic leg, a leg whose tight search
failed) contribute their floor (0 where none is known: a URDF robot). A leg with no plan
even alone and free at both ends (Newton with its restarts and continuation found none)
fails every candidate that has it, unsearched and named in its reason: each such sequence's
own search would start with the same leg under more conditions, and took seconds to fail (a
two-arm comparison: 79 s, now 8 s, the same choice). `--exhaustive` still searches them.
When no two candidates share a leg the bounds cannot be shared and the comparison searches
every candidate instead; without floors (URDF robots) the legs must be shared twice over
(`legs_shared`).
"""

from __future__ import annotations

import heapq
import math
import multiprocessing
import os
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .frozen_json import FrozenDict
from .interrupts import checkpoint
from .leg_bounds import leg_items, plan_alone
from .leg_floors import floors_known, leg_floor
from .trie import STATE, plan_whole, run_units, stop_workers, submit, worker_init
from .values import MadeAgainOnUnpickling

__all__ = ["Screen", "legs_shared", "screen_candidates"]

LEG_BATCH = 8  # legs bounded per round, at most (beside the round's searches)
SEARCH_BATCH = 2  # candidates searched per round, at most (the same for any number of jobs)
ROUND_SPAN = 1.25  # a round takes candidates whose bound is within this factor of the front's
ROUND_FILL = 2  # ... or, while it has fewer legs than this, any (two processes kept busy)


@dataclass(frozen=True)
class Screen(MadeAgainOnUnpickling):
    """What the screen did: every candidate's bound, which were searched, the corrections."""

    bounds: dict[int, float]  # candidate -> lower bound on its energy (at its own duration)
    searched: tuple[int, ...]  # fully searched, in the order they were started
    legs: int  # distinct legs bounded (each one energy search)
    corrections: int  # leg bounds lowered by a searched sequence's own leg energy
    seconds: float  # CPU time spent on the leg bounds (all processes)
    sunk: tuple[int, ...] = ()  # failed unsearched: a leg with no plan even alone (`_sunk`)
    floored: int = 0  # distinct legs with a positive floor (`leg_floors`), searched or not
    # candidate -> per leg (its floor, its bound: the larger of the floor and the leg's
    # searched minima, loose and tight), at the leg's own duration
    leg_bounds: dict[int, tuple[tuple[float, float], ...]] = field(default_factory=dict)

    def __post_init__(self) -> None:  # a frozen value: its tables read-only (`FrozenDict`)
        object.__setattr__(self, "bounds", FrozenDict(self.bounds))
        object.__setattr__(self, "leg_bounds", FrozenDict(self.leg_bounds))


def _unit(item: tuple[str, list]) -> dict:
    """One unit of a round: ("leg", legs to bound) or ("search", sequences to plan)."""
    kind, work = item
    return plan_alone(work) if kind == "leg" else plan_whole(work)


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
        initializer=worker_init,
        initargs=(os.getpid(),),
    )


def _round(items, jobs: int, pool, flight: dict, ahead: Callable) -> list[dict]:
    """Run one round's units ((name, unit) pairs) in `pool`, else with `trie.run_units` (here or on
    STATE["executor"]). With a pool, a worker that would wait idle for the round's slowest
    unit takes a unit `ahead()` says later rounds are likely to ask for; `flight` (name ->
    future, kept across rounds) hands its result to the round that asks for it. What a round
    computes does not depend on it, only how soon it is known."""
    if pool is None:
        return run_units(_unit, [(unit, 0) for _, unit in items], jobs, lambda k: None)
    for name, unit in items:
        if name not in flight:
            flight[name] = submit(pool, _unit, unit)
    wanted = [flight[name] for name, _ in items]
    while not all(f.done() for f in wanted):
        running = [f for f in flight.values() if not f.done()]
        later = ahead()  # (name, unit) pairs, most likely first
        while len(running) < jobs:  # a worker is free: start something likely needed next
            name, unit = next(later, (None, None))
            if name is None:
                break
            if name not in flight:
                flight[name] = submit(pool, _unit, unit)
                running.append(flight[name])
        wait(running, return_when=FIRST_COMPLETED)
        checkpoint()
    return [f.result() for f in wanted]


def _floors(system, legs: dict) -> dict[tuple, float]:
    """Each loose key's floor (`leg_floors.leg_floor`, for plans within the planner's
    tolerance of the goal; 0 for a leg that is not searched, or whose floor fails: a floor
    only saves searches, it never stops a comparison)."""
    settings = STATE.get("settings")
    slack = settings.tolerance if settings is not None else 0.0
    out: dict[tuple, float] = {}
    peaks: dict = {}  # shared by legs on the same stratum with the same joints at rest
    for key, item in legs.items():
        if len(key) == 5:
            stratum, _, duration, at, goal = key
            at, goal = np.frombuffer(at), np.frombuffer(goal)
            out[key] = 0.0
            if item is not None:
                try:
                    out[key] = leg_floor(system, stratum, at, goal, duration, peaks, slack)
                except Exception:  # any model's failure: no floor (0, as before floors)
                    pass
    return out


def _sunk(candidate, pairs: list[tuple], loose: tuple, why: str = "") -> str:
    """Why a candidate fails unsearched: one of its legs has no plan even alone, free at both
    ends (Newton with its restarts and continuation, the search the sequence would start
    with, under fewer conditions), and why when known (a direction its stratum cannot move)."""
    i = next(i for i, (a, _) in enumerate(pairs) if a == loose)
    leg = candidate.legs[i]
    because = f" ({why})" if why else ""
    return (
        f"leg {i + 1} on {leg.stratum} has no plan even alone, free at both ends{because}: not "
        "searched (--exhaustive searches it)"
    )


def legs_shared(system, candidates, valid, start) -> bool:
    """Whether bounding the `valid` candidates' legs alone can cost less than searching them:
    whether two share a leg (the same stratum, vias and duration). Without any, every bound
    serves one candidate: bounding a candidate's legs alone, free and under their own
    conditions, costs about as much as searching it, and the comparison searches them all
    instead (the exhaustive search: its choice, never a worse one; arm3_auto's two
    candidates with the energy objective: 10.8 s screened, 4 s searched). Where the legs
    have no floors (URDF robots: `leg_floors` knows none), a candidate is pruned only once
    each of its legs is bounded by a search, so the legs must be shared twice over (as many
    distinct legs as half the candidates' legs, or fewer): arm3 with all three strata, up to
    2 legs, shares 9 distinct legs among 12 (screened 12.9 s CPU, searched 9.5 s), up to 3
    legs 12 among 48 (17.1 s, 62.0 s)."""
    _, keys = leg_items(system, candidates, valid, start)
    slots = [loose for k in valid for loose in {loose for loose, _ in keys[k]}]
    distinct = len(set(slots))
    if _floorless(system, candidates, valid):
        return 2 * distinct <= len(slots)
    return distinct < len(slots)


def _floorless(system, candidates, valid) -> bool:
    """Whether no leg of the candidates can have a floor (`leg_floors.floors_known`)."""
    strata = {leg.stratum for k in valid for leg in candidates[k].legs}
    return not any(floors_known(system, stratum) for stratum in strata)


def screen_candidates(system, settings, start, candidates, valid, jobs, advance, top, reference):
    """Branch and bound over `valid` (see the module's docstring).

    Returns (planned, requested, plans, times, screen): the legs planned and requested, the
    plans and planning times of the searched candidates only, and the `Screen`."""
    pool = _pool(jobs)
    try:
        return _branch_and_bound(
            system, candidates, valid, jobs, advance, top, reference, start, pool
        )
    finally:  # done, interrupted or a worker's error: nothing is waited for
        if pool is not None:
            stop_workers(pool, [])


def _branch_and_bound(system, candidates, valid, jobs, advance, top, reference, start, pool):
    legs, keys = leg_items(system, candidates, valid, start)
    known = {key: 0.0 for key, item in legs.items() if item is None}  # no search needed
    floors = _floors(system, legs)  # certified, before any search (`leg_floors`)
    warm: dict[tuple, Any] = {}  # each bounded leg's minimising coefficients
    uses: dict[tuple, list[int]] = {}
    for k in valid:
        for key in {key for pair in keys[k] for key in pair}:
            uses.setdefault(key, []).append(k)

    def scale(k: int) -> float:  # energy -> energy at the comparison's total duration
        duration = sum(leg.duration for leg in candidates[k].legs)
        return duration / reference if math.isfinite(reference) and reference > 0 else 1.0

    def leg_bound(loose: tuple, tight: tuple) -> float:  # a leg not searched: its floor
        return max(floors[loose], known.get(loose, 0.0), known.get(tight, 0.0))

    def bound(k: int) -> float:  # on the energy at equal duration
        return sum(leg_bound(a, b) for a, b in keys[k]) * scale(k)

    def unbounded(k: int) -> list[tuple]:  # loose bounds first, then the tight ones
        loose = [a for a, _ in keys[k] if a not in known]
        return loose or [b for _, b in keys[k] if b not in known]

    plans: dict[int, Any] = {}
    times: dict[int, float] = {}
    planned = requested = corrections = 0
    sunk: list[int] = []
    searched: list[int] = []
    bounded_legs: list[tuple] = []
    seconds = 0.0
    best = math.inf
    heap = [(bound(k), k) for k in valid]
    heapq.heapify(heap)
    done: set[int] = set()
    flight: dict[tuple, Any] = {}  # units started in the pool, by name

    def leg_unit(key: tuple) -> tuple:  # a tight bound starts from the loose minimum too
        return ("leg", [(key, *legs[key], warm.get(key[:5]))])

    def ahead():  # legs the next rounds are likely to ask for: the front's, in order
        for _, k in sorted(heap):
            unknown = [] if k in done else unbounded(k)
            key = unknown[0] if unknown else None
            if key is not None and (len(key) == 5 or key[:5] in warm):  # tight: loose first
                yield ("leg", key), leg_unit(key)

    while True:
        new_legs: list[tuple] = []
        searches: list[int] = []
        held: list[int] = []
        while heap:  # the round: candidates in the order of their current bounds
            b, k = heap[0]
            if k in done:
                heapq.heappop(heap)
                continue
            if bound(k) > b:  # raised by legs bounded since: back in its place
                heapq.heapreplace(heap, (bound(k), k))
                continue
            if len(searched) + len(searches) >= max(1, top) and b >= best:
                break  # this one and every one after it cannot beat the best
            if len(new_legs) >= ROUND_FILL and b > ROUND_SPAN * bound(held[0]):
                break  # far behind the front: likely never needed
            unknown = unbounded(k)
            if not unknown:
                if new_legs or len(searches) >= min(SEARCH_BATCH, 1 + len(searched)):
                    break  # bound the legs before it first; the very first search alone
                searches.append(k)
            else:  # its first leg not bounded yet (prefixes are the most shared)
                if len(new_legs) >= LEG_BATCH:
                    break
                if unknown[0] not in new_legs:
                    new_legs.append(unknown[0])
            held.append(heapq.heappop(heap)[1])
        if not new_legs and not searches:
            break
        items = [(("search", k), ("search", [(k, list(candidates[k].legs))])) for k in searches]
        items += [(("leg", key), leg_unit(key)) for key in new_legs]
        results = _round(items, jobs, pool, flight, ahead)
        for part in results[len(searches) :]:
            for key, (value, elapsed, coefficients, why) in part.items():
                known[key] = value
                warm[key] = coefficients
                bounded_legs.append(key)
                seconds += elapsed
                if coefficients is None and len(key) == 5:  # no plan even free at both ends
                    for k in uses[key]:
                        if k not in done:
                            reason = _sunk(candidates[k], keys[k], key, why)
                            plans[k], times[k] = reason, 0.0
                            done.add(k)
                            sunk.append(k)
                            advance(1)
        for k, part in zip(searches, results, strict=False):
            plan, elapsed, error = part[k]
            searched.append(k)
            done.add(k)
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
            for pair, leg in zip(keys[k], plan.legs, strict=True):
                for key in pair:
                    if len(key) == 5 and leg.energy < floors[key] * (1 - 1e-9):
                        floors[key] = float(leg.energy)  # a floor above a plan: never (tested)
                        corrections += 1
                    if leg.energy < known[key] * (1 - 1e-9):  # the leg's search missed this
                        known[key] = float(leg.energy)
                        corrections += 1
                        for j in uses[key]:  # lowered: to the front again
                            if j not in done:
                                heapq.heappush(heap, (bound(j), j))
        for k in held:
            if k not in done:
                heapq.heappush(heap, (bound(k), k))
    advance(len(valid) - len(searched) - len(sunk))
    bounds = {k: bound(k) / scale(k) for k in valid}
    floored = sum(value > 0 for value in floors.values())
    per_leg = {k: tuple((floors[a], leg_bound(a, b)) for a, b in keys[k]) for k in valid}
    screen = Screen(
        bounds, tuple(searched), len(bounded_legs), corrections, seconds, tuple(sunk), floored,
        per_leg,
    )  # fmt: skip
    return planned, requested, plans, times, screen
