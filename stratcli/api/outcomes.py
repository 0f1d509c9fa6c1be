"""What the planning use cases return: frozen, picklable values (ARCHITECTURE: results as
values). `stratcli.api.planning` makes them; `write_record` turns them into run records."""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

from ..compare import Comparison
from ..decomposition import Decomposition
from ..frozen_json import HoldsDocument
from ..records.manifest import Phases
from ..scenario import Task
from ..sequence import SequencePlan
from ..wording import counted
from .auto import AutoSettings

__all__ = ["ComparisonOutcome", "DecompositionOutcome", "PlanOutcome"]


@dataclass(frozen=True, repr=False)
class PlanOutcome(HoldsDocument):
    """A planned scenario: the plan (`result`), its result.json document and what it took.

    Attributes
    ----------
    task : Task
        The scenario planned; in auto mode, with the chosen sequence's legs.
    result : SequencePlan
        The plan.
    document : dict
        Its result.json (read-only: `copy.deepcopy` gives a changeable copy).
    started : datetime
        When planning started (UTC).
    compile_time, planning_time : float
        Seconds generating the model's numeric functions, and planning.
    phases : dict
        Wall and CPU seconds of each phase (import, check, compile, planning; `write_record`
        adds the record's parts, `write` and `total`); no part of the outcome's value.
    check_time : float or None
        Seconds of the controllability check (None: not run).
    ok : bool
        Every leg reached its goal.
    """

    task: Task  # in auto mode: the scenario with the chosen sequence's legs
    result: SequencePlan
    document: dict[str, Any]  # result.json (read-only: `frozen_json`)
    started: datetime  # UTC, when planning started
    compile_time: float  # seconds generating numeric functions (not the check: check_time)
    planning_time: float  # seconds planning
    # wall and CPU seconds per phase: import, check, compile, planning; write_record adds the
    # record's parts, "write" and "total" (since `import stratcli`); see records.manifest.
    # How long it took, not what was planned: no part of the outcome's value (==)
    phases: Phases = field(default_factory=dict, compare=False)
    check_time: float | None = None  # seconds of the controllability check; None: not run

    @property
    def ok(self) -> bool:
        """Every leg reached its goal."""
        return self.result.ok

    def __repr__(self) -> str:  # the fields' reprs run to many kB (scenario text, models)
        return f"PlanOutcome({self.result!r})"

    def __hash__(self) -> int:  # (the document is a dict: equal outcomes share their plan)
        return hash(self.result)


@dataclass(frozen=True, repr=False)
class ComparisonOutcome(HoldsDocument):
    """Every candidate sequence planned and ranked; `best` is the chosen sequence's
    `PlanOutcome` (its plan: `best.result`).

    Attributes
    ----------
    task : Task
        The scenario compared (its [decompose] table, no legs).
    settings : AutoSettings
        The [decompose] table with the call's overrides applied (`settings.notes`: what it
        said about them).
    decomposition : Decomposition
        The candidate sequences, as `decompose` finds them.
    comparison : Comparison
        Every candidate's outcome and the ranking (`comparison.choice()`: why `best`).
    document : dict
        comparison.json (read-only).
    best : PlanOutcome
        The chosen sequence's plan.
    notes : tuple of str
        About the best plan, which the ranking does not show (where it leaves its URDF's
        joint limits, how much it was slowed to meet rate limits).
    ok : bool
        Some sequence reached the goal.
    """

    task: Task
    settings: AutoSettings  # the [decompose] table with overrides applied
    decomposition: Decomposition
    comparison: Comparison
    document: dict[str, Any]  # comparison.json (read-only: `frozen_json`)
    best: PlanOutcome
    # for the user, about the best plan, which the ranking does not show (also in its notes):
    # where it leaves its URDF's joint limits (`urdf_limits.with_limit_notes`), how much it
    # was slowed to meet its rate limits (`planning.within_rates`)
    notes: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        """Some sequence reached the goal."""
        return self.best.ok

    def __hash__(self) -> int:  # (the document is a dict: equal outcomes share these)
        return hash((self.task, self.best))

    def __repr__(self) -> str:
        candidates = len(self.decomposition.candidates)
        return (
            f"ComparisonOutcome({self.task.scenario.name!r}: "
            f"{counted(candidates, 'candidate sequence')}, "
            f"best {self.best.result!r})"
        )


@dataclass(frozen=True)
class DecompositionOutcome(HoldsDocument):
    """The candidate sequences of a scenario's task, not planned.

    Attributes
    ----------
    task : Task
        The scenario decomposed.
    settings : AutoSettings
        The [decompose] table with the call's overrides applied.
    decomposition : Decomposition
        The essential coordinates and the candidate sequences with their vias.
    document : dict
        What `stratplan decompose --json` prints (read-only).
    notes : tuple of str
        For the user: an attitude of a URDF task past a half turn, and the shorter rotation
        it is (as `plan` notes it).
    """

    task: Task
    settings: AutoSettings
    decomposition: Decomposition
    document: dict[str, Any]  # what `stratplan decompose --json` prints (read-only)
    notes: tuple[str, ...] = ()

    def __hash__(self) -> int:  # (the document is a dict: equal outcomes share their task)
        return hash(self.task)

    def __repr__(self) -> str:  # the dataclass's runs to many kB (task, every candidate)
        sequences = [f"({', '.join(c.sequence)})" for c in self.decomposition.candidates]
        shown = ", ".join(sequences[:6]) + (", ..." if len(sequences) > 6 else "")
        return (
            f"DecompositionOutcome({self.task.scenario.name!r}: {len(sequences)} candidate "
            f"sequences: {shown})"
        )
