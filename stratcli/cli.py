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
from .records.rundir import run_name, write_run
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
    files = {
        "scenario.toml": task.text,
        "result.json": doc,
        "manifest.json": manifest(
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
        ),
    }
    run_dir = write_run(out, run_name(task.scenario.name, task.text, started), files)
    if json_output:
        print(json.dumps(doc, indent=2))
    elif not quiet:
        _print_plan(task, doc, planning_time, compile_time, run_dir)
    if code:
        err_console.print(
            f"[bold red]planning failed:[/] {result.message}", highlight=False, soft_wrap=True
        )
    raise typer.Exit(code)


def _print_plan(task: Task, doc: dict, planning: float, compiling: float, run_dir: Path) -> None:
    s = task.settings
    extras = [x for x, on in (("soft start", s.soft_start), ("full stop", s.full_stop)) if on]
    out_console.print(
        f"[bold]{task.scenario.name}[/] · model {doc['model']} · {s.continuity}"
        f"{' · ' + ', '.join(extras) if extras else ''} · tolerance {s.tolerance:g} · "
        f"H = {s.basis.harmonics}, P = {s.basis.period:g}",
        highlight=False,
    )
    table = Table(show_edge=False)
    for col, just in (
        ("leg", "right"),
        ("stratum", "left"),
        ("method", "left"),
        ("evaluator", "left"),
        ("iterations", "right"),
        ("starts", "right"),
        ("final error", "right"),
        ("energy", "right"),
        ("status", "left"),
    ):
        table.add_column(col, justify=just)
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
    ref = doc["reference_energy"]
    if ref:
        line += f" (paper: {_fmt(ref)}, ratio {doc['total_energy'] / ref:.2f})"
    if doc["switches"]:
        worst = max(max(abs(v) for v in sw["jump"].values()) for sw in doc["switches"])
        line += f" · largest control jump at a switch {worst:.1e}"
    out_console.print(line, highlight=False)
    out_console.print(
        f"planned in {planning * 1e3:.0f} ms (model compiled in {compiling * 1e3:.0f} ms) · "
        f"record: {run_dir}",
        highlight=False,
    )


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


def main() -> None:  # pragma: no cover - entry point for `python -m stratcli`
    app()
