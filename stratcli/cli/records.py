"""The commands that read run records back: `show` (a run or a sweep directory) and `runs`
(the records under a directory). They plan nothing; as in `commands`, the API is imported
inside them, for start-up speed.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from . import render, render_plan, render_tables
from .options import Json, Out, directory_value


def show(
    run: Annotated[
        Path,
        typer.Argument(
            help="Run directory (as printed by plan; or its name, under ./runs), or a sweep "
            "directory.",
            parser=directory_value,
        ),
    ],
    json_output: Json = False,
) -> None:
    """Show a run record (read back from its files, not re-planned), or a sweep directory."""
    from .. import api  # start-up speed
    from ..records.sweepdir import is_sweep_dir

    default = Path("runs") / run  # a name as `runs` lists it, under the default --out
    if not run.exists() and len(run.parts) == 1 and default.is_dir():
        run = default

    if is_sweep_dir(run):
        from .sweep import show_sweep

        show_sweep(run, json_output)
        return

    with render.reported():
        if not run.exists():  # `show` reads sweeps too: the message names both
            raise InputError(f"no run record or sweep directory at {run}")
        record, log = api.read_run(run)
    if json_output:
        doc = {"result": record.result, "manifest": record.manifest, "mcap": log}
        if record.comparison is not None:  # compare-sequences and auto-mode records
            doc["comparison"] = record.comparison
        render.print_json(doc)
    else:
        render_plan.run_record(record, log)


def runs(
    directory: Annotated[
        Path | None,
        typer.Argument(
            metavar="DIR",
            help="Directory of run records (as --out).",
            show_default=False,
            parser=directory_value,
        ),
    ] = None,
    out: Out = Path("runs"),
    json_output: Json = False,
    clean: Annotated[
        bool,
        typer.Option(
            "--clean",
            metavar="",
            help="First remove the hidden partial directories of killed runs (those of runs "
            "still writing are kept).",
        ),
    ] = False,
) -> None:
    """List run records, newest first: status, energy and the run's directory (named by
    the time it was planned and its scenario; `stratplan show` it).

    A damaged record is skipped with a note on stderr naming the file and what is wrong.
    """
    from .. import api  # start-up speed
    from ..api.runs import clean_runs

    given = "--out" if directory is None else "DIR"
    if directory is not None and out != Path("runs"):
        render.error("error", f"DIR {directory} and --out {out}: give the directory once")
        raise typer.Exit(2)
    out = out if directory is None else directory
    if out.exists() and not out.is_dir():
        render.error("error", f"{given} {out}: not a directory (a folder of run records)")
        raise typer.Exit(2)
    if not out.exists() and (directory is not None or out != Path("runs")):  # a typo, say
        render.error("error", f"{given} {out}: no such directory (a folder of run records)")
        raise typer.Exit(2)
    if clean:
        for path in clean_runs(out):
            typer.echo(f"removed {path} (left by a killed run)", err=True)
    rows = api.list_runs(out, on_damaged=lambda line: typer.echo(f"skipped: {line}", err=True))
    if json_output:
        render.print_json(rows)
    else:
        render_tables.runs_table(rows, out)
