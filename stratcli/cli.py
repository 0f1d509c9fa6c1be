"""Command line: thin glue between scenario files, the planner and the run records."""

from __future__ import annotations

import json
import sys
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from .errors import InputError
from .models.presets import PRESETS, preset
from .records.manifest import manifest
from .records.result import result_document
from .records.run import record_files, write_record
from .records.store import list_records, read_record
from .regress import DEFAULT_TOLERANCES, baseline_document, compare, load_baseline, summarise
from .scenario import Task, load_scenario
from .stratified import plan_sequence

app = typer.Typer(
    name="stratplan",
    help="Motion planning for stratified nonholonomic systems (free-floating manipulators).",
    no_args_is_help=True,
    pretty_exceptions_show_locals=False,
    add_completion=False,
)
out_console = Console()
err_console = Console(stderr=True)


def _fail_input(exc: InputError) -> None:
    for problem in exc.problems:
        err_console.print(
            f"[bold red]error:[/] {problem.render(exc.source)}", highlight=False, soft_wrap=True
        )
    raise typer.Exit(2)


def _load(path: Path) -> Task:
    try:
        return load_scenario(path)
    except InputError as exc:
        _fail_input(exc)
        raise  # unreachable


def _fmt(x: float) -> str:
    return f"{x:,.2f}" if abs(x) < 1e6 else f"{x:.3e}"


@app.command()
def plan(
    file: Annotated[Path, typer.Argument(help="Scenario file (TOML).")],
    out: Annotated[Path, typer.Option(help="Directory for run records.")] = Path("runs"),
    json_output: Annotated[
        bool, typer.Option("--json", help="Print result.json to stdout instead of tables.")
    ] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="Print nothing but errors.")] = False,
    animation: Annotated[
        bool, typer.Option("--animation/--no-animation", help="Write motion.gif.")
    ] = True,
) -> None:
    """Plan a scenario: every leg to tolerance, controls continuous across switches.

    Writes a run record under OUT and exits 0 (planned), 1 (a leg failed; the record is
    still written, marked failed) or 2 (bad input).
    """
    task = _load(file)
    started = datetime.now(UTC)
    clock = time.perf_counter()
    for leg in task.legs:  # generate the numeric functions first: start-up, not planning
        task.system.compiled(leg.stratum)
    compile_time = time.perf_counter() - clock
    clock = time.perf_counter()
    result = plan_sequence(task.system, task.start, task.legs, task.settings)
    planning_time = time.perf_counter() - clock
    reference = task.scenario.reference.energy if task.scenario.reference else None
    doc = result_document(result, task.scenario.name, task.model_name, reference)
    code = 0 if result.ok else 1
    info = manifest(
        task.text,
        ["stratplan", *sys.argv[1:]],
        task.settings.seed,
        {
            "started": started.isoformat(),
            "finished": datetime.now(UTC).isoformat(),
            "compile_time_s": compile_time,
            "planning_time_s": planning_time,
        },
        code,
    )
    files = record_files(task, result, doc, info, animation)
    run_dir = write_record(out, task, files, started)
    if json_output:
        print(json.dumps(doc, indent=2))
    elif not quiet:
        _print_summary(doc)
        out_console.print(
            f"planned in {planning_time * 1e3:.0f} ms (model compiled in "
            f"{compile_time * 1e3:.0f} ms) · record: {run_dir}",
            highlight=False,
        )
    if code:
        err_console.print(
            f"[bold red]planning failed:[/] {result.message}", highlight=False, soft_wrap=True
        )
    raise typer.Exit(code)


def _print_summary(doc: dict) -> None:
    """Header, one row per leg, total energy beside the paper's: from result.json alone."""
    extras = [x for x in ("soft_start", "full_stop") if doc.get(x)]
    basis = doc["legs"][0]["pieces"][0]["basis"] if doc["legs"] else None
    out_console.print(
        f"[bold]{doc['scenario']}[/] · model {doc['model']} · {doc['continuity']}"
        f"{' · ' + ', '.join(x.replace('_', ' ') for x in extras) if extras else ''} · "
        f"tolerance {doc['tolerance']:g}"
        + (f" · H = {basis['harmonics']}, P = {basis['period']:g}" if basis else ""),
        highlight=False,
    )
    table = Table(show_edge=False)
    columns = ("leg", "stratum", "method", "evaluator", "iterations", "starts", "final error")
    for col in (*columns, "energy", "status"):
        table.add_column(
            col, justify="left" if col in ("stratum", "method", "evaluator", "status") else "right"
        )
    for i, leg in enumerate(doc["legs"]):
        table.add_row(
            str(i + 1),
            leg["stratum"],
            leg["method"],
            leg["evaluator"],
            str(leg["iterations"]),
            str(leg["attempts"]),
            f"{leg['error']:.2e}",
            _fmt(leg["energy"]),
            "[green]ok[/]" if leg["converged"] else "[red]failed[/]",
        )
    out_console.print(table)
    line = f"total energy [bold]{_fmt(doc['total_energy'])}[/]"
    ref = doc.get("reference_energy")
    if ref:
        line += f" (paper: {_fmt(ref)}, ratio {doc['total_energy'] / ref:.2f})"
    if doc["switches"]:
        worst = max(max(abs(v) for v in sw["jump"].values()) for sw in doc["switches"])
        line += f" · largest control jump at a switch {worst:.1e}"
    status = "[green]ok[/]" if doc["status"] == "ok" else "[red]failed[/]"
    out_console.print(f"{line} · status {status}", highlight=False)


@app.command()
def show(
    run: Annotated[Path, typer.Argument(help="Run directory (as printed by plan).")],
    json_output: Annotated[bool, typer.Option("--json", help="Print result.json.")] = False,
) -> None:
    """Show a run record (read back from its files, not re-planned)."""
    try:
        record = read_record(run)
    except InputError as exc:
        _fail_input(exc)
    if json_output:
        print(json.dumps({"result": record.result, "manifest": record.manifest}, indent=2))
        return
    _print_summary(record.result)
    m = record.manifest
    out_console.print(
        f"run {record.path.name} · started {m.get('started', '?')} · planning "
        f"{1e3 * m.get('planning_time_s', float('nan')):.0f} ms · stratplan {m.get('stratplan')} · "
        f"exit code {m.get('exit_code')}",
        highlight=False,
    )
    files = sorted(p.name for p in record.path.iterdir())
    out_console.print(f"files: {', '.join(files)}", highlight=False)


@app.command()
def runs(
    out: Annotated[Path, typer.Option(help="Directory of run records.")] = Path("runs"),
    json_output: Annotated[bool, typer.Option("--json", help="Machine-readable list.")] = False,
) -> None:
    """List run records, newest first: time, scenario, status, energy."""
    records = list_records(out)
    rows = [
        {
            "run": r.path.name,
            "started": r.started,
            "scenario": r.result.get("scenario"),
            "status": r.result.get("status"),
            "total_energy": r.result.get("total_energy"),
        }
        for r in records
    ]
    if json_output:
        print(json.dumps(rows, indent=2))
        return
    if not rows:
        out_console.print(f"no run records in {out}")
        return
    table = Table(show_edge=False)
    for col in ("started (UTC)", "scenario", "status", "energy", "run"):
        table.add_column(col, justify="right" if col == "energy" else "left")
    for row in rows:
        table.add_row(
            row["started"][:19].replace("T", " "),
            str(row["scenario"]),
            "[green]ok[/]" if row["status"] == "ok" else "[red]failed[/]",
            _fmt(row["total_energy"]),
            row["run"],
        )
    out_console.print(table)


@app.command()
def models(
    file: Annotated[
        Path | None, typer.Argument(help="Scenario file: describe its model instead.")
    ] = None,
) -> None:
    """List the preset models, or describe the model of a scenario file.

    For a scenario: coordinates, inputs and every stratum with its locked coordinates, active
    inputs, dimension and the end-point evaluator `auto` will use on it.
    """
    if file is None:
        table = Table(show_edge=False)
        for col in ("preset", "coordinates", "inputs", "strata", "description"):
            table.add_column(col)
        for name in PRESETS:
            system = preset(name)
            table.add_row(
                name,
                ", ".join(system.states),
                ", ".join(system.inputs),
                ", ".join(system.strata),
                system.description,
            )
        out_console.print(table)
        return
    task = _load(file)
    system = task.system
    out_console.print(
        f"[bold]{task.model_name}[/] model of {task.scenario.name}"
        f"{': ' + system.description if system.description else ''}",
        highlight=False,
    )
    out_console.print(f"coordinates: {', '.join(system.states)}", highlight=False)
    out_console.print(f"inputs: {', '.join(system.inputs)}", highlight=False)
    table = Table(show_edge=False)
    for col in ("stratum", "locked", "active inputs", "dimension", "auto evaluator"):
        table.add_column(col)
    for s in system.strata.values():
        cs = system.compiled(s)
        table.add_row(
            s.name,
            ", ".join(system.states[i] for i in s.locked) or "–",
            ", ".join(system.inputs[j] for j in s.active),
            str(system.n - len(s.locked)),
            "quadrature" if cs.supports_quadrature else "ode",
        )
    out_console.print(table)
    if task.settings.evaluator != "auto":
        out_console.print(f"this scenario asks for the {task.settings.evaluator} evaluator")


@app.command()
def regress(
    directory: Annotated[Path, typer.Argument(help="Directory of scenario files.")] = Path(
        "scenarios"
    ),
    baseline: Annotated[Path, typer.Option(help="Baseline JSON file.")] = Path(
        "scenarios/baseline.json"
    ),
    update: Annotated[bool, typer.Option(help="Rewrite the baseline from this run.")] = False,
) -> None:
    """Plan every scenario in DIRECTORY and compare with a baseline; exit 1 on a regression.

    Compared: status, each leg's final error and the total energy, with the tolerances stored
    in the baseline file (`energy_rel`, `error_abs`).
    """
    paths = sorted(directory.glob("*.toml"))
    if not paths:
        _fail_input(InputError(f"no scenario files (*.toml) in {directory}"))
    old, tolerances = ({}, dict(DEFAULT_TOLERANCES))
    if not update or baseline.exists():
        try:
            old, tolerances = load_baseline(baseline)
        except InputError as exc:
            if not update:
                _fail_input(exc)
    now = {}
    for path in paths:
        try:
            now[path.stem] = summarise(path)
        except InputError as exc:
            _fail_input(exc)
    diffs = compare(now, old, tolerances)
    if update:
        baseline.write_text(json.dumps(baseline_document(now, tolerances), indent=2) + "\n")
        out_console.print(f"baseline {baseline} written: {len(now)} scenarios")
        return
    table = Table(show_edge=False, title=f"{len(now)} scenarios against {baseline}")
    for col in ("scenario", "quantity", "baseline", "now", "verdict"):
        table.add_column(col)
    for d in diffs:
        table.add_row(
            d.scenario,
            d.quantity,
            _show(d.baseline),
            _show(d.now),
            "[red]regression[/]" if d.regression else "[yellow]changed[/]",
        )
    if diffs:
        out_console.print(table)
    bad = sum(d.regression for d in diffs)
    verdict = "[red]regressions[/]" if bad else "[green]no regressions[/]"
    out_console.print(f"{verdict}: {bad} of {len(diffs)} differences", highlight=False)
    raise typer.Exit(1 if bad else 0)


def _show(x) -> str:
    return f"{x:.6g}" if isinstance(x, float) else str(x)


def main() -> None:  # pragma: no cover - entry point for `python -m stratcli`
    app()
