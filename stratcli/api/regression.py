"""Replaying scenarios against a baseline file (`stratplan regress`): what CI compares."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..arguments import checked, integer, optional
from ..errors import InputError, Problem, RecordError
from ..frozen_json import HoldsDocument
from ..planner_contract import PlannerContractError
from ..records.sweepdir import write_json
from ..regress import DEFAULT_TOLERANCES, Difference, baseline_document, load_baseline, summary_of
from ..regress import compare as compare_baseline

if TYPE_CHECKING:
    from ..task import Task

__all__ = ["RegressReport", "regress", "summarise"]


@dataclass(frozen=True)
class RegressReport(HoldsDocument):
    """Scenarios replayed against a baseline file (a frozen value: its differences a tuple,
    its tables read-only)."""

    _documents = ("tolerances", "results", "seconds", "messages")

    scenarios: int
    baseline: Path
    tolerances: dict[str, float]
    differences: tuple[Difference, ...]
    updated: bool  # the baseline was rewritten from this run
    results: dict[str, dict[str, Any]] = field(default_factory=dict)  # each scenario's summary
    seconds: dict[str, float] = field(default_factory=dict)  # each scenario's planning (wall)
    messages: dict[str, str] = field(default_factory=dict)  # a failed plan's, by scenario

    def __post_init__(self) -> None:
        object.__setattr__(self, "differences", tuple(self.differences))
        super().__post_init__()

    @property
    def regressions(self) -> int:
        return sum(d.regression for d in self.differences)

    @property
    def document(self) -> dict[str, Any]:
        """The report as JSON-ready data (`regress --json`): the verdict, every difference
        and each scenario's status, energies, errors and seconds (non-finite numbers: None)."""
        from ..records.rundir import finite_or_none

        return finite_or_none(
            {
                "schema": "stratplan.regress/1",
                "baseline": str(self.baseline),
                "tolerances": dict(self.tolerances),
                "updated": self.updated,
                "scenarios": self.scenarios,
                "regressions": self.regressions,
                "differences": [asdict(d) for d in self.differences],
                "results": {
                    name: {
                        **summary,
                        "seconds": self.seconds.get(name),
                        "message": self.messages.get(name, ""),
                    }
                    for name, summary in self.results.items()
                },
            }
        )


@checked(jobs=optional(integer(1)))
def regress(
    directory: Path,
    baseline: Path,
    update: bool = False,
    progress: Callable[[str, dict[str, Any], float], None] | None = None,
    jobs: int | None = None,
) -> RegressReport:
    """Plan every scenario in `directory` and compare with a baseline file.

    Parameters
    ----------
    directory : Path
        Directory of scenario files (``*.toml``).
    baseline : Path
        Baseline JSON file (schema ``stratplan.baseline/1``).
    update : bool
        Rewrite the baseline from this run (keeping its tolerances when it exists).
    progress : callable, optional
        Called as `progress(name, summary, seconds)` after each scenario is planned (its
        status, energies and errors, and the seconds it took); default: silent.
    jobs : int, optional
        Worker processes of an auto-mode scenario's comparison (default: all cores; 1 keeps
        the whole run in this process, for a shared CI machine).

    Returns
    -------
    RegressReport
        Every difference beyond the baseline's tolerances; `.regressions` counts the ones
        that fail CI.
    """
    if not Path(directory).is_dir():  # (it said "no scenario files (*.toml) in" it)
        what = "a file, not a folder" if Path(directory).exists() else "no such directory"
        raise InputError(f"{directory}: {what} (regress replays the *.toml files of a folder)")
    paths = sorted(Path(directory).glob("*.toml"))
    if not paths:
        raise InputError(f"no scenario files (*.toml) in {directory}")
    if update and (why := _unwritable(Path(baseline))):  # before minutes of planning
        raise InputError(f"baseline file {baseline}: {why}")
    old, tolerances = {}, dict(DEFAULT_TOLERANCES)
    if not update or baseline.exists():
        try:
            old, tolerances = load_baseline(baseline)
        except InputError:
            if not update:
                raise
    tasks = _load_all(paths)  # a bad file is found before minutes of planning, not after
    now, seconds, messages = {}, {}, {}
    for path in paths:
        clock = time.perf_counter()
        try:
            now[path.stem] = summarise(tasks[path], jobs=jobs)
        except PlannerContractError as exc:  # (it named the planner and leg, not the file)
            raise PlannerContractError(f"{path.name}: {exc}") from None
        seconds[path.stem] = time.perf_counter() - clock
        if progress is not None:
            progress(path.stem, now[path.stem], seconds[path.stem])
        if message := now[path.stem].pop("message", ""):  # why it failed: said, not compared
            messages[path.stem] = message
    diffs = compare_baseline(now, old, tolerances)
    if update:
        try:
            write_json(baseline, baseline_document(now, tolerances))
        except OSError as exc:
            why = exc.strerror or exc
            raise RecordError(f"cannot write the baseline {baseline}: {why}") from None
    return RegressReport(len(now), baseline, tolerances, diffs, update, now, seconds, messages)


def _unwritable(path: Path) -> str:
    """Why `--update` could not write the baseline `path` ("" when it can try): a folder, or
    a file in a folder that does not exist (a traceback after every scenario was planned)."""
    target = Path(os.path.realpath(path))  # (a link: its target is written)
    if target.is_dir():
        return "a directory, not a file"
    if not target.parent.is_dir():
        return f"no such directory {target.parent}"
    return ""


def _load_all(paths: list[Path]) -> dict[Path, Task]:
    """Every scenario file loaded, or an `InputError` naming the problems of all of them."""
    from ..scenario import load_scenario  # start-up speed (module comment)

    tasks, problems = {}, []
    for path in paths:
        try:
            tasks[path] = load_scenario(path)
        except InputError as exc:
            problems += [Problem("", p.render(exc.source)) for p in exc.problems]
    if problems:
        raise InputError(problems)
    return tasks


def summarise(path: Path | Task, jobs: int | None = None) -> dict[str, Any]:
    """Plan one scenario (as `plan` does, unchecked and not time-scaled) and keep what the
    baseline compares.

    Parameters
    ----------
    path : Path or Task
        A scenario file, or a loaded one; in auto mode the best candidate sequence is kept.
    jobs : int, optional
        Worker processes of an auto-mode comparison (default: all cores).

    Returns
    -------
    dict
        status, total_energy, errors and energies (one per leg), and a failed plan's
        message (not compared: a CI log says why).
    """
    from ..scenario import load_scenario  # start-up speed (module comment)
    from .planning import plan_auto, plan_run

    task = load_scenario(path) if isinstance(path, str | Path) else path
    if task.legs:
        result = plan_run(task, check=False, time_scale=1.0).result
    else:  # auto mode ([decompose], no [[legs]]): the best candidate sequence
        result = plan_auto(task, check=False, time_scale=1.0, jobs=jobs).best.result
    return {**summary_of(result), "message": "" if result.ok else result.message}
