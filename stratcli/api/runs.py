"""Run-record use cases: writing and reading records (replaying scenarios against a baseline:
`regression`)."""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
import tomllib
from collections.abc import Callable, Sequence
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..arguments import checked, choice, flag, instance, pathlike
from ..errors import InputError, Problem
from ..records.rundir import clean_partials, dangling_link  # stdlib only: light
from ..records.store import Record, list_records, mcap_summary, read_record

# The planner (scipy, sympy, matplotlib) is imported by the functions that write, load or
# replay records, not here: `stratplan runs` and `show` only read JSON (start-up speed).
if TYPE_CHECKING:
    from ..sequence import SequencePlan
    from .outcomes import ComparisonOutcome, PlanOutcome


# ------------------------------------------------------------------------------------------
# Records
# ------------------------------------------------------------------------------------------


def _outcome_types() -> tuple[type, ...]:
    from ..sequence import SequencePlan  # start-up speed (module comment)
    from .outcomes import ComparisonOutcome, PlanOutcome

    return SequencePlan, PlanOutcome, ComparisonOutcome


OUTCOME = "a SequencePlan, PlanOutcome or ComparisonOutcome (plan, plan_auto, compare_sequences)"
FORMATS = ("png", "svg", "pdf")  # of the plots (`records.figure_common.FORMATS`)


@checked(
    out=pathlike, outcome=instance(OUTCOME, _outcome_types), animation=flag, fmt=choice(*FORMATS)
)
def write_record(
    out: str | Path,
    outcome: SequencePlan | PlanOutcome | ComparisonOutcome,
    *,
    animation: bool = False,
    argv: Sequence[str] | None = None,
    fmt: str = "png",
) -> Path:
    """Write a run record (result, manifest, scenario, MCAP log, plots) atomically.

    Parameters
    ----------
    out : str or Path
        Directory of run records; the run gets a new directory inside it.
    outcome : SequencePlan, PlanOutcome or ComparisonOutcome
        A plan (from `plan`, or a run of the CLI's use cases); for a comparison, the best
        sequence's record plus comparison.json, comparison.csv and ranking.png.
    animation : bool
        Also write motion.gif (off by default: drawing it costs more than planning); planar
        robots only (a URDF robot's motion plays from run.mcap in Foxglove).
    argv : sequence of str, optional
        The command recorded in manifest.json (default: this process's `sys.argv`).
    fmt : str
        Format of the plots: "png", "svg" or "pdf" (configuration.svg, ...; motion.gif stays).

    Returns
    -------
    Path
        The run directory. The outcome's `phases` (a `PlanOutcome`'s, or the best's) gain
        the record's parts, `write` and `total` (see `stratcli.records.manifest`).

    Raises
    ------
    RecordError
        The record could not be written (nothing complete-looking is left).
    InputError
        `fmt` is not png, svg or pdf; a plan without a scenario to record.
    TypeError
        `outcome` is not one of those values (or another argument of the wrong type).
    """
    wall, cpu = time.perf_counter(), time.process_time()
    from ..records import drawing
    from ..records import run as run_files  # start-up speed (module comment)
    from ..records.comparison import comparison_csv
    from ..records.manifest import RECORD_PHASES, manifest, phase, since_start

    if not drawing.running():  # no drawing process (`draw_ahead`): matplotlib loads here
        from ..records import plots, ranking  # noqa: F401

    # matplotlib and mcap load here, on the first record a process writes: a phase of its own
    imported = {"wall_s": time.perf_counter() - wall, "cpu_s": time.process_time() - cpu}
    from ..sequence import SequencePlan
    from .outcomes import ComparisonOutcome

    if isinstance(outcome, SequencePlan):
        outcome = _outcome_of(outcome)
    planned = outcome.best if isinstance(outcome, ComparisonOutcome) else outcome
    task = planned.task
    timings = {
        "started": planned.started.isoformat(),
        "finished": datetime.now(UTC).isoformat(),
        "compile_time_s": planned.compile_time,
        "planning_time_s": planned.planning_time,
    }
    command = list(sys.argv if argv is None else argv)
    code = 0 if planned.ok else 1
    planning = {k: v for k, v in planned.phases.items() if k not in RECORD_PHASES}
    info = manifest(task.text, command, task.settings.seed, timings, code, planning)
    info["phases"]["record imports"] = imported
    comparing = isinstance(outcome, ComparisonOutcome)
    ranking = outcome.document if comparing else None  # its chart is drawn with the plots
    phases = info["phases"]
    extra = {}
    if comparing:  # (before run.mcap is built: the manifest in it has every phase's time)
        with phase(phases, "comparison files"):
            extra["comparison.json"] = outcome.document
            extra["comparison.csv"] = comparison_csv(outcome.document)
    files = run_files.record_files(
        task, planned.result, planned.document, info, animation, fmt, ranking
    )
    files.update(extra)
    with phase(phases, "write"):  # after manifest.json is written: in the outcome only
        run_dir = run_files.write_record(Path(out), task, files, planned.started)
    planned.phases.update(phases, total=since_start())
    return run_dir


def draw_ahead(yielding: bool = True) -> bool:
    """Start a process that loads matplotlib now and draws the figures of the records this
    process writes (`records.drawing`).

    The command line calls it once a command's input is valid: the record then does not
    wait for matplotlib to load, and its figures are drawn on two cores. The figures are the
    same bytes. It does nothing where it cannot help: matplotlib already loaded (a notebook),
    one core, no fork.

    Parameters
    ----------
    yielding : bool
        Whether the process runs niced (`drawing.NICE`), yielding to worker processes that
        plan meanwhile (a comparison's); beside one planning process it need not.

    Returns
    -------
    bool
        Whether the drawing process runs.
    """
    from ..records import drawing

    return drawing.start(yielding)


def prepare_out(out: str | Path) -> Path:
    """Make sure run records can be written under `out` (created if missing).

    Parameters
    ----------
    out : str or Path
        Directory of run records.

    Returns
    -------
    Path
        The directory.

    Raises
    ------
    InputError
        Naming the path when it is a file, cannot be created, or is not writable (also on a
        read-only file system), so that nothing is planned for a record that cannot be kept.
    """
    out = Path(out)
    try:
        if out.exists() and not out.is_dir():
            raise InputError([Problem("out", "not a directory", given=str(out))])
        if gone := dangling_link(out):
            raise InputError([Problem("out", gone, given=str(out))])
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out):
            pass
    except OSError as exc:
        why = f"cannot write there ({exc.strerror or exc})"
        raise InputError([Problem("out", why, given=str(out))]) from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise InputError([Problem("out", "not writable", given=str(out))])
    return out


def _outcome_of(plan: SequencePlan) -> PlanOutcome:
    """What a record needs of a plan value: its scenario (re-read from the plan's text)."""
    from ..scenario import load_scenario  # start-up speed (module comment)
    from ..stratified import LegSpec
    from .planning import PlanOutcome
    from .sequences import with_legs

    if not plan.scenario_text:
        raise InputError(
            "the plan has no scenario to record (it was not planned from one): plan it with "
            "stratcli.plan(scenario)"
        )
    text, spec = plan.scenario_text, plan.model.spec
    if getattr(spec, "kind", None) == "urdf":  # its path is relative to a file unknown here
        from ..records.model_files import with_model_path

        text = with_model_path(text, spec.path)  # (absolute: as the plan was built)
    task = load_scenario(text, name=plan.scenario or "<plan>")
    task = replace(task, text=plan.scenario_text)  # recorded as given
    if not task.legs:  # auto mode: record the chosen sequence, as `stratplan plan` does
        legs = [LegSpec(leg.stratum, leg.goal, leg.method, leg.duration) for leg in plan.legs]
        task = with_legs(task, legs)
    try:
        started = datetime.fromisoformat(plan.timings.started)
    except ValueError:
        started = datetime.now(UTC)
    t = plan.timings
    return PlanOutcome(task, plan, plan.to_dict(), started, t.compile_s, t.planning_s)


@checked(path=pathlike)
def load_run(path: str | Path) -> SequencePlan:
    """A plan read back from its run record (nothing is re-planned).

    Parameters
    ----------
    path : str or Path
        A run directory, or its `result.json`.

    Returns
    -------
    SequencePlan
        The same plan type `plan` returns: `load_run(d).to_dict()` equals the record's
        result.json; `.sample()` rebuilds the model from the record's scenario (a URDF
        robot from the record's own copy of its URDF).

    Raises
    ------
    InputError
        When the record is missing, incomplete or damaged.
    TypeError
        `path` is not a str or Path.
    """
    from ..results import ModelRef, Timings  # start-up speed (module comment)
    from ..sequence import SequencePlan

    path = Path(path)
    if path.is_file():
        if not (path.parent / "result.json").is_file():  # not a file of a record
            raise InputError(f"{path}: a file, not a run record (give a run directory)")
        path = path.parent
    record = read_record(path)
    text = (path / "scenario.toml").read_text(encoding="utf-8")
    scenario = _record_scenario(path, text)
    model = ModelRef(record.result["model"], scenario.model)
    try:
        plan = SequencePlan.from_dict(record.result, scenario.planner, model)
    except InputError as exc:
        raise InputError(f"{path}/result.json: damaged ({exc})") from None
    m = record.manifest
    timings = Timings(
        str(m.get("started", "")),
        float(m.get("compile_time_s", float("nan"))),
        float(m.get("planning_time_s", float("nan"))),
    )
    return replace(plan, scenario_text=text, timings=timings)


def _record_scenario(path: Path, text: str):
    """The record's scenario.toml validated as `load_scenario` reads it (a URDF scenario's
    configurations by joint name, its URDF path relative to the record), not resolved;
    one `InputError` line naming the file when it is not a valid scenario.

    A record written before records held their URDF names it relative to the scenario file
    it came from: where that finds nothing, the absolute path of its resolved.json is used.
    """
    from pydantic import ValidationError

    from ..scenario import Scenario
    from ..schema_problems import validation_problems

    where = f"{path}/scenario.toml"
    try:
        raw = tomllib.loads(text)
        model = raw.get("model")
        if isinstance(model, dict) and model.get("kind") == "urdf":
            from ..models.spatial_scenario import prepare_urdf

            raw["model"] = {**model, "path": _urdf_path(path, model.get("path"))}
            raw, _ = prepare_urdf(raw, path)
        return Scenario.model_validate(raw)
    except tomllib.TOMLDecodeError as exc:
        problems = [Problem("", f"not TOML ({exc})")]
    except ValidationError as exc:
        problems = validation_problems(exc, root=Scenario)
    except InputError as exc:
        problems = exc.problems
    first = problems[0].render() if problems else "invalid"
    more = f"; and {len(problems) - 1} more" if len(problems) > 1 else ""
    raise InputError(f"{where}: not a valid scenario ({first}{more})") from None


def _urdf_path(path: Path, given: Any) -> Any:
    """`given` (the record's `[model] path`), or for an older record whose path does not lead
    to a file from the record, the absolute path of its resolved.json if that exists."""
    if not isinstance(given, str) or (path / Path(given).expanduser()).is_file():
        return given
    try:
        resolved = json.loads((path / "resolved.json").read_text(encoding="utf-8"))
        absolute = resolved["model"]["path"]
    except (OSError, ValueError, KeyError, TypeError):
        return given
    return absolute if isinstance(absolute, str) and Path(absolute).is_file() else given


def read_run(path: Path) -> tuple[Record, dict[str, Any] | None]:
    """A run record read back (not re-planned) and a summary of its MCAP log.

    Parameters
    ----------
    path : Path
        A run directory.

    Returns
    -------
    tuple
        The record (result.json and manifest.json as dicts) and the MCAP summary, or None
        when the record has no log.
    """
    record = read_record(path)
    return record, mcap_summary(record.path)


def list_runs(out: Path, on_damaged: Callable[[str], None] | None = None) -> list[dict[str, Any]]:
    """The run records in `out`, newest first.

    Parameters
    ----------
    out : Path
        Directory of run records.
    on_damaged : callable, optional
        Called with one line (naming the file and what is wrong) for each damaged record,
        which is left out of the list.

    Returns
    -------
    list of dict
        One row per record: run (its folder's name), path (the folder, for `show` or
        `load_run`), started, scenario, status, total_energy.
    """
    return [
        {
            "run": r.path.name,
            "path": str(r.path),
            "started": r.started,
            "scenario": r.result.get("scenario"),
            "status": r.result.get("status"),
            "total_energy": r.result.get("total_energy"),
        }
        for r in list_records(out, on_damaged)
    ]


def clean_runs(out: Path) -> list[Path]:
    """Remove the hidden partial directories that killed runs left in `out`.

    Parameters
    ----------
    out : Path
        Directory of run records.

    Returns
    -------
    list of Path
        The directories removed: those whose writer on this host has died, and any older than
        an hour. A run still writing its record keeps its directory.
    """
    return clean_partials(Path(out))
