"""The legs' minima that bound a sequence's energy in auto mode's screen (`stratcli.screen`):
each distinct leg planned alone, free at both ends (*loose*) or under the boundary conditions
that involve it alone (*tight*), by the energy objective's multi-start search.

The screen's module docstring says why their sum bounds a sequence's minimum and how the
branch and bound uses them; this module computes them (in the screen's worker processes:
`plan_alone` reads the model and settings from `trie.STATE`).
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np

from .continuity import Constraints, sequence_constraints
from .objectives import _exact_hessians
from .planners.energy import optimise_energy
from .planners.sqp import PG_TOL
from .stratified import (
    NUMERICAL_ERRORS,
    LegStart,
    _targets,
    plan_next_leg,
    planner_for,
    seeded,
)
from .trie import STATE

__all__ = ["leg_items", "leg_minimum", "plan_alone"]

START_RATIO = 100.0  # a leg's start this many times above its lowest start is not raced
# Newton plans per leg bound, at least: a bound must not miss the leg's minimum, and the
# sequence search's own default (2: the Newton plan pulled toward least energy, and itself)
# starts from a whole sequence's plan, which a leg alone does not have
BOUND_STARTS = 6
# Without exact Hessians (URDF legs) a bound's search stops at this relative projected
# gradient instead of `sqp.PG_TOL`: the energy is then within ~1e-12 of the minimum's (it
# falls as the square of the gradient), and the last iterations, the costliest (on the full
# Magnus steps, restored to rounding), are saved
BOUND_PG_TOL = 1e-6


def _context(system, legs, i: int) -> tuple:
    """What of leg i's neighbours enters its own boundary conditions: the inputs it must
    start from rest (not active on the previous leg; "first": the sequence's start) and end
    at rest (not active on the next one; "last": the sequence's end)."""
    active = system.stratum(legs[i].stratum).active
    if i == 0:
        begin: tuple = ("first",)
    else:
        before = system.stratum(legs[i - 1].stratum).active
        begin = tuple(k for k in active if k not in before)
    if i + 1 == len(legs):
        end: tuple = ("last",)
    else:
        after = system.stratum(legs[i + 1].stratum).active
        end = tuple(k for k in active if k not in after)
    return begin, end


def _relaxed(settings):
    """The leg alone, free at both ends: no continuity with its neighbours, no soft start, no
    full stop."""
    return replace(settings, continuity="none", soft_start=False, full_stop=False)


def leg_items(system, candidates, valid, start):
    """Distinct legs, two keys each: (loose, tight) -> (start, legs, i, relaxed) or None when
    it gets no bound (leg i among `legs`, itself and its neighbours; relaxed: free at both
    ends, else under its own boundary conditions), and each candidate's pairs of keys."""
    legs: dict[tuple, Any] = {}
    keys: dict[int, list[tuple]] = {}
    for k in valid:
        at = np.asarray(start, dtype=float)
        path = []
        sequence = candidates[k].legs
        for i, leg in enumerate(sequence):
            goal = np.asarray(leg.goal, dtype=float)
            loose = (leg.stratum, leg.method, float(leg.duration), at.tobytes(), goal.tobytes())
            tight = (*loose, _context(system, sequence, i))
            if tight not in legs:
                unknown = bool(np.isnan(at).any())  # a start left to the planner
                loop = not np.isnan(goal).any() and np.array_equal(goal, at)  # u = 0 reaches it
                skip = unknown or loop or leg.method != "newton"
                around = tuple(sequence[max(0, i - 1) : i + 2])
                legs[tight] = None if skip else (at, around, i, False)
                legs.setdefault(loose, None if skip else (at, (leg,), 0, True))
            path.append((loose, tight))
            at = np.where(np.isnan(goal), np.nan, goal)
        keys[k] = path
    return legs, keys


def _local_constraints(system, settings, around, mid: int) -> Constraints:
    """The boundary conditions of `around[mid]` that involve it alone (`around`: it and its
    neighbours): those of the whole sequence minus the ones that tie it to a neighbour."""
    actives = [system.stratum(leg.stratum).active for leg in around]
    cons = sequence_constraints(
        settings.basis,
        [leg.duration for leg in around],
        actives,
        system.inputs,
        settings.continuity,
        soft_start=settings.soft_start,
        full_stop=settings.full_stop,
    )
    size = settings.basis.size
    offsets = np.cumsum([0, *(len(a) * size for a in actives)])
    inside = np.zeros(cons.C.shape[1], dtype=bool)
    inside[offsets[mid] : offsets[mid + 1]] = True
    own = [r for r in range(len(cons.C)) if cons.C[r].any() and not cons.C[r, ~inside].any()]
    C = cons.C[own][:, inside].reshape(len(own), int(inside.sum()))
    return Constraints(C, cons.c[own], tuple(cons.labels[r] for r in own))


def leg_minimum(system, at: np.ndarray, around, i: int, settings, warm=None) -> tuple:
    """The least energy found for leg i of a sequence planned alone, under the boundary
    conditions that involve it alone (`_local_constraints`; `around`: it and its neighbours):
    (energy, its coefficients, ""), or (0.0, None, why) when no start reaches its goal (why:
    the Newton plan's message, e.g. a direction its stratum cannot move). `warm`
    (flat coefficients, e.g. the leg's minimum free at both ends) is an extra first start,
    projected onto the conditions.

    The energy objective's multi-start search (`objectives.plan_with_objective`: a Newton plan
    and `max(starts, BOUND_STARTS) - 1` seeded Newton plans, raced by the feasible SQP), with
    Newton plans that start at rest after a previous leg (feasible: they satisfy more
    conditions than needed),
    except that starts `START_RATIO` times above the lowest are not raced (their iterations
    are the costliest: the quadrature's nodes grow with the controls). With a `warm` start
    (a tight bound: the loose one is known) no Newton plan falls back on continuation (seconds
    on a hard leg; the warm start is a start already), and without any feasible start the
    leg gets no tight bound (its loose one stands). Where the search ends with no feasible
    result at all (every start not restored onto the goals) the bound is 0, not the Newton
    plan's energy: that is where the search started, above the minimum it was heading for (an
    arm3 S1 leg: 7.82, the minimum 6.36), so no lower bound. Its coefficients are still
    returned: the leg has a plan (a warm start for its tight bound), unlike a leg whose
    Newton plan failed."""
    mid = 1 if i > 0 else 0
    leg = around[mid]
    after = around[mid + 1] if mid + 1 < len(around) else None
    rest = (np.zeros(system.m), np.zeros(system.m))
    begin = LegStart(at, rest, 0.0, 1) if i > 0 else LegStart(at)
    seeds = []
    starts = max(settings.starts, BOUND_STARTS)
    exact = _exact_hessians(system, [leg], settings)
    for k in range(starts):  # URDF legs too: one start bounded by poor local minima
        extra = {} if k == 0 else seeded(settings, k)
        if warm is not None:
            extra["continuation"] = False
        planned = plan_next_leg(
            system, settings, leg, begin, after, planner_for(leg, settings, **extra)
        )
        if planned.converged:
            seeds.append(planned)
        elif k == 0 and warm is None:  # as the sequence's search: no Newton plan, no search
            return 0.0, None, planned.message
    if not seeds and warm is None:
        return 0.0, None, ""
    low = min((p.energy for p in seeds), default=np.inf)
    stacked = [("newton", p.coefficients.ravel()) for p in seeds if p.energy <= START_RATIO * low]
    if warm is not None:
        stacked.insert(0, ("warm start", np.ravel(warm)))
    targets = [np.array(_targets(system, leg), dtype=int)]
    local = _local_constraints(system, settings, around, mid)
    with np.errstate(all="ignore"):
        coefficients, search = optimise_energy(
            system, [at], [leg], settings, targets, stacked, constraints=local,
            pg_tol=PG_TOL if exact else BOUND_PG_TOL,
        )  # fmt: skip
    found = [s.energy for s in search.starts if s.feasible and np.isfinite(s.energy)]
    if coefficients is not None and found and min(found) <= low:
        return float(min(found)), coefficients[0], ""
    if not seeds:
        return 0.0, None, ""
    best = min(seeds, key=lambda p: p.energy)
    if not found:  # no search result: no bound but 0 (the screen takes the leg's floor)
        return 0.0, best.coefficients, ""
    return float(low), best.coefficients, ""


def plan_alone(items: list[tuple]) -> dict[tuple, tuple]:
    """Each leg's minimum energy planned alone (0.0 when its search fails), the CPU seconds,
    the coefficients (None when it has no plan: its Newton plan failed) and why it failed
    ("" when unknown)."""
    system, settings = STATE["system"], STATE["settings"]
    out = {}
    for key, at, around, i, relaxed, warm in items:
        clock = time.process_time()
        own = _relaxed(settings) if relaxed else settings
        try:
            value, coefficients, why = leg_minimum(system, at, around, i, own, warm)
        except (*NUMERICAL_ERRORS, ValueError):  # no bound from this leg
            value, coefficients, why = 0.0, None, ""
        out[key] = (value, time.process_time() - clock, coefficients, why)
    return out
