"""Task decomposer (paper §5.3): from a start and a goal to candidate sequences.

Pure functions, no I/O. For a task `q0 → qd` on a stratified system:

1. *Essential coordinates*: the prescribed goal coordinates that differ from the start by more
   than a tolerance (a goal entry "*" is never essential).
2. *Candidate strata*: those that move at least one essential coordinate. A stratum *moves* a
   coordinate when the coordinate is not locked on it and its row of `G` is not identically zero
   on the stratum's active inputs, so the unactuated base angle θ of a manipulator counts as
   moved by every stratum (θ' = A(q)·u whenever some joint moves).
3. *Sequences*: every sequence of candidates up to a maximum length, repeats allowed but never
   the same stratum twice in a row, whose strata together move every essential coordinate;
   shortest first, then in the model's stratum order.
4. *Boundary configurations* (the via configurations), leg by leg from the start. On a leg,
   coordinates the stratum cannot move keep their current value (a via must be reachable), and
   so do coordinates that need no change. An essential coordinate the stratum moves is set to
   its goal value
   - `conservative`: on every leg that moves it (so on the first such leg, "as soon as
     possible"; later legs keep it there),
   - `postponed`: only on the last leg of the sequence that moves it.
   The last leg's goal is the task goal. A coordinate whose goal is "*" is left to the planner
   (not prescribed) on every leg that moves it.

With the conservative strategy this reproduces the paper's Sim 4 exactly: tasks A (S1, S2),
B (S2, S1), C (S3, S2, S1) and D (S3, S1) with their printed via configurations.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from .errors import InputError, Problem
from .models.system import Stratum, System
from .stratified import LegSpec
from .wording import counted

STRATEGIES = ("conservative", "postponed")
ESSENTIAL_TOLERANCE = 1e-9  # the same slack check_legs allows on a locked coordinate
MAX_SEQUENCES = 5000  # refuse to enumerate (and plan) more candidates than this


@dataclass(frozen=True)
class Candidate:
    """One candidate decomposition: a sequence of strata and the legs that realise it."""

    sequence: tuple[str, ...]
    strategy: str
    legs: tuple[LegSpec, ...]  # the last leg's goal is the task goal

    @property
    def vias(self) -> list[np.ndarray]:
        """The intermediate configurations (every leg's goal but the last)."""
        return [leg.goal for leg in self.legs[:-1]]

    @property
    def label(self) -> str:
        return "(" + ", ".join(self.sequence) + ")"

    def __repr__(self) -> str:  # the dataclass's prints every leg's goal array
        return f"Candidate({self.label} {self.strategy})"

    def redundant_legs(self, start: np.ndarray) -> tuple[int, ...]:
        """1-based numbers of legs whose goal equals their start: they only close a loop."""
        out = []
        current = np.asarray(start, dtype=float)
        for i, leg in enumerate(self.legs):
            if _same(leg.goal, current):
                out.append(i + 1)
            current = np.where(np.isnan(leg.goal), current, leg.goal)
        return tuple(out)


@dataclass(frozen=True)
class Decomposition:
    """Everything the decomposer found for one task."""

    essential: tuple[int, ...]
    candidates_strata: tuple[str, ...]
    max_length: int
    strategies: tuple[str, ...]
    sequences: tuple[tuple[str, ...], ...]
    candidates: tuple[Candidate, ...]  # sequence-major, strategies in the order asked

    def __repr__(self) -> str:  # the dataclass's prints every candidate's legs (kB)
        return (
            f"Decomposition({len(self.candidates)} candidates of up to {self.max_length} "
            f"strata from {', '.join(self.candidates_strata)}; {', '.join(self.strategies)})"
        )


def essential_coordinates(
    start: Sequence[float], goal: Sequence[float], tolerance: float = ESSENTIAL_TOLERANCE
) -> tuple[int, ...]:
    """Indices of the prescribed goal coordinates that differ from the start (paper step 1)."""
    start = np.asarray(start, dtype=float)
    goal = np.asarray(goal, dtype=float)
    differs = ~np.isnan(goal) & (np.abs(goal - start) > tolerance)
    return tuple(np.flatnonzero(differs).tolist())


def moved_coordinates(system: System, stratum: Stratum | str) -> tuple[int, ...]:
    """Coordinates a stratum can change: unlocked, with a row of `G` that is not zero on it."""
    s = system.stratum(stratum) if isinstance(stratum, str) else stratum
    if system.robot is not None or getattr(system, "spatial", None) is not None:
        # a manipulator (planar or URDF): unlocked joints have inputs, the attitude moves with
        # them (and deriving A symbolically is slow for long chains; a URDF has no symbols)
        return s.free(system.n)
    G = system.fields_on(s)
    return tuple(
        i
        for i in s.free(system.n)
        if any(G[i, j] != 0 for j in range(G.shape[1]))  # structural zero: no simplification
    )


def candidate_strata(
    system: System, essential: Iterable[int], allowed: Iterable[str] | None = None
) -> tuple[str, ...]:
    """Strata (in the model's order) that move at least one essential coordinate (step 2)."""
    essential = set(essential)
    names = system.strata if allowed is None else [s for s in system.strata if s in set(allowed)]
    return tuple(s for s in names if essential & set(moved_coordinates(system, s)))


def count_sequences(n_strata: int, max_length: int) -> int:
    """Sequences of length 1..max_length with no stratum twice in a row (before coverage)."""
    return sum(n_strata * (n_strata - 1) ** (k - 1) for k in range(1, max_length + 1))


def enumerate_sequences(
    moves: dict[str, tuple[int, ...]], essential: Iterable[int], max_length: int
) -> list[tuple[str, ...]]:
    """All sequences over `moves` (stratum → moved coordinates) that cover `essential` (step 3).

    Shortest first; within a length, in the order of `moves`. Never the same stratum twice in
    a row; repeats otherwise allowed.
    """
    essential = frozenset(essential)
    names = list(moves)
    out: list[tuple[str, ...]] = []
    for length in range(1, max_length + 1):
        for seq in itertools.product(names, repeat=length):
            if any(a == b for a, b in itertools.pairwise(seq)):
                continue
            covered = set().union(*(moves[s] for s in seq))
            if essential <= covered:
                out.append(seq)
    return out


def boundary_configurations(
    system: System,
    start: Sequence[float],
    goal: Sequence[float],
    sequence: Sequence[str],
    strategy: str,
    essential: Iterable[int] | None = None,
    moves: dict[str, tuple[int, ...]] | None = None,
) -> list[np.ndarray]:
    """The goal of every leg of `sequence` (step 4); the last one is `goal` itself.

    NaN marks a coordinate left to the planner (its goal is "*"). Raises ValueError if the
    sequence cannot reach the goal (an essential coordinate no stratum of it moves).
    """
    if strategy not in STRATEGIES:
        raise ValueError(f"unknown strategy {strategy!r} (known: {', '.join(STRATEGIES)})")
    start = np.asarray(start, dtype=float)
    goal = np.asarray(goal, dtype=float)
    essential = set(essential_coordinates(start, goal) if essential is None else essential)
    moves = moves or {s: moved_coordinates(system, s) for s in set(sequence)}
    moved = [set(moves[s]) for s in sequence]
    uncovered = essential - set().union(*moved)
    if uncovered:
        names = ", ".join(system.states[i] for i in sorted(uncovered))
        raise ValueError(f"no stratum of {tuple(sequence)} moves {names}")
    current = start.copy()
    targets: list[np.ndarray] = []
    for i in range(len(sequence)):
        target = current.copy()
        for c in moved[i]:
            if np.isnan(goal[c]):
                target[c] = np.nan  # not prescribed: wherever the planner ends
            elif c in essential and (
                strategy == "conservative" or not any(c in later for later in moved[i + 1 :])
            ):
                target[c] = goal[c]
        targets.append(target)
        current = target
    # The last leg: what is left equals the goal on prescribed coordinates by construction.
    last = targets[-1]
    prescribed = ~np.isnan(goal)
    assert np.allclose(last[prescribed], goal[prescribed], rtol=0, atol=ESSENTIAL_TOLERANCE)
    targets[-1] = goal.copy()
    return targets


def decompose(
    system: System,
    start: Sequence[float],
    goal: Sequence[float],
    *,
    max_length: int = 3,
    strategies: Sequence[str] = ("conservative",),
    strata: Iterable[str] | None = None,
    duration: float = 1.0,
    method: str = "newton",
) -> Decomposition:
    """Essential coordinates, candidate strata, sequences and their legs (paper §5.3).

    Raises InputError whose problems name `max_length` or `strata` (callers prefix the path)
    when there is nothing to plan, when no sequence of at most `max_length` strata moves every
    essential coordinate, or when there would be more than MAX_SEQUENCES candidates.
    """
    start = np.asarray(start, dtype=float)
    goal = np.asarray(goal, dtype=float)
    for s in strategies:
        if s not in STRATEGIES:
            raise ValueError(f"unknown strategy {s!r} (known: {', '.join(STRATEGIES)})")
    essential = essential_coordinates(start, goal)
    names = [system.states[i] for i in essential]
    if not essential:
        why = (  # (every one "*": "equals the start on every prescribed coordinate" of none)
            'the goal prescribes no coordinate (every one is "*"): nothing to decompose; '
            "give at least one coordinate's goal, or the legs"
            if np.isnan(goal).all()
            else "the goal equals the start on every prescribed coordinate (within "
            f"{ESSENTIAL_TOLERANCE:g}): nothing to decompose; give the legs instead"
        )
        raise InputError([Problem("", why)])
    allowed = list(system.strata) if strata is None else list(strata)
    moves_all = {s: moved_coordinates(system, s) for s in allowed}
    cands = candidate_strata(system, essential, allowed)
    moves = {s: moves_all[s] for s in cands}
    reachable = set().union(*moves.values()) if moves else set()
    missing = [system.states[i] for i in essential if i not in reachable]
    if missing:
        which = "no stratum of the model" if strata is None else "none of the strata listed"
        raise InputError(
            [Problem("strata", f"{which} moves {', '.join(missing)}; add a stratum that does")]
        )
    shortest = _shortest_cover(moves, essential)
    if shortest > max_length:
        raise InputError(
            [
                Problem(
                    "max_length",
                    f"no sequence of at most {counted(max_length, 'stratum', 'strata')} moves "
                    f"every essential coordinate ({', '.join(names)}); the shortest needs "
                    f"{shortest} "
                    f"(got {max_length})",
                )
            ]
        )
    total = count_sequences(len(cands), max_length)
    if total > MAX_SEQUENCES:
        raise InputError(
            [
                Problem(
                    "max_length",
                    f"{len(cands)} candidate strata give up to {total} sequences of at most "
                    f"{max_length} strata (limit {MAX_SEQUENCES}); lower max_length or "
                    f"restrict the strata (got {max_length})",
                )
            ]
        )
    sequences = enumerate_sequences(moves, essential, max_length)
    candidates = []
    for seq in sequences:
        for strategy in strategies:
            targets = boundary_configurations(
                system, start, goal, seq, strategy, essential, moves_all
            )
            legs = tuple(
                LegSpec(stratum=s, goal=t, method=method, duration=duration)
                for s, t in zip(seq, targets, strict=True)
            )
            candidates.append(Candidate(seq, strategy, legs))
    return Decomposition(
        essential, cands, max_length, tuple(strategies), tuple(sequences), tuple(candidates)
    )


def _shortest_cover(moves: dict[str, tuple[int, ...]], essential: Iterable[int]) -> int:
    """Fewest strata that together move every essential coordinate (distinct strata)."""
    essential = set(essential)
    names = list(moves)
    for k in range(1, len(names) + 1):
        for combo in itertools.combinations(names, k):
            if essential <= set().union(*(moves[s] for s in combo)):
                return k
    return math.inf  # pragma: no cover - excluded by the caller's reachability check


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal where both are prescribed (NaN = not prescribed matches anything)."""
    mask = ~(np.isnan(a) | np.isnan(b))
    return bool(np.all(np.abs(a[mask] - b[mask]) <= ESSENTIAL_TOLERANCE))


__all__ = [
    "ESSENTIAL_TOLERANCE",
    "STRATEGIES",
    "Candidate",
    "Decomposition",
    "boundary_configurations",
    "candidate_strata",
    "decompose",
    "enumerate_sequences",
    "essential_coordinates",
    "moved_coordinates",
]
