"""Command line: thin glue between scenario files, the planner and the run records."""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from .compare import (
    CRITERIA,
    CRITERION_LABELS,
    auto_settings,
    compare_decomposition,
    decompose_task,
    default_jobs,
)
from .decompose import STRATEGIES, format_configuration, moved_coordinates, pi_fraction
from .errors import InputError, Problem
from .models.presets import PRESETS, preset
from .records.comparison import comparison_csv, comparison_document, ranking_png
from .records.manifest import manifest
from .records.result import result_document
from .records.run import record_files, write_record
from .records.store import list_records, mcap_summary, read_record
from .regress import DEFAULT_TOLERANCES, baseline_document, compare, load_baseline, summarise
from .scenario import LegEntry, Task, load_scenario
from .settings import DecomposeSettings
from .stratified import plan_sequence, time_scaled

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
            f"[bold red]error:[/] {escape(problem.render(exc.source))}",
            highlight=False,
            soft_wrap=True,
        )
    raise typer.Exit(2)


def _load(path: Path) -> Task:
    try:
        return load_scenario(path)
    except InputError as exc:
        _fail_input(exc)
        raise  # unreachable


def _manifest(task: Task, started: datetime, compile_s: float, planning_s: float, code: int):
    """manifest.json of a run started at `started` (UTC) that ends now with exit `code`."""
    timings = {
        "started": started.isoformat(),
        "finished": datetime.now(UTC).isoformat(),
        "compile_time_s": compile_s,
        "planning_time_s": planning_s,
    }
    return manifest(task.text, ["stratplan", *sys.argv[1:]], task.settings.seed, timings, code)


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
    time_scale: Annotated[
        float | None,
        typer.Option(
            min=1e-6,
            help="Run the planned path S times faster after planning (duration ÷ S, energy × S); "
            "overrides planner.time_scale.",
        ),
    ] = None,
    check_first: Annotated[
        bool,
        typer.Option(
            "--check/--no-check",
            help="First check that each leg's stratum spans what the leg steers (Lie brackets, "
            "paper eq. 4; as `stratplan check`).",
        ),
    ] = True,
) -> None:
    """Plan a scenario: every leg to tolerance, controls continuous across switches.

    Writes a run record under OUT and exits 0 (planned), 1 (a leg failed; the record is
    still written, marked failed), 2 (bad input) or 3 (the controllability check failed: a
    leg's stratum cannot steer what the leg asks for; nothing is planned or written).

    Auto mode: a scenario with a decompose table and no legs plans every candidate sequence
    (as compare-sequences does), records the best by the table's criterion and says why.
    """
    task = _load(file)
    check_time = time.perf_counter()
    if check_first:
        problems = _controllability_problems(task)
        for problem in problems:
            err_console.print(
                f"[bold red]not controllable:[/] {escape(problem)} (stratplan check "
                f"{escape(str(file))} shows the ranks; --no-check skips this)",
                highlight=False,
                soft_wrap=True,
            )
        if problems:
            raise typer.Exit(3)
    check_time = time.perf_counter() - check_time
    if not task.legs:  # auto mode: a [decompose] table and no [[legs]]
        _plan_auto_mode(task, out, json_output, quiet, animation)
    started = datetime.now(UTC)
    clock = time.perf_counter()
    for leg in task.legs:  # generate the numeric functions first: start-up, not planning
        task.system.compiled(leg.stratum)
    compile_time = time.perf_counter() - clock + check_time  # incl. the brackets of the check
    clock = time.perf_counter()
    result = plan_sequence(task.system, task.start, task.legs, task.settings)
    planning_time = time.perf_counter() - clock
    scale = time_scale if time_scale is not None else task.scenario.planner.time_scale
    if scale != 1.0:
        result = time_scaled(result, scale)
    reference = task.scenario.reference.energy if task.scenario.reference else None
    doc = result_document(result, task.scenario.name, task.model_name, reference)
    code = 0 if result.ok else 1
    info = _manifest(task, started, compile_time, planning_time, code)
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
    if doc.get("time_scale", 1.0) != 1.0:
        extras.append(f"time scale {doc['time_scale']:g}")
    basis = doc["legs"][0]["pieces"][0]["basis"] if doc["legs"] else None
    out_console.print(
        f"[bold]{doc['scenario']}[/] · model {doc['model']} · {doc['continuity']} · "
        f"objective {doc.get('objective', 'newton')}"
        f"{' · ' + ', '.join(x.replace('_', ' ') for x in extras) if extras else ''} · "
        f"tolerance {doc['tolerance']:g}"
        + (f" · H = {basis['harmonics']}, P = {basis['period']:g}" if basis else ""),
        highlight=False,
    )
    table = Table(show_edge=False)
    # Per-leg Newton iterations and starts describe the plan only when legs are planned one
    # by one; the energy objective optimises all legs together (its line below says how).
    per_leg = not (doc.get("optimisation") or {}).get("starts")
    counts = ("iterations", "starts") if per_leg else ()
    columns = ("leg", "stratum", "method", "evaluator", *counts, "final error")
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
            *((str(leg["iterations"]), str(leg["attempts"])) if per_leg else ()),
            f"{leg['error']:.2e}",
            _fmt(leg["energy"]),
            "[green]ok[/]" if leg["converged"] else "[red]failed[/]",
        )
    out_console.print(table)
    line = f"total energy [bold]{_fmt(doc['total_energy'])}[/]"
    ref = doc.get("reference_energy")
    scale = doc.get("time_scale", 1.0)
    if ref and scale != 1.0:  # the paper's legs last 1 s: compare the path at its own speed
        own = doc["total_energy"] / scale
        line += f" (at time scale 1: {_fmt(own)}; paper: {_fmt(ref)}, ratio {own / ref:.2f})"
    elif ref:
        line += f" (paper: {_fmt(ref)}, ratio {doc['total_energy'] / ref:.2f})"
    if doc["switches"]:
        worst = max(max(abs(v) for v in sw["jump"].values()) for sw in doc["switches"])
        line += f" · largest control jump at a switch {worst:.1e}"
    status = "[green]ok[/]" if doc["status"] == "ok" else "[red]failed[/]"
    out_console.print(f"{line} · status {status}", highlight=False)
    for note in doc.get("notes") or []:
        out_console.print(f"note: {escape(note)}", highlight=False)
    lie = [(i + 1, leg) for i, leg in enumerate(doc["legs"]) if leg["method"] == "lie"]
    for i, leg in lie:
        out_console.print(
            f"leg {i}: {len(leg['pieces'])} Lie-algebraic steps of "
            f"{leg['pieces'][0]['duration']:g} s (one piece each in result.json), "
            f"{leg['duration']:g} s in all",
            highlight=False,
        )
    opt = doc.get("optimisation")
    if opt and opt.get("best") is not None:
        best = opt["starts"][opt["best"]]
        energies = ", ".join(_fmt(s["energy"]) for s in opt["starts"])
        out_console.print(
            f"energy-optimal over all legs together: start {best['index'] + 1} of "
            f"{len(opt['starts'])} ({best['iterations']} SQP iterations"
            f"{', ' + best['stopped'] if best.get('stopped') else ''}, "
            f"projected gradient {best['projected_gradient']:.0e}); the starts ended at "
            f"{energies}; plain Newton: {_fmt(opt['newton_energy'])}"
            + (" (energies before time scaling)" if scale != 1.0 else ""),
            highlight=False,
        )


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
    log = mcap_summary(record.path)
    if json_output:
        doc = {"result": record.result, "manifest": record.manifest, "mcap": log}
        print(json.dumps(doc, indent=2))
        return
    _print_summary(record.result)
    if log:
        topics = ", ".join(f"{t} {n}" for t, n in log["topics"].items())
        out_console.print(
            f"run.mcap: {log['messages']} messages over {log['duration_s']:.2f} s ({topics})",
            highlight=False,
        )
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
    if not diffs:
        out_console.print(
            f"[green]no regressions[/]: all {len(now)} scenarios match {baseline} "
            f"(energy within {tolerances['energy_rel']:g} relative, errors within "
            f"{tolerances['error_abs']:g})",
            highlight=False,
        )
    else:
        verdict = "[red]regressions[/]" if bad else "[green]no regressions[/]"
        out_console.print(
            f"{verdict}: {bad} of {len(diffs)} differences are regressions", highlight=False
        )
    raise typer.Exit(1 if bad else 0)


def _show(x) -> str:
    return f"{x:.6g}" if isinstance(x, float) else str(x)


MaxLengthOption = Annotated[
    int | None,
    typer.Option(
        "--max-length", help="Longest sequence of strata (default: decompose table, else 3).", min=1
    ),
]
JsonOption = Annotated[bool, typer.Option("--json", help="Machine-readable output.")]
StrategyOption = Annotated[
    str | None,
    typer.Option(
        help="conservative | postponed | both (default: decompose table, else conservative)."
    ),
]


def _auto(task: Task, max_length, strategy, criterion=None):
    """[decompose] settings with command-line overrides; bad option values exit 2."""
    problems = []
    if strategy is not None and strategy not in (*STRATEGIES, "both"):
        problems.append(
            Problem("--strategy", f"must be conservative, postponed or both (got {strategy!r})")
        )
    if criterion is not None and criterion not in CRITERIA:
        problems.append(
            Problem("--criterion", f"must be one of {', '.join(CRITERIA)} (got {criterion!r})")
        )
    if max_length is not None and max_length > 8:
        problems.append(Problem("--max-length", f"must be at most 8 (got {max_length})"))
    if problems:
        _fail_input(InputError(problems))
    auto = auto_settings(task, max_length=max_length, strategy=strategy, criterion=criterion)
    try:
        return auto, decompose_task(task, auto)
    except InputError as exc:
        _fail_input(exc)
        raise  # unreachable


def _via_cell(goal) -> str:
    """A via as fractions of π where exact, then in radians (dim) if that differs."""
    exact, plain = format_configuration(goal, "pi"), format_configuration(goal, "rad")
    return exact if exact == plain else f"{exact}\n[dim]{plain}[/]"


@app.command("decompose")
def decompose_command(
    file: Annotated[Path, typer.Argument(help="Scenario file (TOML); its start and goal.")],
    max_length: MaxLengthOption = None,
    strategy: StrategyOption = None,
    json_output: JsonOption = False,
) -> None:
    """List the candidate sequences of strata and their via configurations, without planning.

    Essential coordinates are those whose goal differs from the start; a sequence qualifies
    when its strata together move all of them (no stratum twice in a row). `conservative`
    sets every essential coordinate a leg can move to its goal value; `postponed` leaves it to
    the last leg that can move it. Coordinates a leg's stratum locks keep their value.
    """
    task = _load(file)
    _, dec = _auto(task, max_length, strategy)
    system = task.system
    rows = []
    for k, cand in enumerate(dec.candidates):
        rows.append(
            {
                "index": k + 1,
                "sequence": list(cand.sequence),
                "strategy": cand.strategy,
                "vias": [[None if x != x else float(x) for x in v] for v in cand.vias],
                "vias_pi": [[pi_fraction(float(x)) for x in v] for v in cand.vias],
                "loops": list(cand.redundant_legs(task.start)),
            }
        )
    if json_output:
        doc = {
            "scenario": task.scenario.name,
            "coordinates": list(system.states),
            "essential": [system.states[i] for i in dec.essential],
            "candidate_strata": list(dec.candidates_strata),
            "max_length": dec.max_length,
            "strategies": list(dec.strategies),
            "sequences": rows,
        }
        print(json.dumps(doc, indent=2))
        return
    out_console.print(
        f"[bold]{task.scenario.name}[/] · model {task.model_name} · "
        f"start {format_configuration(task.start)} → goal {format_configuration(task.goal)} "
        "(angles in rad; π fractions where exact)",
        highlight=False,
    )
    out_console.print(
        f"essential coordinates: {', '.join(system.states[i] for i in dec.essential)} "
        f"({len(dec.essential)} of {system.n})",
        highlight=False,
    )
    moves = [
        f"{s} moves {', '.join(system.states[i] for i in moved_coordinates(system, s))}"
        for s in dec.candidates_strata
    ]
    out_console.print(f"candidate strata: {'; '.join(moves)}", highlight=False)
    table = Table(show_edge=False, show_lines=True)
    table.add_column("#", justify="right")
    table.add_column("sequence")
    table.add_column("strategy")
    vias = max(len(c.legs) for c in dec.candidates) - 1
    for v in range(vias):
        table.add_column(f"via {v + 1}" if vias > 1 else "via")
    table.add_column("loop legs")
    for row, cand in zip(rows, dec.candidates, strict=True):
        cells = [_via_cell(leg.goal) for leg in cand.legs[:-1]]
        table.add_row(
            str(row["index"]),
            " → ".join(cand.sequence),
            cand.strategy,
            *cells,
            *([""] * (vias - len(cells))),
            ", ".join(map(str, row["loops"])) or "–",
        )
    out_console.print(table)
    n, k = len(dec.sequences), len(dec.candidates)
    out_console.print(
        f"{n} sequence{'s' * (n != 1)} of at most {dec.max_length} strata × "
        f"{' and '.join(dec.strategies)} = {k} candidate{'s' * (k != 1)}; a loop leg's goal "
        f"is its start. Plan and rank them: stratplan compare-sequences {file}",
        highlight=False,
    )


def _progress(total: int, enabled: bool):
    """A progress bar on stderr, refreshed by hand: no refresh thread while workers fork."""
    return Progress(
        TextColumn("planning sequences"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=err_console,
        auto_refresh=False,
        transient=True,
        disable=not enabled,
    )


def _run_comparison(task: Task, auto, dec, jobs: int, show_progress: bool):
    try:
        with _progress(len(dec.candidates), show_progress) as bar:
            job = bar.add_task("plan", total=len(dec.candidates))

            def advance(k: int) -> None:
                bar.update(job, advance=k)
                bar.refresh()

            return compare_decomposition(task, auto, dec, jobs=jobs, progress=advance)
    except InputError as exc:
        _fail_input(exc)


def _comparison_record(task: Task, auto, dec, comparison, compile_time, started, out, animation):
    """Write the best sequence's full run record plus comparison.json/csv and ranking.png."""
    best = comparison.best
    settings = {
        k: getattr(task.settings, k)
        for k in ("continuity", "soft_start", "full_stop", "tolerance", "seed", "objective")
        if hasattr(task.settings, k)
    }
    doc = comparison_document(
        comparison,
        dec,
        scenario=task.scenario.name,
        model=task.model_name,
        states=task.system.states,
        start=task.start,
        goal=task.goal,
        settings=settings,
        compile_time=compile_time,
    )
    strategy = "both" if len(auto.strategies) > 1 else auto.strategies[0]
    entries = [
        LegEntry(stratum=leg.stratum, method=leg.method, goal=list(leg.goal), duration=leg.duration)
        for leg in best.candidate.legs
    ]
    scenario = task.scenario.model_copy(
        update={
            "legs": entries,
            "decompose": DecomposeSettings(
                max_length=auto.max_length,
                strategy=strategy,
                criterion=auto.criterion,
                strata=tuple(auto.strata) if auto.strata else None,
            ),
        }
    )
    best_task = dataclasses.replace(task, scenario=scenario, legs=list(best.candidate.legs))
    reference = task.scenario.reference.energy if task.scenario.reference else None
    result = result_document(best.plan, task.scenario.name, task.model_name, reference)
    code = 0 if best.ok else 1
    info = _manifest(task, started, compile_time, comparison.wall_time, code)
    files = record_files(best_task, best.plan, result, info, animation)
    files["comparison.json"] = doc
    files["comparison.csv"] = comparison_csv(doc)
    files["ranking.png"] = ranking_png(doc)
    run_dir = write_record(out, best_task, files, started)
    return doc, result, run_dir, code


def _footer(comparison, compile_time, run_dir) -> None:
    saved = (
        f"legs planned {comparison.legs_planned} of {comparison.legs_requested} "
        f"({comparison.legs_saved} shared)"
        if comparison.shared
        else f"legs planned {comparison.legs_planned} of {comparison.legs_requested}"
    )
    out_console.print(
        f"{saved} · {len(comparison.outcomes)} sequences in {comparison.wall_time:.2f} s on "
        f"{comparison.jobs} process{'es' if comparison.jobs > 1 else ''} (model compiled in "
        f"{compile_time * 1e3:.0f} ms) · record: {run_dir}",
        highlight=False,
    )


@app.command("compare-sequences")
def compare_sequences(
    file: Annotated[Path, typer.Argument(help="Scenario file (TOML); its start and goal.")],
    max_length: MaxLengthOption = None,
    strategy: StrategyOption = None,
    criterion: Annotated[
        str | None,
        typer.Option(
            help="energy | peak-control | excursion | duration "
            "(default: decompose table, else energy)."
        ),
    ] = None,
    jobs: Annotated[
        int | None, typer.Option(help="Worker processes (default: all cores).", min=1)
    ] = None,
    out: Annotated[Path, typer.Option(help="Directory for run records.")] = Path("runs"),
    json_output: Annotated[
        bool, typer.Option("--json", help="Print comparison.json instead of tables.")
    ] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="Print nothing but errors.")] = False,
    animation: Annotated[
        bool, typer.Option("--animation/--no-animation", help="Write the best's motion.gif.")
    ] = True,
) -> None:
    """Plan every candidate sequence in parallel (Newton: shared prefixes once) and rank them.

    Ranked by the criterion among the sequences that reached the goal (ties: lower energy);
    failed sequences stay in the table with their reason. The record holds the best
    sequence's full run record plus comparison.json, comparison.csv and ranking.png. Exits 0
    when some sequence reached the goal, 1 when none did, 2 on bad input.
    """
    task = _load(file)
    auto, dec = _auto(task, max_length, strategy, criterion)
    started = datetime.now(UTC)
    interactive = not (quiet or json_output) and err_console.is_terminal
    comparison, compile_time = _run_comparison(task, auto, dec, jobs or default_jobs(), interactive)
    doc, _, run_dir, code = _comparison_record(
        task, auto, dec, comparison, compile_time, started, out, animation
    )
    if json_output:
        print(json.dumps(doc, indent=2))
    elif not quiet:
        _print_ranking(task, auto, doc)
        out_console.print(f"best: {comparison.choice()}", highlight=False)
        _footer(comparison, compile_time, run_dir)
    if code:
        err_console.print(
            f"[bold red]no sequence reached the goal:[/] {comparison.choice()}",
            highlight=False,
            soft_wrap=True,
        )
    raise typer.Exit(code)


def _print_ranking(task: Task, auto, doc: dict) -> None:
    s = task.settings
    out_console.print(
        f"[bold]{doc['scenario']}[/] · model {doc['model']} · {s.continuity} · objective "
        f"{getattr(s, 'objective', 'newton')} · tolerance {s.tolerance:g} · essential "
        f"{', '.join(doc['essential'])} · {doc['sequences']} "
        f"sequences (max length {doc['max_length']}, {' + '.join(doc['strategies'])}) · "
        f"ranked by {CRITERION_LABELS[doc['criterion']]}",
        highlight=False,
    )
    table = Table(show_edge=False)
    columns = ("rank", "sequence", "strategy", "status", "energy", "peak |u|")
    for col in (*columns, "max excursion", "duration", "planning ms"):
        table.add_column(
            col,
            justify="left" if col in columns[1:4] else "right",
            no_wrap=col in ("sequence", "strategy"),
        )
    for row in doc["rows"]:
        ok = row["status"] == "ok"
        style = "bold green" if ok and row["rank"] == 1 else None

        def num(x, fmt="{:,.2f}"):
            return "–" if x is None else fmt.format(x)

        table.add_row(
            str(row["rank"]),
            " → ".join(row["sequence"]),
            row["strategy"],
            "ok" if ok else f"[red]failed[/]: {escape(row['reason'])}",
            num(row["energy"]) if ok else "–",
            num(row["peak_control"]) if ok else "–",
            num(row["excursion"], "{:.3f}") if ok else "–",
            num(row["duration"], "{:g}"),
            f"{1e3 * row['planning_time_s']:.0f}",
            style=style,
        )
    out_console.print(table)


def _plan_auto_mode(task: Task, out: Path, json_output: bool, quiet: bool, animation: bool):
    """`plan` on a scenario without legs: compare the candidates, record and show the best."""
    auto, dec = _auto(task, None, None)
    started = datetime.now(UTC)
    interactive = not (quiet or json_output) and err_console.is_terminal
    comparison, compile_time = _run_comparison(task, auto, dec, default_jobs(), interactive)
    _, result, run_dir, code = _comparison_record(
        task, auto, dec, comparison, compile_time, started, out, animation
    )
    if json_output:
        print(json.dumps(result, indent=2))
    elif not quiet:
        out_console.print(
            f"auto mode: {len(comparison.outcomes)} candidate sequences (max length "
            f"{auto.max_length}, {' + '.join(auto.strategies)}) planned; chose "
            f"{comparison.choice()}",
            highlight=False,
        )
        _print_summary(result)
        _footer(comparison, compile_time, run_dir)
        out_console.print(
            f"the full ranking: comparison.csv in the record, or stratplan compare-sequences "
            f"{task.source}",
            highlight=False,
        )
    if code:
        err_console.print(
            f"[bold red]planning failed:[/] {comparison.choice()}",
            highlight=False,
            soft_wrap=True,
        )
    raise typer.Exit(code)


def _check_target(target: str, at: str | None):
    """(system, strata, configuration, legs, title) for a preset name or a scenario file."""
    from .models.expressions import parse_number

    if target in PRESETS and not Path(target).exists():
        system, legs, title = preset(target), None, f"preset {target}"
        strata, q = list(system.strata), [0.0] * system.n
        source = "--at"
    else:
        task = _load(Path(target))
        system, legs = task.system, task.legs or None
        if legs:
            strata = list(dict.fromkeys(leg.stratum for leg in legs))
        elif task.scenario.decompose and task.scenario.decompose.strata:
            strata = list(task.scenario.decompose.strata)
        else:
            strata = list(system.strata)
        q, source = list(task.start), "--at"
        title = f"{task.scenario.name} ({task.model_name} model)"
    if at is not None:
        try:
            values = [parse_number(x.strip()) for x in at.strip("()[] ").split(",")]
        except (ValueError, TypeError) as exc:
            _fail_input(InputError([Problem(source, f"not a configuration: {exc}")]))
        if len(values) != system.n:
            _fail_input(
                InputError(
                    [
                        Problem(
                            source,
                            f"needs {system.n} values ({', '.join(system.states)}), "
                            f"got {len(values)}",
                        )
                    ]
                )
            )
        q = values
    return system, strata, q, legs, title


def _controllability_problems(task: Task, degree: int = 2, samples: int = 100) -> list[str]:
    """The check `plan` runs first: each leg's stratum spans what the leg steers (or, in auto
    mode, the candidate strata together reach every direction)."""
    from .controllability import check_document

    degree = max([degree] + [(leg.lie or task.settings.lie).degree for leg in task.legs if
                             leg.method == "lie"])  # fmt: skip
    if task.legs:
        strata = list(dict.fromkeys(leg.stratum for leg in task.legs))
    elif task.scenario.decompose and task.scenario.decompose.strata:
        strata = list(task.scenario.decompose.strata)
    else:
        strata = list(task.system.strata)
    doc = check_document(
        task.system,
        strata,
        task.start,
        samples=samples,
        degree=degree,
        legs=task.legs or None,
    )
    return doc["problems"]


@app.command()
def check(
    target: Annotated[str, typer.Argument(help="Scenario file (TOML) or preset model name.")],
    at: Annotated[
        str | None,
        typer.Option(
            help='Configuration, e.g. "0, pi/3, 0, 0" (default: the scenario start, or zeros '
            "for a preset)."
        ),
    ] = None,
    samples: Annotated[int, typer.Option(min=0, help="Sampled configurations.")] = 100,
    degree: Annotated[int, typer.Option(min=1, max=3, help="Lie bracket degree (1-3).")] = 2,
    seed: Annotated[int, typer.Option(min=0, help="Seed of the sampled configurations.")] = 0,
    json_output: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """Controllability of every stratum (paper eq. 4) and of the strata together (eq. 2).

    Per stratum: the rank of its generators and Lie brackets (up to DEGREE, on its free
    coordinates) and their smallest singular value, at the configuration and at SAMPLES
    sampled ones; where DEGREE falls short, third-order brackets are tried. For a scenario,
    also whether each leg's stratum spans the coordinates the leg steers. Exits 0, 2 on bad
    input, 3 when the scenario's strata cannot do their legs (or the strata of a model or an
    auto-mode scenario do not reach every direction together), naming stratum and
    configuration.
    """
    from .controllability import check_document

    system, strata, q, legs, title = _check_target(target, at)
    clock = time.perf_counter()
    doc = check_document(system, strata, q, samples=samples, degree=degree, seed=seed, legs=legs)
    seconds = time.perf_counter() - clock
    doc["target"] = target
    if json_output:
        print(json.dumps(doc, indent=2))
    else:
        _print_check(doc, title, seconds)
    for problem in doc["problems"]:
        err_console.print(
            f"[bold red]not controllable:[/] {escape(problem)}", highlight=False, soft_wrap=True
        )
    raise typer.Exit(0 if doc["controllable"] else 3)


def _print_check(doc: dict, title: str, seconds: float) -> None:
    out_console.print(
        f"[bold]{escape(title)}[/] · generators and Lie brackets up to degree {doc['degree']} · "
        f"at q = {format_configuration(doc['at'])} and {doc['samples']} sampled "
        f"configurations (seed {doc['seed']})",
        highlight=False,
    )
    table = Table(show_edge=False)
    for col in ("stratum", "dim", "rank at q", "σ_min at q", "min rank, σ_min (q + samples)"):
        table.add_column(col, justify="left" if col == "stratum" else "right")
    table.add_column("spanning at q")
    table.add_column("eq. 4")
    notes = []
    for s in doc["strata"]:
        rank = f"{s['rank_at']}"
        escalated = s["degree_at"] != doc["degree"] and s["rank_at"] == s["dimension"]
        if escalated:
            rank += " (deg 3)"
            notes.append(
                f"{s['stratum']}: at q the brackets up to degree {doc['degree']} have rank "
                f"{s['rank_at_requested_degree']}; third-order brackets span"
            )
        if s["third_order_needed"] > int(escalated):
            notes.append(
                f"{s['stratum']}: degree {doc['degree']} falls short at "
                f"{s['third_order_needed'] - int(escalated)} sampled configuration(s), "
                "third order spans there"
            )
        table.add_row(
            s["stratum"],
            str(s["dimension"]),
            rank,
            f"{s['sigma_min_at']:.1e}",
            f"{s['min_rank']}, {s['min_sigma']:.1e}",
            escape(", ".join(s["spanning_at"])),
            "[green]strong[/]" if s["strong"] else "[red]no[/]",
        )
    out_console.print(table)
    for note in notes:
        out_console.print(f"note: {escape(note)}", highlight=False)
    eq2 = doc["eq2"]
    line = (
        f"eq. 2 ({' + '.join(eq2['strata'])}, each stratum's closure): rank "
        f"{eq2['sum_min_rank']} of {eq2['n']}"
    )
    if eq2["holds"]:
        line += " at q and every sample: [green]holds[/]"
    else:
        line += (
            f" — [red]falls short[/]; with brackets across strata (switching between them): "
            f"rank {eq2['cross_min_rank']} of {eq2['n']}"
        )
        if eq2["by_switching"]:
            extra = [x for x in eq2["cross_spanning_at"] if x.startswith("[")]
            line += " ([green]holds[/]" + (f"; needs {escape(', '.join(extra))})" if extra else ")")
    out_console.print(line, highlight=False)
    if doc["legs"] is not None:
        for leg in doc["legs"]:
            steers = ", ".join(leg["steers"]) or "nothing"
            mark = "[green]spanned[/]" if leg["ok"] else "[red]NOT spanned[/]"
            out_console.print(
                f"leg {leg['leg']} on {leg['stratum']} steers {steers}: rank {leg['rank']}, "
                f"σ_min {leg['sigma_min']:.1e} at its start "
                f"{format_configuration(leg['configuration'])}: {mark}",
                highlight=False,
            )
    weak = [s["stratum"] for s in doc["strata"] if not s["strong"]]
    verdict = (
        "strongly controllable on every stratum (eq. 4)"
        if not weak
        else f"not strongly controllable on {', '.join(weak)} (eq. 4)"
    )
    verdict += (
        "; stratified controllable (eq. 2" + (")" if eq2["holds"] else ", by switching)")
        if doc["stratified_controllable"]
        else "; [red]not stratified controllable[/] (eq. 2)"
    )
    if doc["legs"] is not None:
        verdict += (
            "; every leg's stratum spans the coordinates it steers"
            if all(leg["ok"] for leg in doc["legs"])
            else "; [red]some legs cannot be planned[/]"
        )
    out_console.print(f"verdict: {verdict} · {seconds * 1e3:.0f} ms", highlight=False)
