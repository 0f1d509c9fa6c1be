"""`stratplan sweep` and the sweep view of `stratplan show`: parse, call the API, render."""

from __future__ import annotations

import os
import shlex
import textwrap
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any, Literal

import typer
from rich.markup import escape
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    ProgressColumn,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.text import Text

from ..errors import UnusedLegsWarning
from ..wording import counted
from . import progress, render
from .options import Quiet, directory_value, file_value, jobs_notes

REASON_WIDTH = 240  # characters of a failure's message in a sweep's summary (all: results.csv)


class _Rate(ProgressColumn):
    """Tasks per second over the last half minute."""

    def render(self, task) -> Text:
        speed = task.speed
        return Text("– tasks/s" if speed is None else f"{speed:.2f} tasks/s", style="cyan")


@contextmanager
def progress_bar(enabled: bool, waiting: str | None = None) -> Iterator[Any]:
    """A `progress(done, total)` callback drawing tasks done, tasks/s and the time left on
    stderr (None when disabled; plain lines where stderr is no terminal,
    `progress.progress_lines`); refreshed as rows arrive, no refresh thread. The bar appears
    with the first row (or the first call); until then `waiting` is shown, if given."""
    if not enabled or not render.err_console.is_terminal:
        yield progress.progress_lines("sweep", " tasks") if enabled else None
        return
    columns = (
        TextColumn("sweep"),
        BarColumn(),
        MofNCompleteColumn(),
        _Rate(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        TextColumn("left"),
    )
    bar = Progress(*columns, console=render.err_console, auto_refresh=False, transient=True)
    job = bar.add_task("sweep", total=None)
    with progress.until_first_update(bar, waiting) as show:
        first: list[int] = []

        def update(done: int, total: int) -> None:
            if not first:  # rows found by --resume are not this run's speed
                first.append(done)
                bar.update(job, total=total - done)
            bar.update(job, completed=done - first[0])
            show()
            bar.refresh()

        yield update


def sweep(
    file: Annotated[Path, typer.Argument(help="Sweep file (TOML).", parser=file_value)],
    jobs: Annotated[
        int | None, typer.Option(help="Local worker processes (default: all cores).", min=1)
    ] = None,
    dask: Annotated[
        str | None,
        typer.Option(
            metavar="ADDRESS|FILE",
            help="Run on a Dask cluster: its scheduler's address (tcp://host:8786) or "
            "scheduler JSON file (needs stratplan[dask]).",
        ),
    ] = None,
    resume: Annotated[
        bool,
        typer.Option(
            "--resume", metavar="", help="Finish the sweep in OUT: plan only the missing tasks."
        ),
    ] = False,
    out: Annotated[
        Path | None,
        typer.Option(
            help="Sweep directory (default: sweeps/NAME, NAME from the sweep file).",
            parser=directory_value,
        ),
    ] = None,
    records: Annotated[
        Literal["best", "failed", "all", "none"] | None,
        typer.Option(
            help="Full run records written under OUT/records for these tasks, as they are "
            "planned.  [default: failed]",
            show_default=False,
        ),
    ] = None,
    json_output: Annotated[
        bool, typer.Option("--json", metavar="", help="Print sweep.json instead of the summary.")
    ] = False,
    strict: Annotated[
        bool,
        typer.Option(
            "--strict",
            metavar="",
            help="Exit 1 when any task did not plan (for CI: a failed "
            "task is otherwise a row like any other).",
        ),
    ] = False,
    quiet: Quiet = False,
) -> None:
    """Plan many tasks of one base scenario (a grid, random tasks or a table of them).

    Tasks run on local worker processes or a Dask cluster; each task's row is written to
    OUT/rows.jsonl as it finishes (fsync'd), so a sweep that was killed continues with
    --resume. At the end: results.csv (one row per task, in task order), sweep.json (counts,
    success rate, executor, wall time) and plots. Exits 0 when every task has its row (a
    task that failed is a row, with its status and message; with --strict, 1), 1 when tasks
    are missing because a worker died (run again with --resume), 2 on a bad sweep file.
    """
    import gc

    from .. import api  # start-up speed

    render.quiet(quiet)
    gc.enable()  # paused for short commands (stratcli.__main__); a sweep may run for hours
    with render.reported(), warnings.catch_warnings(record=True) as caught:
        from ..sweep import load_sweep

        warnings.simplefilter("always", UnusedLegsWarning)
        loaded = load_sweep(file)
    for w in caught:  # the legs a sweep in auto or compare mode does not use: a note line
        if issubclass(w.category, UnusedLegsWarning):
            render.notes([str(w.message)])
        else:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    render.notes(jobs_notes(jobs, dask))
    waiting = f"connecting to the Dask scheduler at {dask}" if dask else None
    target = loaded.out_dir(out)
    again = _again_command(file, target, jobs, dask, records)  # how to go on after a stop
    with _resume_hint(again, target, loaded.count), render.reported():
        with progress_bar(progress.shown(quiet, json_output), waiting) as bar:
            outcome = api.run_sweep(
                loaded, out, jobs=jobs, dask=dask, resume=resume, records=records or "failed",
                progress=bar,
            )  # fmt: skip
    if records not in (None, "none") and outcome.reprinted:  # finished before: no record
        render.notes([
            f"--records {records} made no record: the sweep was finished, and records are "
            "written as tasks are planned (stratplan plan a task's scenario for its record: "
            "its row in results.csv gives its values)"
        ])  # fmt: skip
    if json_output:
        render.print_json(outcome.summary)
    elif not quiet:
        summary(outcome.summary, outcome.out, loaded.source, again=again)
    if outcome.missing:
        render.error(
            "incomplete",
            f"{len(outcome.missing)} tasks have no row (their worker died); {again} plans them",
        )
    failed = sum(n for status, n in outcome.summary["counts"].items() if status != "ok")
    if strict and failed and not outcome.missing:  # (said, in a CI log, whatever --quiet)
        render.error("failed", f"{counted(failed, 'task')} did not plan (--strict)")
    raise typer.Exit(1 if outcome.missing or (strict and failed) else 0)


def _again_command(file: Path, out: Path, jobs, dask, records) -> str:
    """The command that resumes this sweep with the options it was given (quoted for a
    shell): --records too, or a resumed sweep would write the default records."""
    words = ["stratplan", "sweep", str(file), "--out", str(out), "--resume"]
    for flag, value in (("--jobs", jobs), ("--dask", dask), ("--records", records)):
        if value is not None:
            words += [flag, str(value)]
    return shlex.join(words)


@contextmanager
def _resume_hint(again: str, out: Path, count: int) -> Iterator[None]:
    """On Ctrl-C (or SIGTERM) during a sweep: how many rows it keeps and how to go on
    (`again`), before the `interrupted` line (a new user saw that word alone)."""
    from ..interrupts import Interrupted

    try:
        yield
    except Interrupted:
        from ..records.sweepdir import ROWS, read_rows

        if not out.is_dir():  # stopped before it began (connecting to a cluster, say)
            render.notes(["sweep: stopped before its first task; nothing written"], always=True)
            raise
        done = len(read_rows(out / ROWS))  # (a torn last row is planned again)
        rest = "plans the rest" if done < count else "writes its table, summary and plots"
        kept = f"sweep: {done} of {counted(count, 'task')} kept in {out}; {again} {rest}"
        render.notes([kept], always=True)  # (whatever --quiet: how to go on)
        raise


def summary(
    doc: dict[str, Any], path: Path, source: str = "", at: str | None = None, again=None
) -> None:
    """A sweep's summary (sweep.json, or computed from the rows of an unfinished one);
    `source`: the sweep file it was made from, as given (spec.json's), for the resume hint,
    which names it from here where its absolute path `at` is known and the file is there;
    `again`: the resume command itself, where the sweep that ran says it with its options."""
    say = render.say
    fmt = render.fmt
    say(f"[bold]sweep {escape(str(doc['name']))}[/] ({doc['mode']} mode, {doc['kind']}): "
        f"{doc['done']} of {counted(doc['tasks'], 'task')} done")  # fmt: skip
    counts = ", ".join(f"{n} {s}" for s, n in doc["counts"].items() if n)
    rate = doc.get("success_rate")
    say(f"  status   {counts or 'none'}" + (f"  (success {100 * rate:.1f} %)" if rate else ""))
    e = doc.get("energy") or {}
    if e.get("min") is not None:
        say(f"  energy   min {fmt(e['min'])}  median {fmt(e['median'])}  max {fmt(e['max'])}")
    best = doc.get("best")
    if best:
        inputs = ", ".join(f"{k} = {v:.6g}" if isinstance(v, float) else f"{k} = {v}"
                           for k, v in best["inputs"].items())  # fmt: skip
        seq = f" ({best['sequence']})" if best.get("sequence") else ""
        say(f"  best     task {best['index']}{seq}: energy {fmt(best['energy'])} at {inputs}")
    for kind in doc.get("failures") or []:  # (absent in sweeps written before it)
        say(f"  {'why' if kind is doc['failures'][0] else '':8} {_failure(kind)}")
    if doc.get("sequences") and doc["mode"] != "legs":
        shown = ", ".join(f"({k}) {n}" for k, n in doc["sequences"].items())
        say(f"  chosen   {shown}")
    ex = doc.get("executor")
    if ex:
        wall = doc.get("wall_time_s") or 0.0
        speed = doc.get("tasks_per_s")
        workers = counted(ex["workers"], "worker")
        now, done = doc.get("planned_this_run"), doc.get("done")
        earlier = done - now if isinstance(now, int) and isinstance(done, int) else 0
        rate = f" ({speed:.2f} tasks/s)" if speed else ""
        before = f"; {earlier} more from an earlier run (--resume)" if earlier > 0 else ""
        tasks = counted(now, "task") if isinstance(now, int) else f"{now} tasks"
        say(f"  ran on   {ex['kind']}, {workers}: {tasks} in {wall:.1f} s{rate}{before}")
    if doc.get("missing"):
        file = "FILE" if not source or source.startswith("<") else source  # "<dict>": Python
        if at is not None and Path(at).is_file():  # as given, it was relative to where it ran
            file = at if (here := os.path.relpath(at)).startswith("..") else here
        words = ["stratplan", "sweep", file, "--out", str(path), "--resume"]
        if ex and ex.get("kind") == "dask" and ex.get("address"):  # where it ran, not locally
            words += ["--dask", str(ex["address"])]
        again = again or shlex.join(words)
        say(f"  missing  {doc['missing']} tasks ({escape(again)})")
    for name in ("results.csv", *doc.get("plots", [])):
        if (Path(path) / name).exists():
            say(f"  file     {escape(str(Path(path) / name))}")
    if (Path(path) / "records").is_dir():
        n = sum(1 for p in (Path(path) / "records").iterdir() if not p.name.startswith("."))
        say(f"  records  {n} under {escape(str(Path(path) / 'records'))}")
    if doc.get("records_lost"):
        lost, first = len(doc["records_lost"]), doc["records_lost"][0]
        why = escape(first["reason"])
        say(f"  records  {lost} asked for could not be made (task {first['task']}: {why}; "
            "all in sweep.json records_lost)")  # fmt: skip


def _failure(kind: dict[str, Any], width: int = REASON_WIDTH) -> str:
    """One kind of failure of `summary`: how many tasks, the first one's message (on one
    line, cut at a word after `width` characters: each task's whole message is in
    results.csv, which it then says)."""
    more = kind["tasks"] - 1
    first = f"task {kind['first']}" + (f" and {more} more like it" if more else "")
    message = " ".join((kind["message"] or "(no message)").split())  # one line (a traceback's)
    cut = textwrap.shorten(message, width, placeholder=" … (in full: results.csv)")
    return f"{kind['tasks']} {kind['status']} ({first}): {escape(cut)}"


def show_sweep(path: Path, json_output: bool) -> None:
    """`stratplan show SWEEPDIR`."""
    from .. import api  # start-up speed

    with render.reported():
        report = api.read_sweep(path)
    if json_output:
        render.print_json(report.summary)
        return
    summary(report.summary, path, report.spec.get("source", ""), report.spec.get("source_path"))
    if not report.finished:
        say = render.say
        say("  (not finished: the counts are of the rows written so far)")
