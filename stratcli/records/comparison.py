"""The comparison record: `comparison.json`, `comparison.csv` and the bar chart `ranking.png`.

`comparison.json` (schema "stratplan.comparison/1") holds the task, the decomposition
(essential coordinates, candidate strata, strategies) and one row per candidate sequence in
rank order: its legs' strata and goals (the via configurations), status and reason, the
ranking quantities and the planning time. The best sequence's full run record (result.json
and the rest) sits beside it in the same run directory.
"""

from __future__ import annotations

import csv
import io
import math
from typing import Any

from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator

from ..compare import CRITERION_LABELS, Comparison, Outcome
from ..decompose import Decomposition, pi_fraction
from .figure_common import save_figure

SCHEMA = "stratplan.comparison/1"
TIMING_KEYS = ("planning_time_s",)  # the only row entries that vary between identical runs


def _num(x: float) -> float | None:
    return None if x is None or (isinstance(x, float) and math.isnan(x)) else float(x)


def _vec(q) -> list[float | None]:
    return [_num(float(x)) for x in q]


def _pi(q) -> list[str | None]:
    return [None if math.isnan(float(x)) else pi_fraction(float(x)) for x in q]


def _leg_row(o: Outcome, i: int, leg) -> dict[str, Any]:
    planned = None if o.plan is None or i >= len(o.plan.legs) else o.plan.legs[i]
    return {
        "stratum": leg.stratum,
        "goal": _vec(leg.goal),
        "error": None if planned is None else planned.error,
        "converged": None if planned is None else planned.converged,
        "energy": None if planned is None else planned.energy,
    }


def _row(o: Outcome) -> dict[str, Any]:
    cand = o.candidate
    return {
        "rank": o.rank,
        "sequence": list(cand.sequence),
        "strategy": cand.strategy,
        "status": o.status,
        "reason": o.reason,
        "message": o.message,
        "energy": _num(o.energy),
        "energy_equal_time": _num(o.energy_equal_time),
        "peak_control": _num(o.peak_control),
        "excursion": _num(o.excursion),
        "duration": _num(o.duration),
        "planning_time_s": o.planning_time,
        "screened": o.screened,
        "vias": [_vec(v) for v in cand.vias],
        "vias_pi": [_pi(v) for v in cand.vias],
        "legs": [_leg_row(o, i, leg) for i, leg in enumerate(cand.legs)],
    }


def comparison_document(
    comparison: Comparison,
    decomposition: Decomposition,
    *,
    scenario: str,
    model: str,
    states: tuple[str, ...],
    start,
    goal,
    settings: dict[str, Any],
    compile_time: float,
) -> dict[str, Any]:
    """The JSON-ready comparison; rows in rank order (best first)."""
    rows = [_row(comparison.outcomes[k]) for k in comparison.ranking]
    best = comparison.best
    return {
        "schema": SCHEMA,
        "scenario": scenario,
        "model": model,
        "coordinates": list(states),
        "start": _vec(start),
        "goal": _vec(goal),
        "essential": [states[i] for i in decomposition.essential],
        "candidate_strata": list(decomposition.candidates_strata),
        "max_length": decomposition.max_length,
        "strategies": list(decomposition.strategies),
        "criterion": comparison.criterion,
        "reference_duration_s": _num(comparison.reference_duration),
        "settings": settings,
        "best": 0 if best is not None and best.ok else None,
        "choice": comparison.choice(),
        "sequences": len(rows),
        "reached_goal": sum(1 for o in comparison.outcomes if o.ok),
        "shared_prefixes": comparison.shared,
        "legs_requested": comparison.legs_requested,
        "legs_planned": comparison.legs_planned,
        "legs_saved": comparison.legs_saved,
        "jobs": comparison.jobs,
        "wall_time_s": comparison.wall_time,
        "compile_time_s": compile_time,
        "rows": rows,
    }


CSV_COLUMNS = (
    "rank",
    "sequence",
    "strategy",
    "status",
    "energy",
    "peak_control",
    "excursion",
    "duration",
    "planning_time_s",
    "vias",
    "reason",
)


def comparison_csv(doc: dict[str, Any]) -> str:
    """One line per sequence, in rank order; vias as `(…);(…)` with "*" unprescribed."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(CSV_COLUMNS)
    for row in doc["rows"]:
        vias = ";".join(
            "(" + " ".join("*" if x is None else repr(x) for x in v) + ")" for v in row["vias"]
        )
        writer.writerow(
            [
                row["rank"],
                " ".join(row["sequence"]),
                row["strategy"],
                row["status"],
                *("" if row[k] is None else repr(row[k]) for k in CSV_COLUMNS[4:9]),
                vias,
                row["reason"],
            ]
        )
    return buf.getvalue()


def _short(x: float) -> str:
    return f"{x:,.0f}" if abs(x) >= 1000 else f"{x:.4g}"


LOG_RATIO = 10.0  # ranking.png: a log axis whenever the plotted values span more than this
BEST_COLOR = "#2e7d32"
OTHER_COLOR = "#4a6fa5"
FAILED_COLOR = "#c0392b"
# units of the ranking quantities for the presets and physical planar models (rad, rad/s)
_UNITS = {"energy": "rad²/s", "peak-control": "rad/s", "excursion": "rad", "duration": "s"}
_KEYS = {
    "energy": "energy_equal_time",
    "peak-control": "peak_control",
    "excursion": "excursion",
    "duration": "duration",
}


def _axis_label(doc: dict[str, Any]) -> str:
    criterion = doc["criterion"]
    label = CRITERION_LABELS[criterion]
    if criterion == "energy":
        label += " ∫|u|² dt"
        if doc.get("reference_duration_s") is not None:
            label += f", each path run in {doc['reference_duration_s']:g} s"
    if criterion == "duration" or doc.get("model") != "custom":
        return f"{label} [{_UNITS[criterion]}]"
    return f"{label} (the model's units)"


def ranking_figure(doc: dict[str, Any]) -> Figure:
    """Horizontal bars of the criterion per sequence, best on top and highlighted.

    One rule for the scale: a log axis whenever the largest plotted value exceeds `LOG_RATIO`
    times the smallest (positive) one, as the axis label and a note say; linear otherwise.
    Failed sequences get their reason instead of a bar.
    """
    key = _KEYS[doc["criterion"]]
    rows = doc["rows"]
    if rows and key not in rows[0]:  # a record written before energies were compared so
        key = doc["criterion"]
    labels = [f"{'→'.join(r['sequence'])} · {r['strategy'][:4]}." for r in rows]
    ok = [i for i, r in enumerate(rows) if r["status"] == "ok" and r[key] is not None]
    values = [rows[i][key] for i in ok]
    positive = [v for v in values if v > 0]
    if not positive:  # nothing, or all zero
        ratio = 1.0
    else:  # a zero among positive values: an infinite range
        ratio = max(positive) / min(positive) if len(positive) == len(values) else math.inf
    log = ratio > LOG_RATIO
    floor = min(positive) / 2 if log else 0.0
    height = max(3.0, 0.26 * len(rows) + 1.5)
    fig = Figure(figsize=(8.0, height), layout="constrained")
    ax = fig.add_subplot()
    best = 0 if doc.get("best") == 0 and 0 in ok else None
    colors = [BEST_COLOR if i == best else OTHER_COLOR for i in ok]
    shown = [max(v, floor) for v in values]  # a zero on a log axis sits at the floor
    bars = ax.barh(ok, [v - floor for v in shown], left=floor, color=colors, height=0.7)
    for i, v, x in zip(ok, values, shown, strict=True):
        ax.text(x, i, f" {_short(v)}", va="center", fontsize=7.5)
    failed = False
    for i, r in enumerate(rows):
        if i not in ok:
            failed = True
            reason = " failed: " + (r["reason"] or r["status"])[:60]
            ax.text(floor, i, reason, va="center", fontsize=7.5, color=FAILED_COLOR)
    if log:
        ax.set_xscale("log")
        plain = FuncFormatter(lambda x, _: f"{x:,.10g}")
        ax.xaxis.set_major_formatter(plain)
        if ratio < 1000:  # labels at 2 and 5 too: a bar's length can be read off the axis
            ax.xaxis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
            ax.xaxis.set_minor_formatter(plain)
            ax.tick_params(axis="x", which="minor", labelsize=8)
    ax.set_yticks(range(len(rows)), labels, fontsize=7.5)
    ax.set_ylim(len(rows) - 0.5, -0.5)
    ax.set_xlabel(_axis_label(doc) + (" — log scale" if log else ""), fontsize=9)
    ax.set_title(
        f"{doc['scenario']}: {len(rows)} sequences ranked by {CRITERION_LABELS[doc['criterion']]}",
        fontsize=10,
    )
    ax.grid(axis="x", alpha=0.3)
    if values:
        ax.set_xlim(floor if log else 0.0, max(shown) * (1.7 if log else 1.18))
    handles = []
    if best is not None:
        handles.append(bars[ok.index(best)])
        bars[ok.index(best)].set_label(f"best: {labels[best]}")
    if len(ok) > (best is not None):
        other = next(b for b, i in zip(bars, ok, strict=True) if i != best)
        other.set_label("reached the goal")
        handles.append(other)
    if failed:
        from matplotlib.lines import Line2D

        handles.append(Line2D([], [], color=FAILED_COLOR, ls="none", marker="$x$", label="failed"))
    span = "from 0" if math.isinf(ratio) else f"{ratio:,.3g}×"
    relation = ">" if log else "≤"
    scale = f"{'log' if log else 'linear'} scale: values span {span} ({relation} {LOG_RATIO:g}×)"
    fig.legend(
        handles=handles,
        loc="outside lower center",
        ncols=len(handles),
        fontsize=8,
        title=scale,
        title_fontsize=8,
        frameon=False,
    )
    return fig


def ranking_png(doc: dict[str, Any], fmt: str = "png") -> bytes:
    """`ranking_figure` as PNG (or SVG or PDF) bytes."""
    return save_figure(ranking_figure(doc), fmt)


def without_timings(doc: dict[str, Any]) -> dict[str, Any]:
    """The document minus what varies between identical runs (timings, number of jobs)."""
    out = {k: v for k, v in doc.items() if k not in ("wall_time_s", "compile_time_s", "jobs")}
    out["rows"] = [{k: v for k, v in r.items() if k not in TIMING_KEYS} for r in doc["rows"]]
    return out
