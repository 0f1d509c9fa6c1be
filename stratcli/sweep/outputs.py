"""What a sweep leaves besides its rows: the table, sweep.json and the plots."""

from __future__ import annotations

import re
import statistics
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from ..records import sweepdir
from ..records.sweep_plots import sweep_figures
from .spec import Sweep
from .worker import STATUSES

MAX_LISTED = 1000  # missing task indices listed in sweep.json
MAX_REASONS = 5  # kinds of failure listed in sweep.json (the most common)
_NUMBER = re.compile(r"\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def failure_reasons(rows: dict[int, dict[str, Any]]) -> list[dict[str, Any]]:
    """Why the tasks not ok ended so, most common first (at most `MAX_REASONS`): tasks whose
    status and message differ only in their numbers (a leg, a violation) are counted
    together, each kind with its first task and that task's message."""
    kinds: dict[tuple[str, str], dict[str, Any]] = {}
    for k in sorted(rows):
        row = rows[k]
        if row["status"] == "ok":
            continue
        message = str(row.get("message") or "")
        kind = kinds.setdefault(
            (row["status"], _NUMBER.sub("#", message)),
            {"status": row["status"], "tasks": 0, "first": k, "message": message},
        )
        kind["tasks"] += 1
    return sorted(kinds.values(), key=lambda kind: (-kind["tasks"], kind["first"]))[:MAX_REASONS]


def summarise(
    spec: dict[str, Any], rows: dict[int, dict[str, Any]], missing: list[int] | None = None
) -> dict[str, Any]:
    """Counts by status, success rate, energies and the best task of some rows."""
    counts = dict.fromkeys(STATUSES, 0)
    for row in rows.values():
        counts[row["status"]] = counts.get(row["status"], 0) + 1
    done = len(rows)
    ok = {k: r for k, r in rows.items() if r["status"] == "ok" and r.get("energy") is not None}
    energies = sorted(r["energy"] for r in ok.values())
    best = min(ok, key=lambda k: (ok[k]["energy"], k)) if ok else None
    sequences: dict[str, int] = {}
    for r in ok.values():
        if r.get("sequence"):
            sequences[r["sequence"]] = sequences.get(r["sequence"], 0) + 1
    return {
        "schema": sweepdir.FORMAT,  # the key every other document of a record has
        "format": sweepdir.FORMAT,  # the key sweep.json had first: kept for its readers
        "name": spec["name"],
        "mode": spec["mode"],
        "kind": spec["kind"],
        "tasks": spec["count"],
        "done": done,
        "missing": spec["count"] - done,
        "missing_tasks": list(missing or [])[:MAX_LISTED],  # the first ones, by index
        "counts": counts,
        "success_rate": counts["ok"] / done if done else None,
        "energy": {
            "min": energies[0] if energies else None,
            "median": statistics.median(energies) if energies else None,
            "max": energies[-1] if energies else None,
        },
        "best": None
        if best is None
        else {
            "index": best,
            "energy": ok[best]["energy"],
            "sequence": ok[best].get("sequence"),
            "inputs": {k: ok[best].get(k) for k in spec["keys"]},
        },
        "sequences": dict(sorted(sequences.items(), key=lambda kv: (-kv[1], kv[0]))),
        "planning_time_s": sum(r.get("planning_time_s") or 0.0 for r in rows.values()),
        "failures": failure_reasons(rows),
    }


def finish(
    sweep: Sweep,
    out: Path,
    rows: dict[int, dict[str, Any]],
    info,
    wall: float,
    planned: int,
    resumed: int,
    missing: list[int],
    started: str,
    lost: dict[int, str] | None = None,
) -> tuple[dict[str, Any], list[Path]]:
    """Write results.csv, the plots and sweep.json; (sweep.json, the files written). `lost`:
    the tasks of this run whose run record was asked for and could not be made, and why."""
    from .run import spec_document

    spec = spec_document(sweep)
    summary = summarise(spec, rows, missing)
    summary.update(
        executor={"kind": info.kind, "workers": info.workers, "address": info.address},
        wall_time_s=wall,
        planned_this_run=planned,
        resumed_rows=resumed,
        tasks_per_s=planned / wall if wall > 0 else None,
        started=started,
        finished=datetime.now(UTC).isoformat(),
        records_lost=[{"task": k, "reason": why} for k, why in sorted((lost or {}).items())],
    )
    files = []
    for name, data in sweep_figures(spec, rows).items():
        sweepdir.write_atomic(out / name, data)
        files.append(out / name)
    summary["plots"] = [p.name for p in files]
    sweepdir.write_outputs(out, list(sweep.keys), rows, summary)
    return summary, [out / sweepdir.TABLE, out / sweepdir.SUMMARY, *files]
