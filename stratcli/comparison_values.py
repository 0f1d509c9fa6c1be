"""The values of a comparison of candidate sequences (`compare`): each candidate's `Outcome`,
the `Comparison` of them all, and their ranking (`rank`): by the criterion among those that
reached the goal, then the screen's bounded ones, then the failed ones.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

from .decomposition import Candidate
from .screen import Screen
from .sequence import SequencePlan
from .values import ByValue  # a value: NaN (not known) equals NaN

__all__ = ["CRITERIA", "CRITERION_LABELS", "TIE", "Comparison", "Outcome", "rank"]

CRITERIA = ("energy", "peak-control", "excursion", "duration")
CRITERION_LABELS = {
    "energy": "total energy",
    "peak-control": "peak |u|",
    "excursion": "largest joint excursion",
    "duration": "total duration",
}
TIE = 1e-9  # relative: values that differ by less are a tie but for rounding (`_tie`)


def at_reference(durations, lengths, reference: float) -> bool:
    """Whether a comparison ranks energies at its equal total duration `reference` rather than
    as planned: a sequence that reached the goal took another duration (`durations`: theirs),
    or the ranked sequences (`lengths`: the legs of those that reached the goal and of those
    the screen bounded, whose bounds are at `reference`) differ in their number of legs. A
    failed sequence counts for neither: its duration is of the legs it planned. The
    comparison's sentence and the CLI's table (from comparison.json) both ask this."""
    return any(not math.isclose(d, reference) for d in durations) or len(set(lengths)) > 1


@dataclass(frozen=True, eq=False)
class Outcome(ByValue):
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


@dataclass(frozen=True, eq=False)
class Comparison(ByValue):
    """All outcomes, their ranking and what sharing and parallelism did."""

    outcomes: tuple[Outcome, ...]  # enumeration order (a list given is kept as a tuple)
    ranking: tuple[int, ...]  # outcome indices, best first (failed ones last)
    criterion: str
    jobs: int
    legs_requested: int  # legs the candidates' plans hold (what planning each alone costs)
    legs_planned: int  # legs actually planned
    wall_time: float
    shared: bool  # prefix sharing used (Newton objective)
    reference_duration: float = math.nan  # total duration the energies are compared at
    screen: Screen | None = None  # the screen's bounds and what it searched (None: exhaustive)
    on: str = ""  # where it ran, when not on `jobs` local processes: "a Dask cluster"

    def __post_init__(self) -> None:  # a frozen value: tuples, which cannot be changed
        object.__setattr__(self, "outcomes", tuple(self.outcomes))
        object.__setattr__(self, "ranking", tuple(self.ranking))

    @property
    def equal_durations(self) -> bool:
        """Whether the energies compare as planned, not at the reference duration
        (`at_reference`)."""
        durations = [o.duration for o in self.outcomes if o.ok and math.isfinite(o.duration)]
        lengths = [len(o.candidate.sequence) for o in self.outcomes if o.status != "failed"]
        return not at_reference(durations, lengths, self.reference_duration)

    @property
    def best(self) -> Outcome | None:
        return self.outcomes[self.ranking[0]] if self.ranking else None

    @property
    def legs_saved(self) -> int:
        return self.legs_requested - self.legs_planned

    __hash__ = None  # its outcomes hold NaN energies (hashed by identity: not by value)

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


def _show(x: float, criterion: str) -> str:
    if criterion == "duration":
        return f"{x:g}"
    return f"{x:,.2f}" if abs(x) < 1e6 else f"{x:.3e}"


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
    ones after them: those that reached every goal but broke a limit first, by how far
    (`_outside_only`: among six such, the last leg's errors of ~1e-14 had decided, and then
    the number of legs: a 3-leg sequence 0.824 outside ranked above a 2-leg one 0.502
    outside), then the others, more legs planned first, then the smaller error of the leg
    that failed, then enumeration order (rejected before planning: last).
    """

    def ok_key(o: Outcome):
        value = o.value(criterion)
        return (math.inf if math.isnan(value) else value, o.energy, len(o.candidate.legs), o.index)

    def failed_key(o: Outcome):
        if o.plan is None or not o.plan.legs:
            return (2, 0, math.inf, o.index)
        by = _outside_only(o)
        if by is not None:  # every goal reached: by how far, whatever the sequence's length
            return (0, 0, by, o.index)
        reached = sum(leg.converged for leg in o.plan.legs)
        return (1, -reached, o.plan.legs[-1].error, o.index)

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
