"""Rich rendering: tables and messages of the commands; nothing here plans or validates."""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from ..errors import InputError, NotControllableError, RecordError

out_console = Console()
err_console = Console(stderr=True)


def say(text: str) -> None:
    """One line on stdout; rich markup allowed, no highlighting."""
    out_console.print(text, highlight=False)


def error(label: str, message: str) -> None:
    """`label: message` on stderr, label in bold red (message is plain text)."""
    err_console.print(f"[bold red]{label}:[/] {escape(message)}", highlight=False, soft_wrap=True)


def print_json(doc: Any) -> None:
    print(json.dumps(doc, indent=2))


@contextmanager
def reported(scenario: Path | None = None) -> Iterator[None]:
    """Map errors to exit codes: bad input 2, not controllable 3 (naming `scenario`), a
    record that could not be written 4."""
    try:
        yield
    except InputError as exc:
        for problem in exc.problems:
            error("error", problem.render(exc.source))
        raise typer.Exit(2) from None
    except NotControllableError as exc:
        for problem in exc.problems:
            error(
                "not controllable",
                f"{problem} (stratplan check {scenario} shows the ranks; --no-check skips this)",
            )
        raise typer.Exit(3) from None
    except RecordError as exc:
        error("cannot write the run record", str(exc))
        raise typer.Exit(4) from None


@contextmanager
def progress_bar(enabled: bool) -> Iterator[Any]:
    """A `progress(done, total)` callback drawing a bar on stderr (None when disabled),
    refreshed by hand: no refresh thread while workers fork."""
    if not enabled:
        yield None
        return
    columns = (TextColumn("planning sequences"), BarColumn(), MofNCompleteColumn())
    with Progress(
        *columns, TimeElapsedColumn(), console=err_console, auto_refresh=False, transient=True
    ) as bar:
        job = bar.add_task("plan", total=None)

        def update(done: int, total: int) -> None:
            bar.update(job, completed=done, total=total)
            bar.refresh()

        yield update


def fmt(x: float | None) -> str:
    """An energy for a table: grouped digits, scientific when large, "–" when unknown."""
    if x is None or x != x:
        return "–"
    return f"{x:,.2f}" if abs(x) < 1e6 else f"{x:.3e}"


def fmt_error(x: float | None) -> str:
    """A goal error for a table ("–" when a numerical failure left none)."""
    return "–" if x is None else f"{x:.2e}"


def plan_summary(doc: dict) -> None:
    """Header, one row per leg, total energy beside the paper's: from result.json alone."""
    extras = [x for x in ("soft_start", "full_stop") if doc.get(x)]
    if doc.get("time_scale", 1.0) != 1.0:
        extras.append(f"time scale {doc['time_scale']:g}")
    with_pieces = [leg for leg in doc["legs"] if leg["pieces"]]
    basis = with_pieces[0]["pieces"][0]["basis"] if with_pieces else None
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
            fmt_error(leg["error"]),
            fmt(leg["energy"]),
            "[green]ok[/]" if leg["converged"] else "[red]failed[/]",
        )
    out_console.print(table)
    line = f"total energy [bold]{fmt(doc['total_energy'])}[/]"
    ref = doc.get("reference_energy")
    scale = doc.get("time_scale", 1.0)
    if doc["total_energy"] is None:
        ref = None  # no energy to compare (a numerical failure)
    if ref and scale != 1.0:  # the paper's legs last 1 s: compare the path at its own speed
        own = doc["total_energy"] / scale
        line += f" (at time scale 1: {fmt(own)}; paper: {fmt(ref)}, ratio {own / ref:.2f})"
    elif ref:
        line += f" (paper: {fmt(ref)}, ratio {doc['total_energy'] / ref:.2f})"
    if doc["switches"]:
        worst = max(max(abs(v) for v in sw["jump"].values()) for sw in doc["switches"])
        line += f" · largest control jump at a switch {worst:.1e}"
    status = "[green]ok[/]" if doc["status"] == "ok" else "[red]failed[/]"
    out_console.print(f"{line} · status {status}", highlight=False)
    for note in doc.get("notes") or []:
        out_console.print(f"note: {escape(note)}", highlight=False)
    lie = [
        (i + 1, leg)
        for i, leg in enumerate(doc["legs"])
        if leg["method"] == "lie" and leg["pieces"]
    ]
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
        energies = ", ".join(fmt(s["energy"]) for s in opt["starts"])
        out_console.print(
            f"energy-optimal over all legs together: start {best['index'] + 1} of "
            f"{len(opt['starts'])} ({best['iterations']} SQP iterations"
            f"{', ' + best['stopped'] if best.get('stopped') else ''}, "
            f"projected gradient {best['projected_gradient']:.0e}); the starts ended at "
            f"{energies}; plain Newton: {fmt(opt['newton_energy'])}"
            + (" (energies before time scaling)" if scale != 1.0 else ""),
            highlight=False,
        )


def plan_footer(outcome, run_dir: Path) -> None:
    total = outcome.phases.get("total", {}).get("wall_s")  # since stratplan started
    say(
        f"planned in {outcome.planning_time * 1e3:.0f} ms (model compiled in "
        f"{outcome.compile_time * 1e3:.0f} ms)"
        f"{'' if total is None else f' · {total:.2f} s in all'} · record: {run_dir}"
    )


def ranking(task, doc: dict) -> None:
    from ..compare import CRITERION_LABELS  # here, not at the top: start-up speed

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


def comparison_footer(outcome, run_dir: Path) -> None:
    comparison = outcome.comparison
    saved = (
        f"legs planned {comparison.legs_planned} of {comparison.legs_requested} "
        f"({comparison.legs_saved} shared)"
        if comparison.shared
        else f"legs planned {comparison.legs_planned} of {comparison.legs_requested}"
    )
    say(
        f"{saved} · {len(comparison.outcomes)} sequences in {comparison.wall_time:.2f} s on "
        f"{comparison.jobs} process{'es' if comparison.jobs > 1 else ''} (model compiled in "
        f"{outcome.best.compile_time * 1e3:.0f} ms) · record: {run_dir}"
    )


def auto_mode(outcome, run_dir: Path) -> None:
    """`plan` in auto mode: what was compared, the chosen plan, where the ranking is."""
    auto = outcome.settings
    say(
        f"auto mode: {len(outcome.comparison.outcomes)} candidate sequences (max length "
        f"{auto.max_length}, {' + '.join(auto.strategies)}) planned; chose "
        f"{outcome.comparison.choice()}"
    )
    plan_summary(outcome.best.document)
    comparison_footer(outcome, run_dir)
    say(
        f"the full ranking: comparison.csv in the record, or stratplan compare-sequences "
        f"{outcome.task.source}"
    )


def run_record(record, log: dict | None) -> None:
    """`show`: the summary read back from result.json, the MCAP log, the manifest, files."""
    plan_summary(record.result)
    if log:
        topics = ", ".join(f"{t} {n}" for t, n in log["topics"].items())
        say(f"run.mcap: {log['messages']} messages over {log['duration_s']:.2f} s ({topics})")
    m = record.manifest
    say(
        f"run {record.path.name} · started {m.get('started', '?')} · planning "
        f"{1e3 * m.get('planning_time_s', float('nan')):.0f} ms · stratplan {m.get('stratplan')} · "
        f"exit code {m.get('exit_code')}"
    )
    files = sorted(p.name for p in record.path.iterdir())
    say(f"files: {', '.join(files)}")


def runs_table(rows: list[dict], out: Path) -> None:
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
            fmt(row["total_energy"]),
            row["run"],
        )
    out_console.print(table)


def presets_table(systems: dict) -> None:
    table = Table(show_edge=False)
    for col in ("preset", "coordinates", "inputs", "strata", "description"):
        table.add_column(col)
    for name, system in systems.items():
        table.add_row(
            name,
            ", ".join(system.states),
            ", ".join(system.inputs),
            ", ".join(system.strata),
            system.description,
        )
    out_console.print(table)


def model(task, strata: list[dict]) -> None:
    """`models FILE`: a scenario's model, one row per stratum."""
    system = task.system
    say(
        f"[bold]{task.model_name}[/] model of {task.scenario.name}"
        f"{': ' + system.description if system.description else ''}"
    )
    say(f"coordinates: {', '.join(system.states)}")
    say(f"inputs: {', '.join(system.inputs)}")
    table = Table(show_edge=False)
    for col in ("stratum", "locked", "active inputs", "dimension", "auto evaluator"):
        table.add_column(col)
    for s in strata:
        table.add_row(
            s["stratum"],
            ", ".join(s["locked"]) or "–",
            ", ".join(s["active"]),
            str(s["dimension"]),
            s["evaluator"],
        )
    out_console.print(table)
    if task.settings.evaluator != "auto":
        out_console.print(f"this scenario asks for the {task.settings.evaluator} evaluator")


def regress_report(report) -> None:
    if report.updated:
        out_console.print(f"baseline {report.baseline} written: {report.scenarios} scenarios")
        return
    diffs = report.differences
    table = Table(show_edge=False, title=f"{report.scenarios} scenarios against {report.baseline}")
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
        verdict = "[red]regressions[/]" if report.regressions else "[green]no regressions[/]"
        say(f"{verdict}: {report.regressions} of {len(diffs)} differences are regressions")
    else:
        say(
            f"[green]no regressions[/]: all {report.scenarios} scenarios match {report.baseline} "
            f"(energy within {report.tolerances['energy_rel']:g} relative, errors within "
            f"{report.tolerances['error_abs']:g})"
        )


def _show(x) -> str:
    return f"{x:.6g}" if isinstance(x, float) else str(x)
