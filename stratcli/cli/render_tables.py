"""Rich rendering of the comparison, the run list, the models and the regression report.

Numbers and ids go in `number_column`s (never cut with "…"), words in `text_column`s.
"""

from __future__ import annotations

from pathlib import Path
from shlex import quote  # a path in a command to paste: spaces, quotes

from rich.markup import escape

from ..wording import counted
from . import render, render_plan
from .render import fmt, number_column, say, table, text_column

SHOWN_RANKS = 40  # rows of the ranking printed, at most (comparison.csv has every one)
SHOWN_FAILURES = 10  # failure reasons printed below it, at most


def ranking(task, doc: dict) -> None:
    """`compare-sequences`: the settings, then one row per candidate sequence, best first
    (the first `SHOWN_RANKS`: an 8-joint robot's 986 candidates scrolled the terminal for
    pages; the record's comparison.csv and --json have them all).

    A scenario compared with both strategies shows each row's strategy under its sequence.
    """
    from ..comparison_values import CRITERION_LABELS, at_reference  # (start-up speed)

    s = task.settings
    reference = doc.get("reference_duration_s")
    listed = doc["rows"]
    durations = [r["duration"] for r in listed if r["duration"] is not None and r["status"] == "ok"]
    lengths = [len(r["sequence"]) for r in listed if r["status"] != "failed"]
    scaled = (
        doc["criterion"] == "energy"
        and reference is not None
        and at_reference(durations, lengths, reference)
    )
    ranked = CRITERION_LABELS[doc["criterion"]]
    if scaled:
        ranked = f"energy at an equal total duration of {reference:g} s"
    render.out_console.print(
        f"[bold]{doc['scenario']}[/] · model {doc['model']} · {s.continuity} · objective "
        f"{getattr(s, 'objective', 'newton')} · tolerance {s.tolerance:g} · essential "
        f"{', '.join(doc['essential'])} · {doc['sequences']} "
        f"sequences (max length {doc['max_length']}, {' + '.join(doc['strategies'])}) · "
        f"ranked by {ranked}",
        highlight=False,
    )
    both = len(doc["strategies"]) > 1
    rows = table()
    number_column(rows, "rank")
    if both:  # the strategy word under each sequence: as wide as the longest strategy
        text_column(rows, "sequence\n(strategy)", min_width=len("conservative"))
    else:
        text_column(rows, "sequence")
    number_column(rows, "status", justify="left")
    headers = ["energy"] + ([f"energy\nin {reference:g} s"] if scaled else [])
    for header in (*headers, "peak\n|u|", "max\nexcursion", "duration", "planning\nms"):
        number_column(rows, header)
    # rate and acceleration limits slow each plan by its own factor, which a sequence not
    # searched does not have: only its bound at equal duration holds (time scaling keeps it)
    slowed = scaled and task.constraints is not None and task.constraints.timed
    failures = []
    bounded = sum(row["status"] == "bounded" for row in doc["rows"])
    for row in doc["rows"][:SHOWN_RANKS]:
        ok = row["status"] == "ok"
        bound = row["status"] == "bounded"  # not searched: only a lower bound is known
        style = "bold green" if ok and row["rank"] == 1 else None
        sequence = " → ".join(row["sequence"])
        if not ok and not bound:  # the reason is a sentence: below the table, not in a cell
            failures.append(f"rank {row['rank']} ({sequence}) failed: {escape(row['reason'])}")
        energies = [fmt(row["energy"]) if ok else "–"]
        if scaled:
            energies.append(fmt(row["energy_equal_time"]) if ok else "–")
        if bound:  # under rate limits its energy and duration as run are unknown (slowed)
            energies = ["–" if slowed else "≥ " + fmt(row["energy_bound"])]
            if scaled:
                energies.append("≥ " + fmt(row["energy_bound_equal_time"]))
        rows.add_row(
            str(row["rank"]),
            f"{sequence}\n[dim]{row['strategy']}[/]" if both else sequence,
            "ok" if ok else ("[dim]bounded[/]" if bound else "[red]failed[/]"),
            *energies,
            fmt(row["peak_control"]) if ok else "–",
            _number(row["excursion"], "{:.3f}") if ok else "–",
            "–" if (bound and slowed) or not (ok or bound) else _number(row["duration"], "{:g}"),
            "–" if bound else f"{1e3 * row['planning_time_s']:.0f}",
            style=style,
        )
    render.out_console.print(rows)
    if (hidden := len(doc["rows"]) - SHOWN_RANKS) > 0:
        say(
            f"… and {hidden} more sequences, ranks {SHOWN_RANKS + 1}–{len(doc['rows'])} "
            "(comparison.csv in the record, or --json, has every row)"
        )
    if bounded:
        at = ", at the equal total duration," if scaled else ""
        say(
            f"{counted(bounded, 'sequence')} bounded, not searched: the sum of their legs' minimum "
            "energies (each leg planned alone, without the conditions that tie it to its "
            "neighbours, or bounded below by the joints' travel and the stratum's curvature) "
            f"is{at} at least the best's; they are listed in the order of their bounds, not "
            "ranked among themselves (--exhaustive searches and ranks every one)"
        )
    if scaled:
        say(
            f"sequences are ranked by energy at equal total duration: each path run in "
            f"{reference:g} s (energy × duration / {reference:g} s; time-scaling a path keeps "
            "energy × duration)"
        )
    for failure in failures[:SHOWN_FAILURES]:
        say(failure)
    if (more := len(failures) - SHOWN_FAILURES) > 0:
        say(f"… and {more} more failed above (their reasons: comparison.csv in the record)")


def _number(x: float | None, pattern: str) -> str:
    """`x` formatted, "–" when unknown, scientific from 1e6 on (a table cell stays short)."""
    if x is None or x != x:
        return "–"
    return pattern.format(x) if abs(x) < 1e6 else f"{x:.3e}"


def comparison_footer(outcome, run_dir: Path) -> None:
    """How many legs were planned (and shared), in what time, and where the record is."""
    comparison = outcome.comparison
    saved = (
        f"legs planned {comparison.legs_planned} of {comparison.legs_requested} "
        f"({comparison.legs_saved} shared)"
        if comparison.shared
        else f"legs planned {comparison.legs_planned} of {comparison.legs_requested}"
    )
    if comparison.screen is not None:  # the screen planned legs alone for its bounds too
        saved += f" (and {comparison.screen.legs} alone for the screen's bounds)"
    where = comparison.on or counted(comparison.jobs, "process", "processes")  # or Dask
    say(
        f"{saved} · {len(comparison.outcomes)} sequences in {comparison.wall_time:.2f} s on "
        f"{where} (model compiled in {outcome.best.compile_time * 1e3:.0f} ms) · "
        f"{render.record(run_dir)}"
    )


def auto_mode(outcome, run_dir: Path) -> None:
    """`plan` in auto mode: what was compared, the chosen plan, where the ranking is."""
    from ..api.auto import auto_choice

    say(auto_choice(outcome))
    render_plan.plan_summary(outcome.best.document)
    comparison_footer(outcome, run_dir)
    say(
        f"the full ranking: comparison.csv in the record, or stratplan compare-sequences "
        f"{quote(str(outcome.task.source))}"
    )


def runs_table(rows: list[dict], out: Path) -> None:
    """`runs`: one line per record, newest first: status, energy and the run (what `show`
    takes), aligned in columns.

    Not a rich table: a run's path may be wider than the terminal, and a table would then
    shrink or fold every column. Each line is printed whole (`soft_wrap`): the terminal
    wraps a long one, and a copied path stays one path.
    """
    if not rows:
        from ..records.sweepdir import is_sweep_dir

        hint = ""
        if is_sweep_dir(out):
            hint = f" (a sweep directory: `stratplan show {quote(str(out))}` summarises it)"
        render.out_console.print(f"no run records in {out}{hint}", highlight=False)
        return
    energies = [fmt(row["total_energy"]) for row in rows]
    width = max(len("energy"), *map(len, energies))
    render.out_console.print(
        f"[bold]status  {'energy':>{width}}  run (stratplan show RUN)[/]", highlight=False
    )
    for row, energy in zip(rows, energies, strict=True):
        status = "[green]ok    [/]" if row["status"] == "ok" else "[red]failed[/]"
        render.out_console.print(
            f"{status}  {energy:>{width}}  {escape(str(out / row['run']))}",
            highlight=False,
            soft_wrap=True,
        )
    if all(row["run"].startswith("task-") for row in rows):  # a sweep's records/
        say("newest first; a sweep's task is named task-<its index in the sweep>")
    else:
        say("newest first; a run is named <UTC time it started>-<scenario>-<hash of its text>")


def presets_table(systems: dict) -> None:
    """`models`: one row per preset model."""
    presets = table()
    number_column(presets, "preset", justify="left")
    for col in ("coordinates", "inputs", "strata", "description"):
        text_column(presets, col)
    for name, system in systems.items():
        presets.add_row(
            name,
            ", ".join(system.states),
            ", ".join(system.inputs),
            ", ".join(system.strata),
            system.description,
        )
    render.out_console.print(presets)
    say("describe one: stratplan models NAME (a preset above, or a scenario file)")


def model(name: str, system, strata: list[dict], of: str | None = None) -> None:
    """`models NAME|FILE`: a model (a preset, or a scenario's), one row per stratum.

    Parameters
    ----------
    name : str
        The model's name.
    system : System
        The model.
    strata : list of dict
        `api.strata_table(system)`.
    of : str, optional
        The scenario whose model it is (None for a preset).
    """
    say(
        f"[bold]{escape(name)}[/] {'model of ' + escape(of) if of else 'preset model'}"
        f"{': ' + escape(system.description) if system.description else ''}"
    )
    say(f"coordinates: {', '.join(system.states)}")
    say(f"inputs: {', '.join(system.inputs)}")
    rows = table()
    number_column(rows, "stratum", justify="left")
    text_column(rows, "locked")
    text_column(rows, "active inputs")
    number_column(rows, "dimension")
    text_column(rows, "auto evaluator")
    for s in strata:
        rows.add_row(
            s["stratum"],
            ", ".join(s["locked"]) or "–",
            ", ".join(s["active"]),
            str(s["dimension"]),
            s["evaluator"],
        )
    render.out_console.print(rows)


def regress_report(report) -> None:
    """`regress`: the differences from the baseline, or that there are none."""
    if report.updated:
        say(f"baseline {report.baseline} written: {counted(report.scenarios, 'scenario')}")
        return
    diffs = report.differences
    rows = table()
    rows.title = f"{counted(report.scenarios, 'scenario')} against {report.baseline}"
    text_column(rows, "scenario")
    text_column(rows, "quantity")
    number_column(rows, "baseline")
    number_column(rows, "now")
    text_column(rows, "verdict")
    for d in diffs:
        rows.add_row(
            escape(d.scenario),
            d.quantity,
            _show(d.baseline),
            _show(d.now),
            "[red]regression[/]" if d.regression else "[yellow]changed[/]",
        )
    if diffs:
        render.out_console.print(rows)
        verdict = "[red]regressions[/]" if report.regressions else "[green]no regressions[/]"
        say(f"{verdict}: {report.regressions} of {len(diffs)} differences are regressions")
    else:
        n = report.scenarios
        matched = "1 scenario matches" if n == 1 else f"all {n} scenarios match"
        say(
            f"[green]no regressions[/]: {matched} {report.baseline} "
            f"(energy within {report.tolerances['energy_rel']:g} relative, errors within "
            f"{report.tolerances['error_abs']:g})"
        )


def regress_failures(report) -> None:
    """`regress --quiet`: one line on stderr per regression, so a failing CI job says why
    (a plan that failed: its message too)."""
    for d in report.differences:
        if d.regression:
            why = report.messages.get(d.scenario)
            render.err_console.print(
                f"regression: {escape(d.scenario)}: {d.quantity}: baseline {_show(d.baseline)}, "
                f"now {_show(d.now)}" + (f" ({escape(why)})" if why else ""),
                highlight=False,
                soft_wrap=True,
            )


def regress_progress(quiet: bool):
    """A `progress(name, summary, seconds)` callback printing one line on stderr per scenario
    planned by `regress` (None under --quiet). Plain lines, so a CI log shows them too: a
    baseline of slow scenarios is otherwise silent for minutes."""
    if quiet:
        return None

    def planned(name: str, summary: dict, seconds: float) -> None:
        status = "[green]ok[/]" if summary.get("status") == "ok" else "[red]failed[/]"
        why = f" · {escape(summary['message'])}" if summary.get("message") else ""
        render.err_console.print(
            f"planned {escape(name)}: {status} · energy {fmt(summary.get('total_energy'))} · "
            f"{seconds:.1f} s{why}",
            highlight=False,
            soft_wrap=True,
        )

    return planned


def _show(x) -> str:
    """A regress value: a number to 6 digits; none (a failed plan's, null in the baseline,
    NaN now) as "–" both ways (the baseline's showed "None" beside "nan")."""
    if x is None or (isinstance(x, float) and x != x):
        return "–"
    return f"{x:.6g}" if isinstance(x, float) else str(x)
