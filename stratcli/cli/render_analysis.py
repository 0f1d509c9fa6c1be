"""Rich rendering of the analyses that plan nothing: the decomposition and the check report."""

from __future__ import annotations

from pathlib import Path
from shlex import quote  # a path in a command to paste: spaces, quotes

from rich.markup import escape

from ..wording import counted
from . import render
from .render import number_column, table, text_column


def _via_cell(goal) -> str:
    """A via as fractions of π where exact, then in radians (dim) if that differs."""
    from ..format import format_configuration  # here, not at the top: start-up speed

    exact, plain = format_configuration(goal, "pi"), format_configuration(goal, "rad")
    return exact if exact == plain else f"{exact}\n[dim]{plain}[/]"


def decomposition(outcome, file: Path, options: tuple[str, ...] = ()) -> None:
    """`decompose`: task, essential coordinates, candidate strata and one row per candidate."""
    from ..format import format_configuration  # start-up speed

    task, dec, rows = outcome.task, outcome.decomposition, outcome.document["sequences"]
    system = task.system
    render.out_console.print(
        f"[bold]{task.scenario.name}[/] · model {task.model_name} · "
        f"start {format_configuration(task.start)} → goal {format_configuration(task.goal)} "
        "(angles in rad; π fractions where exact)",
        highlight=False,
    )
    render.out_console.print(
        f"essential coordinates: {', '.join(system.states[i] for i in dec.essential)} "
        f"({len(dec.essential)} of {system.n})",
        highlight=False,
    )
    moves = [f"{s} moves {', '.join(coords)}" for s, coords in outcome.document["moves"].items()]
    render.out_console.print(f"candidate strata: {'; '.join(moves)}", highlight=False)
    listing = table()
    listing.show_lines = True
    number_column(listing, "#")
    text_column(listing, "sequence")
    text_column(listing, "strategy")
    vias = max(len(c.legs) for c in dec.candidates) - 1
    for v in range(vias):  # a configuration wraps between its coordinates, not inside one
        text_column(listing, f"via {v + 1}" if vias > 1 else "via")
    text_column(listing, "loop\nlegs")
    for row, cand in zip(rows, dec.candidates, strict=True):
        cells = [_via_cell(leg.goal) for leg in cand.legs[:-1]]
        listing.add_row(
            str(row["index"]),
            " → ".join(cand.sequence),
            cand.strategy,
            *cells,
            *([""] * (vias - len(cells))),
            ", ".join(map(str, row["loops"])) or "–",
        )
    render.out_console.print(listing)
    n, k = len(dec.sequences), len(dec.candidates)
    most = counted(dec.max_length, "stratum", "strata")
    command = " ".join(["stratplan compare-sequences", quote(str(file)), *options])
    render.out_console.print(
        f"{counted(n, 'sequence')} of at most {most} × {' and '.join(dec.strategies)} = "
        f"{counted(k, 'candidate')}; a loop leg's goal is its start. Plan and rank them: "
        f"{command}",
        highlight=False,
    )


def check_report(report) -> None:
    """`check`: per stratum rank and σ_min, eq. 2, each leg, the verdict."""
    from ..format import format_configuration  # here, not at the top: start-up speed

    doc, title, seconds = report.document, report.title, report.seconds
    render.out_console.print(
        f"[bold]{escape(title)}[/] · generators and Lie brackets up to degree {doc['degree']} · "
        f"at q = {format_configuration(doc['at'])} and {doc['samples']} sampled "
        f"configurations (seed {doc['seed']})",
        highlight=False,
    )
    strata = table()
    number_column(strata, "stratum", justify="left")
    number_column(strata, "dim")
    number_column(strata, "rank\nat q")
    number_column(strata, "σ_min\nat q")
    number_column(strata, "min rank, σ_min\n(q + samples)")
    text_column(strata, "spanning at q")
    text_column(strata, "eq. 4")
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
            at_q = (  # (the table's "no" is for q: the samples spanned said nothing of it)
                f", but not at q (rank {s['rank_at']} of {s['dimension']} with third order)"
                if s["rank_at"] < s["dimension"]
                else ""
            )
            notes.append(
                f"{s['stratum']}: degree {doc['degree']} falls short at "
                f"{s['third_order_needed'] - int(escalated)} sampled configuration(s), "
                f"third order spans there{at_q}"
            )
        strata.add_row(
            s["stratum"],
            str(s["dimension"]),
            rank,
            _sigma(s["sigma_min_at"]),
            f"{s['min_rank']}, {_sigma(s['min_sigma'])}",
            escape(", ".join(s["spanning_at"])),
            "[green]strong[/]" if s["strong"] else "[red]no[/]",
        )
    render.out_console.print(strata)
    for note in notes:
        render.out_console.print(f"note: {escape(note)}", highlight=False)
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
    render.out_console.print(line, highlight=False)
    if doc["legs"] is not None:
        for leg in doc["legs"]:
            steers = ", ".join(leg["steers"]) or "nothing"
            mark = "[green]spanned[/]" if leg["ok"] else "[red]NOT spanned[/]"
            if not leg["ok"] and leg.get("failure_sampled"):  # spanned at its start
                where = format_configuration(leg["failure_configuration"])
                mark = f"spanned, but [red]NOT[/] at the sampled configuration {where}"
            render.out_console.print(
                f"leg {leg['leg']} on {leg['stratum']} steers {steers}: rank {leg['rank']}, "
                f"σ_min {_sigma(leg['sigma_min'])} at its start "
                f"{format_configuration(leg['configuration'])}: {mark}",
                highlight=False,
            )
    weak = [s["stratum"] for s in doc["strata"] if not s["strong"]]
    verdict = (
        "strongly controllable on every stratum (eq. 4)"
        if not weak
        else f"not strongly controllable on {', '.join(weak)} (eq. 4, brackets up to degree 3)"
    )
    verdict += (
        "; stratified controllable (eq. 2" + (")" if eq2["holds"] else ", by switching)")
        if doc["stratified_controllable"]
        else "; [red]not stratified controllable[/] (eq. 2, brackets up to degree 3: a "
        "system that needs higher ones, such as a chained form of 5 states, is not decided "
        "here; plan --no-check tries it)"
    )
    if doc["legs"] is not None:
        legs_ok = all(leg["ok"] for leg in doc["legs"])
        if legs_ok and not doc["stratified_controllable"]:  # eq. 2 is about every direction
            verdict += (
                ": these strata together miss a direction, which this task's legs do not need"
            )
        verdict += (
            "; every leg's stratum spans the coordinates it steers"
            if legs_ok
            else "; [red]some legs cannot be planned[/]"
        )
    if doc.get("model_problems"):  # ranks made of inf and NaN say nothing: the error does
        verdict = "[red]the model's fields cannot be evaluated everywhere[/] (the error below)"
    render.out_console.print(f"verdict: {verdict} · {seconds * 1e3:.0f} ms", highlight=False)


def _sigma(x: float | None) -> str:
    """A smallest singular value for the tables ("–" where it is not a number)."""
    return "–" if x is None else f"{x:.1e}"
