"""Plan every candidate sequence of a decomposition and rank them (DESIGN §5.5).

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
import re
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from .decomposition import Candidate
from .errors import InputError
from .metrics import as_run, peak_and_excursion
from .models.system import System
from .screen import Screen, legs_shared, screen_candidates
from .sequence import SequencePlan
from .settings import PlannerSettings
from .stratified import check_legs
from .trie import STATE, compare_shared, compare_whole

CRITERIA = ("energy", "peak-control", "excursion", "duration")
CRITERION_LABELS = {
    "energy": "total energy",
    "peak-control": "peak |u|",
    "excursion": "largest joint excursion",
    "duration": "total duration",
}
SCREEN_TOP = 1  # candidates fully searched (lowest bounds) before any is pruned
TIE = 1e-9  # relative: values that differ by less are a tie but for rounding (`_tie`)


@dataclass(frozen=True)
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
    screened: bool = False  # not searched: bounded by the screen (its energy is not known)
    reference_duration: float = math.nan  # the comparison's equal total duration T
    energy_bound: float = math.nan  # the screen's lower bound on `energy` (own duration)
    leg_bounds: tuple[tuple[float, float], ...] = ()  # per leg (floor, bound): the screen's

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def __eq__(self, other: object) -> bool:  # a value: NaN (not known) equals NaN
        if not isinstance(other, Outcome):
            return NotImplemented
        return all(_same(getattr(self, f.name), getattr(other, f.name)) for f in fields(self))

    def __hash__(self) -> int:  # of what equal outcomes share (NaN hashes by identity)
        return hash((self.index, self.candidate, self.status, self.rank))

    def __repr__(self) -> str:  # the dataclass's prints the candidate's legs and the plan
        energy = f"energy {self.energy:.6g}" if self.ok else self.reason or self.status
        return (
            f"Outcome({self.candidate.label} {self.candidate.strategy}: rank {self.rank}, "
            f"{self.status}, {energy})"
        )

    @property
    def energy_equal_time(self) -> float:
        """The energy of this path run in the comparison's total duration T (E·duration/T)."""
        if not math.isfinite(self.reference_duration) or not self.duration > 0:
            return self.energy
        return self.energy * self.duration / self.reference_duration

    @property
    def energy_bound_equal_time(self) -> float:
        """The screen's lower bound on `energy_equal_time`."""
        if not math.isfinite(self.reference_duration) or not self.duration > 0:
            return self.energy_bound
        return self.energy_bound * self.duration / self.reference_duration

    def value(self, criterion: str) -> float:
        return {
            "energy": self.energy_equal_time,
            "peak-control": self.peak_control,
            "excursion": self.excursion,
            "duration": self.duration,
        }[criterion]


@dataclass(frozen=True)
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
    reference_duration: float = math.nan  # total duration the energies are compared at
    screen: Screen | None = None  # the screen's bounds and what it searched (None: exhaustive)
    on: str = ""  # where it ran, when not on `jobs` local processes: "a Dask cluster"

    @property
    def equal_durations(self) -> bool:
        """Whether every candidate has the reference duration (energies compare as they are)."""
        durations = [o.duration for o in self.outcomes if math.isfinite(o.duration)]
        return all(math.isclose(d, self.reference_duration) for d in durations)

    @property
    def best(self) -> Outcome | None:
        return self.outcomes[self.ranking[0]] if self.ranking else None

    @property
    def legs_saved(self) -> int:
        return self.legs_requested - self.legs_planned

    def __eq__(self, other: object) -> bool:  # a value: no reference duration (NaN) alike
        if not isinstance(other, Comparison):
            return NotImplemented
        return all(_same(getattr(self, f.name), getattr(other, f.name)) for f in fields(self))

    __hash__ = None  # its outcomes are a list

    def __repr__(self) -> str:  # the dataclass's prints every outcome and its plan (16 kB)
        return f"Comparison({len(self.outcomes)} sequences by {self.criterion}: {self.choice()})"

    def choice(self) -> str:
        """Which sequence is best and why, in one sentence."""
        best = self.best
        if best is None:
            return "no candidate sequences"
        ok = [self.outcomes[i] for i in self.ranking if self.outcomes[i].ok]
        label = CRITERION_LABELS[self.criterion]
        if self.criterion == "energy" and not self.equal_durations:
            label += f" at an equal total duration of {self.reference_duration:g} s"
        if not best.ok:
            if _outside_only(best) is not None:  # it reached every goal: a limit failed it
                return (
                    "no sequence stayed within the limits; the nearest was "
                    f"{best.candidate.label} {best.candidate.strategy} ({best.reason})"
                )
            return (
                "no sequence reached the goal; the one that got furthest was "
                f"{best.candidate.label} {best.candidate.strategy} ({best.reason})"
            )
        bounded = sum(o.status == "bounded" for o in self.outcomes)
        among = "searched that reached the goal" if bounded else "that reached the goal"
        text = (
            f"{best.candidate.label} {best.candidate.strategy}: lowest {label} "
            f"({_show(best.value(self.criterion), self.criterion)}) of {len(ok)} "
            f"sequence{'s' if len(ok) != 1 else ''} {among}"
        )
        if len(ok) > 1:
            runner = ok[1]
            text += (
                f"; next {runner.candidate.label} {runner.candidate.strategy} at "
                f"{_show(runner.value(self.criterion), self.criterion)}"
            )
            text += _tie(best, runner, self.criterion)
        if bounded:
            text += (
                f"; {bounded} more not searched: each one's lower bound is at least the best's "
                "value"
            )
        return text


def _same(a: Any, b: Any) -> bool:
    """Equal, NaN counting as equal to NaN (a quantity that is not known)."""
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def _show(x: float, criterion: str) -> str:
    if criterion == "duration":
        return f"{x:g}"
    return f"{x:,.2f}" if abs(x) < 1e6 else f"{x:.3e}"


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


def _tie(best: Outcome, runner: Outcome, criterion: str) -> str:
    """What broke a tie of the best and the next by `criterion` (`rank`'s keys in turn), or
    that they differ by rounding only (a symmetric robot's mirrored sequences: a new user
    read "chose (S2, S1) (81.83); next (S4, S3) at 81.83" with no word of how)."""
    a, b = best.value(criterion), runner.value(criterion)
    if not (math.isfinite(a) and math.isfinite(b)):
        return ""
    if a != b:
        close = abs(a - b) <= TIE * max(1.0, abs(b))
        return f" (a tie but for {abs(a - b):.0e})" if close else ""
    if best.energy != runner.energy:
        return " (a tie, broken by total energy)"
    if len(best.candidate.legs) != len(runner.candidate.legs):
        return " (a tie, broken by fewer legs)"
    return " (a tie, broken by the order of the candidates)"


def rank(outcomes: Sequence[Outcome], criterion: str) -> list[int]:
    """Outcome indices, best first.

    Sequences that reached the goal by `criterion`, then total energy, then fewer legs, then
    enumeration order; then those the screen bounded (not planned), by their bound; failed
    ones after them: more legs planned first, those that reached every goal but broke a limit
    by how far (`_outside_only`: among six such, the last leg's errors of ~1e-14 had decided),
    then the smaller error of the leg that failed, then enumeration order (rejected before
    planning: last).
    """

    def ok_key(o: Outcome):
        value = o.value(criterion)
        return (math.inf if math.isnan(value) else value, o.energy, len(o.candidate.legs), o.index)

    def failed_key(o: Outcome):
        if o.plan is None or not o.plan.legs:
            return (1, 0, 0, math.inf, o.index)
        reached = sum(leg.converged for leg in o.plan.legs)
        by = _outside_only(o)
        if by is not None:
            return (0, -reached, 0, by, o.index)
        return (0, -reached, 1, o.plan.legs[-1].error, o.index)

    ok = sorted((o for o in outcomes if o.ok), key=ok_key)
    bounded = sorted(
        (o for o in outcomes if o.status == "bounded"),
        key=lambda o: (o.energy_bound_equal_time, o.index),
    )
    failed = sorted((o for o in outcomes if o.status == "failed"), key=failed_key)
    return [o.index for o in (*ok, *bounded, *failed)]


STALLED_BY = re.compile(r"still violated by ([0-9.]+(?:e[-+]?[0-9]+)?)")  # `constrained`'s stall


def _outside_only(o: Outcome) -> float | None:
    """How far past a limit a failed candidate is that reached every goal, or None (it did
    not reach them, or no limit failed it): where its constrained search stalled, as its
    row says (`still violated by 0.202 rad`), else its kept plan's first violation."""
    plan = o.plan
    if plan is None or not plan.legs or not all(leg.converged for leg in plan.legs):
        return None
    if len(plan.legs) != len(o.candidate.legs) or plan.constraints is None:
        return None
    stalled = STALLED_BY.search(o.message or "")
    if stalled is not None:
        return float(stalled[1])
    by = (plan.constraints.violation or {}).get("by")
    return None if by is None else float(by)


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
