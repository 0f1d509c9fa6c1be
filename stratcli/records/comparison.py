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

from ..compare import Comparison, Outcome
from ..decomposition import Decomposition
from ..format import pi_fraction

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
    floor, bound = o.leg_bounds[i] if i < len(o.leg_bounds) else (None, None)
    return {
        "stratum": leg.stratum,
        "goal": _vec(leg.goal),
        "error": None if planned is None else planned.error,
        "converged": None if planned is None else planned.converged,
        "energy": None if planned is None else planned.energy,
        "floor": floor,  # the screen's: certified, without a search (`leg_floors`)
        "bound": bound,  # ... the larger of it and the leg's searched minima
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
        "energy_equal_time": _num(o.energy_equal_time) if o.ok else None,  # ranked rows
        "peak_control": _num(o.peak_control),
        "excursion": _num(o.excursion),
        "duration": _num(o.duration),
        "planning_time_s": o.planning_time,
        "screened": o.screened,
        "energy_bound": _num(o.energy_bound),
        "energy_bound_equal_time": _num(o.energy_bound_equal_time),
        "vias": [_vec(v) for v in cand.vias],
        "vias_pi": [_pi(v) for v in cand.vias],
        "legs": [_leg_row(o, i, leg) for i, leg in enumerate(cand.legs)],
    }


def _screen(comparison: Comparison) -> dict[str, Any] | None:
    """What the screen did (None: every candidate searched to its minimum)."""
    screen = comparison.screen
    if screen is None:
        return None
    return {
        "method": (
            "branch and bound on the sum of the legs' minima, each leg planned alone or "
            "bounded below by the joints' travel and the stratum's curvature"
        ),
        "legs_bounded": screen.legs,
        "legs_floored": screen.floored,  # distinct legs with a positive floor (no search)
        "searched": len(screen.searched),
        "bounded": sum(o is not None and o.status == "bounded" for o in comparison.outcomes),
        # failed unsearched: a leg of theirs has no plan even alone, free at both ends
        "failed_unsearched": len(screen.sunk),
        "bound_corrections": screen.corrections,
        "bound_cpu_s": screen.seconds,  # summed over the processes
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
        "screen": _screen(comparison),
        "rows": rows,
    }


CSV_COLUMNS = (
    "rank",
    "sequence",
    "strategy",
    "status",
    "energy",
    "energy_equal_time",  # what the energy criterion ranks by: run in the shortest duration
    "peak_control",
    "excursion",
    "duration",
    "planning_time_s",
    "energy_bound",  # a sequence not searched (status "bounded"): its energy is at least this
    "energy_bound_equal_time",
    "vias",
    "reason",
)
NUMBERS = CSV_COLUMNS[4:12]


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
                *("" if row[k] is None else repr(row[k]) for k in NUMBERS),
                vias,
                row["reason"],
            ]
        )
    return buf.getvalue()


def without_timings(doc: dict[str, Any]) -> dict[str, Any]:
    """The document minus what varies between identical runs (timings, number of jobs)."""
    out = {k: v for k, v in doc.items() if k not in ("wall_time_s", "compile_time_s", "jobs")}
    if out.get("screen"):
        out["screen"] = {k: v for k, v in out["screen"].items() if k != "bound_cpu_s"}
    out["rows"] = [{k: v for k, v in r.items() if k not in TIMING_KEYS} for r in doc["rows"]]
    return out
