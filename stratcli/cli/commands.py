"""One function per command: parse, call `stratcli.api`, render, exit with a code.

Exit codes: 0 ok, 1 a leg or every sequence failed (the record is still written), 2 bad input,
3 not controllable, 4 the run record could not be written. The API is imported inside the
commands, for start-up speed: `--help` needs none of the planner.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Literal

import typer

from ..errors import UnusedLegsWarning
from . import progress as bars
from . import render, render_plan, render_tables
from .options import (
    Animation,
    AutoJobs,
    Json,
    MaxLength,
    Objective,
    Out,
    Quiet,
    Scenario,
    Search,
    Strategy,
    TaskScenario,
    directory_value,
    file_value,
    jobs_notes,
)

Format = Annotated[
    Literal["png", "svg", "pdf"],
    typer.Option("--format", help="Format of the plots (motion.gif stays a GIF)."),
]


def load_task(path: Path):
    """The scenario file, or exit 2 naming every problem."""
    from ..scenario import load_scenario  # start-up speed: --help needs no model code

    with render.reported():
        return load_scenario(path)


def _with_planner(task, objective: str | None, search: str | None):
    """`task` with `--objective` and `--search` (given ones only) in its [planner] table: the
    record holds the scenario as changed."""
    changed = {"objective": objective, "search": search}
    if changed := {key: value for key, value in changed.items() if value is not None}:
        with render.reported():
            task = task.with_changes({"planner": changed})
    if search is not None and task.settings.objective == "newton":  # (said, not ignored)
        render.notes([f"--search {search} is the energy objective's search: the Newton "
                      "objective plans leg by leg without it"])  # fmt: skip
    return task


def _argv() -> list[str]:
    """The command as manifest.json records it."""
    return ["stratplan", *sys.argv[1:]]


def plan(
    file: Scenario,
    out: Out = Path("runs"),
    json_output: Json = False,
    quiet: Quiet = False,
    animation: Animation = False,
    time_scale: Annotated[
        float | None,
        typer.Option(
            min=1e-3,
            max=1e3,
            metavar="S",
            help="Run the planned path S times faster after planning (duration ÷ S, energy × S); "
            "overrides planner.time_scale.",
        ),
    ] = None,
    check: Annotated[
        bool,
        typer.Option(
            "--check/--no-check",
            metavar="",
            help="First check that each leg's stratum spans what the leg steers (Lie brackets, "
            "paper eq. 4; as `stratplan check`).",
        ),
    ] = True,
    fmt: Format = "png",
    objective: Objective = None,
    search: Search = None,
    jobs: AutoJobs = None,
) -> None:
    """Plan a scenario: every leg to tolerance, controls continuous across switches.

    Writes a run record under OUT and exits 0 (planned), 1 (a leg failed; the record is
    still written, marked failed), 2 (bad input, including an OUT that is not a writable
    directory), 3 (the controllability check failed: a leg's stratum cannot steer what the
    leg asks for; nothing is planned or written), 4 (the record could not be written), 130
    or 143 (interrupted by Ctrl-C or SIGTERM; no record is left half-written) or 120 (the
    output could not be written, e.g. to a full disk).

    Auto mode: a scenario with a decompose table and no legs plans every candidate sequence
    (as compare-sequences does), records the best by the table's criterion and says why.

    Legs are numbered from 1 in every table and message ("leg 1 on S3"); a field path such
    as legs[0].goal indexes the file's [[legs]] array, and result.json lists legs in order.
    """
    from .. import api  # start-up speed

    render.quiet(quiet)  # (its notes too: "Print nothing but errors")
    task = _with_planner(load_task(file), objective, search)
    with render.reported():
        api.prepare_out(out)  # before any planning: a bad --out is bad input
    # matplotlib loads while the plan is made; niced only beside a comparison's workers
    api.draw_ahead(yielding=not task.legs)
    if not task.legs:  # auto mode: a [decompose] table and no [[legs]]
        render.notes(jobs_notes(jobs, None))
        _plan_auto(task, file, out, json_output, quiet, animation, check, fmt, time_scale, jobs)
    if jobs is not None:  # (a flag that does nothing says so)
        render.notes(["--jobs is for auto mode (a scenario without [[legs]]): its legs are "
                      "planned in this process"])  # fmt: skip
    with bars.phases(bars.shown(quiet, json_output), log=True) as progress:
        with render.reported(file):
            outcome = api.plan_run(
                task, check=check, time_scale=time_scale, progress=progress, warn=render.warning
            )
        run_dir = _write(out, outcome, animation, progress, fmt)
    if json_output:  # result.json, and where the record is (not a key of result.json)
        render.print_json({**outcome.document, "record": str(run_dir)})
    elif not quiet:
        render_plan.plan_summary(outcome.document)
        render.plan_footer(outcome, run_dir)
    if not outcome.ok:
        render.error("planning failed", outcome.result.message + _kept(run_dir, quiet))
    raise typer.Exit(0 if outcome.ok else 1)


def _kept(run_dir: Path, quiet: bool) -> str:
    """Where a failed plan's record is, for its error line under --quiet (else the footer
    says so): with --quiet it went unsaid."""
    return f" ({render.record(run_dir)})" if quiet else ""


def _plan_auto(
    task, file: Path, out: Path, json_output, quiet, animation, check, fmt, time_scale=None,
    jobs=None,
) -> None:  # fmt: skip
    """`plan` on a scenario without legs: compare the candidates, record and show the best."""
    from .. import api  # start-up speed

    with render.reported(file), bars.progress_bar(bars.shown(quiet, json_output)) as bar:
        outcome = api.plan_auto(
            task, check=check, progress=bar, time_scale=time_scale, jobs=jobs, warn=render.warning
        )
    with bars.phases(bars.shown(quiet, json_output)) as progress:
        run_dir = _write(out, outcome, animation, progress, fmt)
    if json_output:  # the best plan's result.json, and the choice (as `show --json` has it)
        doc = {**outcome.best.document, "record": str(run_dir), "comparison": outcome.document}
        render.print_json(doc)
    elif not quiet:
        render_tables.auto_mode(outcome, run_dir)
    if not outcome.ok:
        render.error("planning failed", outcome.comparison.choice() + _kept(run_dir, quiet))
    raise typer.Exit(0 if outcome.ok else 1)


@contextmanager
def legs_as_notes() -> Iterator[None]:
    """The library's `UnusedLegsWarning` is printed as a `note:` line (the outcome's
    `settings.notes`), not as a Python warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnusedLegsWarning)
        yield


@contextmanager
def _prepared_out(out: Path) -> Iterator[None]:
    """`--out` checked before any planning (`api.prepare_out`: a bad one is bad input, exit
    2), and removed again if this command made it and stops before any record is in it (a
    --dask that cannot be reached, Ctrl-C while connecting): nothing written."""
    from .. import api  # start-up speed

    made = not out.exists()
    with render.reported():
        api.prepare_out(out)
    try:
        yield
    except BaseException:
        if made and out.is_dir() and not any(out.iterdir()):
            out.rmdir()
        raise


def _write(out: Path, outcome, animation: bool, progress, fmt: str = "png") -> Path:
    """Write the run record (exit 4 when it cannot be), telling `progress` so."""
    from .. import api  # start-up speed

    if progress is not None:
        progress(f"writing the run record in {out}")
    with render.reported():
        run_dir = api.write_record(out, outcome, animation=animation, argv=_argv(), fmt=fmt)
    planned = getattr(outcome, "best", outcome)
    if animation and getattr(planned.task.system, "spatial", None) is not None:  # (said)
        render.notes([
            "--animation draws motion.gif of planar robots only: a URDF robot's motion "
            "plays in 3-D from run.mcap in Foxglove (README: Run records)"
        ])  # fmt: skip
    return run_dir


def compare_sequences(
    file: TaskScenario,
    max_length: MaxLength = None,
    strategy: Strategy = None,
    criterion: Annotated[
        str | None,
        typer.Option(
            help="energy | peak-control | excursion | duration "
            "(default: decompose table, else energy).",
            metavar="NAME",
        ),
    ] = None,
    jobs: Annotated[
        int | None, typer.Option(help="Worker processes (default: all cores).", min=1)
    ] = None,
    dask: Annotated[
        str | None,
        typer.Option(
            metavar="ADDRESS|FILE",
            help="Plan the sequences on a Dask cluster (scheduler address or JSON file) instead "
            "of --jobs local processes; needs stratplan[dask].",
        ),
    ] = None,
    exhaustive: Annotated[
        bool,
        typer.Option(
            "--exhaustive",
            metavar="",
            help="Energy objective and criterion: search every sequence to its minimum "
            "instead of screening them (slower, the same choice on the tested tasks).",
        ),
    ] = False,
    out: Out = Path("runs"),
    json_output: Json = False,
    quiet: Quiet = False,
    animation: Animation = False,
    fmt: Format = "png",
    objective: Objective = None,
    search: Search = None,
) -> None:
    """Plan every candidate sequence in parallel (Newton: shared prefixes once) and rank them.

    With the energy objective and criterion the sequences are screened: each distinct leg is
    planned alone at least energy (or bounded below by its joints' travel and its stratum's
    curvature, without a search), and a sequence whose legs' sum cannot beat the best found
    is not searched (status "bounded", marked "screened" in comparison.json).
    Ranked by the criterion among the sequences that reached the goal (ties: lower energy);
    failed sequences stay in the table with their reason. The record holds the best
    sequence's full run record plus comparison.json, comparison.csv and ranking.png. Exits 0
    when some sequence reached the goal, 1 when none did, 2 on bad input.
    """
    from .. import api  # start-up speed

    render.quiet(quiet)
    task = _with_planner(load_task(file), objective, search)
    if exhaustive and task.settings.objective == "newton":
        render.notes(["--exhaustive is for the energy objective's screen: under the Newton "
                      "objective every sequence is planned anyway"])  # fmt: skip
    waiting = f"connecting to the Dask scheduler at {dask}" if dask else None
    shown = bars.shown(quiet, json_output)
    with _prepared_out(out), render.reported():  # (--out before any planning)
        api.draw_ahead()  # matplotlib loads while the sequences are planned
        render.notes(jobs_notes(jobs, dask))
        with bars.progress_bar(shown, waiting) as bar, legs_as_notes():
            options = {"max_length": max_length, "strategy": strategy, "criterion": criterion}
            outcome = api.compare_sequences(
                task, **options, jobs=jobs, progress=bar, exhaustive=exhaustive, dask=dask,
                warn=render.warning,
            )  # fmt: skip
    render.notes(outcome.settings.notes)
    with bars.phases(bars.shown(quiet, json_output)) as progress:
        run_dir = _write(out, outcome, animation, progress, fmt)
    if json_output:  # comparison.json, and where the record is (as `plan --json` says it)
        render.print_json({**outcome.document, "record": str(run_dir)})
    elif not quiet:
        render_tables.ranking(task, outcome.document)
        render.say(f"best: {outcome.comparison.choice()}")
        render_tables.comparison_footer(outcome, run_dir)
    render.notes(outcome.notes)  # the best plan's (its URDF's joint limits)
    if not outcome.ok:
        render.error(  # (its choice says none reached it)
            "planning failed", outcome.comparison.choice() + _kept(run_dir, quiet)
        )
    raise typer.Exit(0 if outcome.ok else 1)


def regress(
    directory: Annotated[
        Path, typer.Argument(help="Directory of scenario files.", parser=directory_value)
    ] = Path("scenarios"),
    baseline: Annotated[
        Path | None,
        typer.Option(
            help="Baseline JSON file (default: DIRECTORY/baseline.json).",
            show_default=False,
            parser=file_value,
        ),
    ] = None,
    update: Annotated[
        bool, typer.Option(metavar="", help="Rewrite the baseline from this run.")
    ] = False,
    quiet: Quiet = False,
    json_output: Json = False,
    jobs: AutoJobs = None,
) -> None:
    """Plan every scenario in DIRECTORY and compare with a baseline; exit 1 on a regression.

    Compared: status, each leg's final error and the total energy, with the tolerances stored
    in the baseline file (`energy_rel`, `error_abs`). With --json the report is printed as
    JSON (schema stratplan.regress/1: the differences and each scenario's numbers).
    """
    from .. import api  # start-up speed

    render.quiet(quiet)
    render.notes(jobs_notes(jobs, None))
    baseline = directory / "baseline.json" if baseline is None else baseline
    with render.reported():
        report = api.regress(
            directory, baseline, update=update, progress=render_tables.regress_progress(quiet),
            jobs=jobs,
        )  # fmt: skip
    if json_output:
        render.print_json(report.document)
    elif not quiet:
        render_tables.regress_report(report)
    elif report.regressions and not report.updated:  # exit 1 must say why, in a CI log too
        # (with --update they are taken into the baseline: no regression)
        render_tables.regress_failures(report)
    if not report.updated:
        raise typer.Exit(1 if report.regressions else 0)
