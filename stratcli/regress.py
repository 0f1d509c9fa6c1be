"""Compare replayed scenarios with a committed baseline (for users' CI).

Pure functions over summaries (status, total energy, each leg's error and energy), and the
baseline file read back (`load_baseline`, one line per problem); the replaying itself is
`stratcli.api.regression.regress`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import InputError
from .wording import closest_choice

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


@dataclass(frozen=True)
class Difference:
    """One quantity of one scenario that differs from the baseline beyond its tolerance;
    `regression` where it fails CI."""

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
        if name not in baseline:  # a new scenario that fails: a CI job stays red until
            failed = now[name]["status"] != "ok"  # --update takes it in as expected
            out.append(
                Difference(name, "scenario", "absent", "new, failed" if failed else "new", failed)
            )
            continue
        if name not in now:
            out.append(Difference(name, "scenario", "present", "missing", True))
            continue
        b, n = baseline[name], now[name]
        if b["status"] != n["status"]:
            out.append(Difference(name, "status", b["status"], n["status"], n["status"] != "ok"))
        # Only a plan that succeeded both times is held to its numbers: a failed plan's are
        # those of where its search stopped (a scenario fixed since the baseline took it in
        # as failed costs more than its stalled search did, and that is no regression).
        held = b["status"] == n["status"] == "ok"
        eb, en = b["total_energy"], n["total_energy"]
        if not (_finite(eb) and _finite(en)):  # a failed plan's energy: compared by status
            if _finite(eb) != _finite(en):
                out.append(Difference(name, "total energy", eb, en, held and not _finite(en)))
        elif abs(en - eb) > rel * max(abs(eb), 1e-12):
            out.append(Difference(name, "total energy", eb, en, held and en > eb))
        if len(b["errors"]) != len(n["errors"]):
            planned = len(b["errors"]), len(n["errors"])
            out.append(Difference(name, "legs planned", *planned, held or planned[1] < planned[0]))
            continue
        for i, (xb, xn) in enumerate(zip(b["errors"], n["errors"], strict=True)):
            lost = _finite(xb) and not _finite(xn)  # a numerical failure now
            if lost or (_finite(xb) and _finite(xn) and xn > xb + abs_err):
                out.append(Difference(name, f"leg {i + 1} error", xb, xn, held))
        # each leg's energy, shown where it moved by more than the tolerance of the total
        # (energy shifted between legs at the same total went unsaid; a leg of no energy moves
        # by rounding); the total alone is held to the baseline
        total = abs(b["total_energy"]) if _finite(b["total_energy"]) else 0.0
        for i, (eb, en) in enumerate(zip(b["energies"], n["energies"], strict=False)):
            if _finite(eb) and _finite(en) and abs(en - eb) > rel * max(abs(eb), total, 1e-12):
                out.append(Difference(name, f"leg {i + 1} energy", eb, en, False))
    return out


def _finite(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


SUMMARY_KEYS = ("status", "total_energy", "errors", "energies")  # `summary_of`'s
BASELINE_KEYS = ("schema", "tolerances", "scenarios")


def _known_keys(doc: dict, known: tuple[str, ...], where: str) -> None:
    """A key a person misspelt is an error, not passed over: a top-level `tolerance` left
    the defaults in force without a word."""
    for key in doc:
        if key not in known:
            near = closest_choice(str(key), known, cutoff=0.7)  # 'energy': 'energies'
            hint = f"did you mean {near!r}?" if near else f"known: {', '.join(known)}"
            raise ValueError(f"{where}{'.' if where else ''}{key}: unknown key ({hint})")


def _check_summary(name: str, entry: Any) -> None:
    """Raise ValueError naming what is wrong with one scenario's entry of a baseline."""
    where = f"scenarios.{name}"
    if not isinstance(entry, dict):
        raise ValueError(f"{where} is not an object")
    _known_keys(entry, SUMMARY_KEYS, where)
    for key in SUMMARY_KEYS:
        if key not in entry:
            raise ValueError(f"{where}.{key} is missing")
    if entry["status"] not in ("ok", "failed"):
        raise ValueError(f"{where}.status is {entry['status']!r}, not 'ok' or 'failed'")
    failed = entry["status"] == "failed"  # a failed plan may have no energy or error (null)
    if not (_finite(entry["total_energy"]) or (failed and entry["total_energy"] is None)):
        raise ValueError(f"{where}.total_energy is {entry['total_energy']!r}, not a number")
    for key in ("errors", "energies"):
        values = entry[key]
        if not isinstance(values, list):
            raise ValueError(f"{where}.{key} is not a list")
        for i, x in enumerate(values):
            if not (_finite(x) or (failed and x is None)):
                raise ValueError(f"{where}.{key}[{i}] is {x!r}, not a number")
    if len(entry["errors"]) != len(entry["energies"]):
        raise ValueError(f"{where}: errors and energies differ in length")


def _check_tolerances(tolerances: Any) -> dict[str, float]:
    if not isinstance(tolerances, dict):
        raise ValueError("tolerances is not an object")
    _known_keys(tolerances, tuple(DEFAULT_TOLERANCES), "tolerances")
    for key, value in tolerances.items():
        if not _finite(value) or value < 0:
            raise ValueError(f"tolerances.{key} is {value!r}, not a number >= 0")
    return DEFAULT_TOLERANCES | tolerances


def load_baseline(path: Path) -> tuple[dict[str, dict], dict[str, float]]:
    """The scenarios and tolerances of a baseline file, checked entry by entry.

    Parameters
    ----------
    path : Path
        Baseline JSON file (schema ``stratplan.baseline/1``).

    Returns
    -------
    tuple
        Scenario name → summary (as `summary_of`), and the tolerances (defaults filled in).

    Raises
    ------
    InputError
        One line naming the file and what is wrong: missing, not JSON, not an object, a
        missing key, a value of the wrong type, NaN or infinity, a negative tolerance.
    """
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"baseline file {path} does not exist (create it with --update)") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"baseline file {path}: unreadable ({exc})") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"baseline file {path}: not JSON ({exc})") from None
    if not isinstance(doc, dict):
        raise InputError(f"baseline file {path}: not a JSON object but a {type(doc).__name__}")
    if doc.get("schema") != SCHEMA:
        raise InputError(f"baseline file {path}: schema must be {SCHEMA!r}")
    try:
        _known_keys(doc, BASELINE_KEYS, "")
        scenarios = doc.get("scenarios")
        if not isinstance(scenarios, dict):
            raise ValueError("scenarios is missing or not an object")
        for name, entry in scenarios.items():
            _check_summary(name, entry)
        tolerances = _check_tolerances(doc.get("tolerances", {}))
    except ValueError as exc:
        raise InputError(f"baseline file {path}: {exc}") from None
    return scenarios, tolerances


def baseline_document(now: dict[str, dict], tolerances: dict[str, float]) -> dict[str, Any]:
    """The baseline file's document: its schema, `tolerances` and each scenario's summary."""
    return {"schema": SCHEMA, "tolerances": tolerances, "scenarios": now}
