"""Compare replayed scenarios with a committed baseline (for users' CI).

Pure functions over summaries (status, total energy, each leg's error and energy); the
replaying itself is `stratcli.api.runs.regress`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import InputError

SCHEMA = "stratplan.baseline/1"
DEFAULT_TOLERANCES = {"energy_rel": 1e-6, "error_abs": 1e-6}


def summary_of(plan) -> dict[str, Any]:
    """What a baseline keeps of a plan (a `SequencePlan`): status, total energy, and each
    leg's error and energy."""
    return {
        "status": "ok" if plan.ok else "failed",
        "total_energy": plan.total_energy,
        "errors": [leg.error for leg in plan.legs],
        "energies": [leg.energy for leg in plan.legs],
    }


@dataclass
class Difference:
    scenario: str
    quantity: str
    baseline: Any
    now: Any
    regression: bool


def compare(
    now: dict[str, dict], baseline: dict[str, dict], tolerances: dict[str, float]
) -> list[Difference]:
    """Every difference beyond tolerance; `regression` marks the ones that fail CI."""
    rel, abs_err = tolerances["energy_rel"], tolerances["error_abs"]
    out: list[Difference] = []
    for name in sorted(set(now) | set(baseline)):
        if name not in baseline:
            out.append(Difference(name, "scenario", "absent", "new", False))
            continue
        if name not in now:
            out.append(Difference(name, "scenario", "present", "missing", True))
            continue
        b, n = baseline[name], now[name]
        if b["status"] != n["status"]:
            out.append(Difference(name, "status", b["status"], n["status"], n["status"] != "ok"))
        eb, en = b["total_energy"], n["total_energy"]
        if abs(en - eb) > rel * max(abs(eb), 1e-12):
            out.append(Difference(name, "total energy", eb, en, en > eb))
        if len(b["errors"]) != len(n["errors"]):
            out.append(Difference(name, "legs planned", len(b["errors"]), len(n["errors"]), True))
            continue
        for i, (xb, xn) in enumerate(zip(b["errors"], n["errors"], strict=True)):
            if xn > xb + abs_err:
                out.append(Difference(name, f"leg {i + 1} error", xb, xn, True))
    return out


def load_baseline(path: Path) -> tuple[dict[str, dict], dict[str, float]]:
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"baseline file {path} does not exist (create it with --update)") from None
    except (OSError, json.JSONDecodeError) as exc:
        raise InputError(f"baseline file {path}: {exc}") from None
    if doc.get("schema") != SCHEMA:
        raise InputError(f"baseline file {path}: schema must be {SCHEMA!r}")
    return doc["scenarios"], DEFAULT_TOLERANCES | doc.get("tolerances", {})


def baseline_document(now: dict[str, dict], tolerances: dict[str, float]) -> dict[str, Any]:
    return {"schema": SCHEMA, "tolerances": tolerances, "scenarios": now}
