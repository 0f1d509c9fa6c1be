"""Reading run records back: find, validate and list run directories (no re-planning).

A record is checked before anything is shown of it: result.json and manifest.json must be
JSON objects, and every field `show` and `runs` read must have its type (`check_result`,
`check_manifest`), so a damaged record is one `InputError` naming the file and the field,
never a traceback half-way through a table.
"""

from __future__ import annotations

import json
import math
import struct
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from shlex import quote  # a path in a command to paste: spaces, quotes
from typing import Any

from ..errors import InputError
from ..status import Status
from ..wording import counted

REQUIRED = ("scenario.toml", "result.json", "manifest.json")


@dataclass
class Record:
    path: Path
    result: dict[str, Any]
    manifest: dict[str, Any]
    comparison: dict[str, Any] | None = None  # comparison.json of a compare/auto-mode record

    @property
    def started(self) -> str:
        return str(self.manifest.get("started", ""))


def is_partial(path: Path) -> bool:
    """A directory still being written (or left by a killed run) has a temporary name."""
    return path.name.startswith(".") or path.name.endswith(".partial")


_KINDS: dict[str, tuple[str, Callable[[Any], bool]]] = {
    "str": ("a string", lambda x: isinstance(x, str)),
    "int": ("an integer", lambda x: isinstance(x, int) and not isinstance(x, bool)),
    "num": ("a number", lambda x: isinstance(x, int | float) and not isinstance(x, bool)),
    "bool": ("true or false", lambda x: isinstance(x, bool)),
    "list": ("a list", lambda x: isinstance(x, list)),
    "dict": ("an object", lambda x: isinstance(x, dict)),
}
RESULT_FIELDS = {
    "scenario": "str",
    "model": "str",
    "continuity": "str",
    "tolerance": "num",
    "status": "str",
    "total_energy": "num?",
    "legs": "list",
    "switches": "list",
    "time_scale": "num-",  # "-": may be absent
    "reference_energy": "num?-",
    "notes": "list?-",
    "optimisation": "dict?-",
    "message": "str?-",  # (a hand-edited 5, "x" or list: show died in a TypeError)
    "planned_legs": "int-",
    "constraints": "dict?-",
}
CONSTRAINT_FIELDS = {"spec": "dict-", "legs": "list-", "violation": "dict?-"}
LEG_FIELDS = {
    "stratum": "str",
    "method": "str",
    "evaluator": "str",
    "iterations": "int",
    "attempts": "int",
    "error": "num?",
    "energy": "num?",
    "converged": "bool",
    "duration": "num",
    "pieces": "list",
}
PIECE_FIELDS = {"duration": "num", "basis": "dict"}
BASIS_FIELDS = {"harmonics": "int", "period": "num"}
START_FIELDS = {"index": "int", "energy": "num?", "iterations": "int", "projected_gradient": "num"}
MANIFEST_FIELDS = {
    "started": "str-",
    "planning_time_s": "num-",
    "compile_time_s": "num-",
    "exit_code": "int?-",
}


def _check(doc: dict, fields: dict[str, str], where: str) -> None:
    for key, spec in fields.items():
        kind = spec.rstrip("?-")
        if key not in doc:
            if not spec.endswith("-"):
                raise ValueError(f"{where}{key} is missing")
            continue
        value = doc[key]
        if value is None and "?" in spec:
            continue
        what, ok = _KINDS[kind]
        if not ok(value):
            raise ValueError(f"{where}{key} is {json.dumps(value)[:40]}, not {what}")


def _check_list(items: list, fields: dict[str, str], where: str) -> None:
    for i, item in enumerate(items):
        if not isinstance(item, dict):
            raise ValueError(f"{where}[{i}] is not an object")
        _check(item, fields, f"{where}[{i}].")


def check_result(doc: Any) -> None:
    """Raise ValueError naming the first field of a result.json that `show` or `runs` could
    not read (missing, or of the wrong type)."""
    if not isinstance(doc, dict):
        raise ValueError(f"not a JSON object but {json.dumps(doc)[:40]}")
    if doc.get("schema") != "stratplan.result/1":
        raise ValueError(f"unknown schema {doc.get('schema')!r}")
    _check(doc, RESULT_FIELDS, "")
    _one_of(doc["status"], RESULT_STATUSES, "status")
    _check_list(doc["legs"], LEG_FIELDS, "legs")
    for i, leg in enumerate(doc["legs"]):
        if "status" in leg:
            _one_of(leg["status"], LEG_STATUSES, f"legs[{i}].status")
        _check_list(leg["pieces"], PIECE_FIELDS, f"legs[{i}].pieces")
        for j, piece in enumerate(leg["pieces"]):
            _check(piece["basis"], BASIS_FIELDS, f"legs[{i}].pieces[{j}].basis.")
            _check_coefficients(piece, f"legs[{i}].pieces[{j}].coefficients")
    _check_total(doc)
    if doc["status"] == "ok":  # (load_run reads the status from the legs)
        for i, leg in enumerate(doc["legs"]):
            if leg.get("status", "success") != "success":
                raise ValueError(f'status is "ok" but legs[{i}].status is "{leg["status"]}"')
    for i, switch in enumerate(doc["switches"]):
        jump = switch.get("jump") if isinstance(switch, dict) else None
        number = _KINDS["num"][1]  # null: a numerical failure left no value (nan_to_none)
        numbers = isinstance(jump, dict) and all(v is None or number(v) for v in jump.values())
        if not numbers or not jump:
            raise ValueError(f"switches[{i}].jump is not an object of numbers")
    if not all(isinstance(note, str) for note in doc.get("notes") or []):
        raise ValueError("notes holds something other than text")
    if isinstance(limits := doc.get("constraints"), dict):
        _check(limits, CONSTRAINT_FIELDS, "constraints.")
        if not all(isinstance(leg, dict) for leg in limits.get("legs") or []):
            raise ValueError("constraints.legs holds something other than objects")
    opt = doc.get("optimisation") or {}
    if opt.get("best") is not None:
        _check(opt, {"best": "int", "starts": "list", "newton_energy": "num?"}, "optimisation.")
        _check_list(opt["starts"], START_FIELDS, "optimisation.starts")
        if not 0 <= opt["best"] < len(opt["starts"]):
            raise ValueError("optimisation.best is not the index of a start")


RESULT_STATUSES = ("ok", "failed")
LEG_STATUSES = tuple(status.name.lower() for status in Status)


def _one_of(value: Any, allowed: tuple[str, ...], where: str) -> None:
    if value not in allowed:  # (show read 'weird' as failed, load_run as ok)
        raise ValueError(f"{where} is {json.dumps(value)[:40]}, not one of {', '.join(allowed)}")


def _check_coefficients(piece: dict, where: str) -> None:
    """Each input's coefficients: 2H + 1 numbers, H the piece's harmonics (a list of 3 for
    H = 3 reached numpy as a ragged array)."""
    rows, size = piece.get("coefficients", {}), 2 * piece["basis"]["harmonics"] + 1
    if not isinstance(rows, dict):
        raise ValueError(f"{where} is not an object")
    number = _KINDS["num"][1]
    for name, row in rows.items():
        if not isinstance(row, list) or len(row) != size or not all(map(number, row)):
            raise ValueError(f"{where}.{name} is not {size} numbers (2H + 1 of the basis)")


def _check_total(doc: dict) -> None:
    """total_energy is the sum of the legs' energies (load_run recomputes it from them: a
    hand-edited total read one way in show, another in Python)."""
    total, energies = doc["total_energy"], [leg["energy"] for leg in doc["legs"]]
    if total is None or any(e is None for e in energies):
        return
    legs = float(sum(energies))
    if abs(total - legs) > 1e-9 * max(abs(legs), 1.0):
        raise ValueError(f"total_energy is {total:.6g}, not the sum of the legs' ({legs:.6g})")


def check_manifest(doc: Any) -> None:
    """Raise ValueError naming the first field of a manifest.json that `show` could not read."""
    if not isinstance(doc, dict):
        raise ValueError(f"not a JSON object but {json.dumps(doc)[:40]}")
    _check(doc, MANIFEST_FIELDS, "")


def read_record(path: Path) -> Record:
    """The record in `path`, checked field by field.

    Parameters
    ----------
    path : Path
        A run directory.

    Returns
    -------
    Record
        Its result.json and manifest.json as dicts.

    Raises
    ------
    InputError
        One line naming the file and what is wrong, when the record is missing, incomplete,
        unreadable or damaged.
    """
    if path.is_file() and (path.parent / "result.json").is_file():  # a file of a record
        raise InputError(f"{path} is a file of a run record: give its directory, {path.parent}")
    if not path.is_dir():
        raise InputError(f"no run record at {path}")
    if is_partial(path):
        raise InputError(f"{path} is an incomplete record (the run was interrupted)")
    missing = [f for f in REQUIRED if not (path / f).is_file()]
    if len(missing) == len(REQUIRED):  # `runs`, say, where `plan` writes its records?
        if inside := _records_inside(path):
            raise InputError(
                f"{path} is a folder of {counted(len(inside), 'run record')}, "
                f"not one: give one of them (the latest: {path / inside[-1]})"
            )
    if missing:
        raise InputError(f"{path} is not a complete run record: missing {', '.join(missing)}")
    result, manifest = (
        _document(path / name, check)
        for name, check in (("result.json", check_result), ("manifest.json", check_manifest))
    )
    comparison = path / "comparison.json"  # a compare-sequences or auto-mode record's
    found = _document(comparison, _check_comparison) if comparison.is_file() else None
    return Record(path, result, manifest, comparison=found)


def _document(file: Path, check: Callable[[Any], None]) -> dict[str, Any]:
    """The JSON document in `file`, `check`ed, or an InputError naming the file."""
    try:
        doc = json.loads(file.read_text(encoding="utf-8"))
        _no_nan(doc, "")
        check(doc)
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{file}: unreadable ({exc})") from None
    except ValueError as exc:  # also json.JSONDecodeError
        raise InputError(f"{file}: damaged record: {exc}") from None
    return doc


def _no_nan(doc: Any, where: str) -> None:
    """Raise ValueError naming the first NaN or Infinity in `doc`: Python's json reads them,
    JSON has none (stratplan writes null), and `runs --json` passed them on as invalid JSON."""
    if isinstance(doc, float) and not math.isfinite(doc):
        raise ValueError(
            f"{where or 'the document'} is {doc}, not a JSON number (stratplan writes null)"
        )
    items = (
        doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    )
    for key, value in items:
        _no_nan(
            value,
            f"{where}[{key}]" if isinstance(key, int) else f"{where}{'.' if where else ''}{key}",
        )


def _check_comparison(doc: Any) -> None:
    """Raise ValueError naming what `show` could not read in a comparison.json."""
    if not isinstance(doc, dict) or doc.get("schema") != "stratplan.comparison/1":
        raise ValueError("not a stratplan.comparison/1 document")
    if not isinstance(doc.get("choice", ""), str) or not isinstance(doc.get("rows", []), list):
        raise ValueError("choice or rows of the wrong type")


def mcap_summary(path: Path) -> dict[str, Any] | None:
    """Topics of a record's run.mcap with message counts and time span, read back from the
    file's summary section (no re-planning); None when the record has no MCAP; InputError
    naming the file when it cannot be read."""
    from mcap.exceptions import McapError  # here: `runs` needs no MCAP reader
    from mcap.reader import make_reader

    file = path / "run.mcap"
    if not file.is_file():
        return None
    try:
        with open(file, "rb") as fh:
            summary = make_reader(fh).get_summary()
    except (OSError, ValueError, KeyError, struct.error, McapError) as exc:
        raise InputError(f"{file}: damaged MCAP log ({type(exc).__name__}: {exc})") from None
    if summary is None or summary.statistics is None:
        return None
    stats = summary.statistics
    counts = {summary.channels[cid].topic: n for cid, n in stats.channel_message_counts.items()}
    return {
        "messages": stats.message_count,
        "topics": dict(sorted(counts.items())),
        "duration_s": (stats.message_end_time - stats.message_start_time) / 1e9,
        "metadata": stats.metadata_count,
        "attachments": stats.attachment_count,
    }


def _records_inside(path: Path) -> list[str]:
    """The names of the run records directly in `path`, sorted (a folder of records)."""
    found = (d.name for d in path.iterdir() if (d / "result.json").is_file())
    return sorted(name for name in found if not name.startswith("."))


def list_records(out: Path, on_damaged: Callable[[str], None] | None = None) -> list[Record]:
    """Complete records under `out`, newest first.

    Parameters
    ----------
    out : Path
        Directory of run records.
    on_damaged : callable, optional
        Called with one line for each directory skipped as a damaged or incomplete record
        (partial directories of runs still writing, or killed, and folders holding neither
        result.json nor manifest.json are skipped silently).

    Returns
    -------
    list of Record
    """
    if not out.is_dir():
        return []
    records = []
    for path in out.iterdir():
        try:
            found = _listed(path, on_damaged)
        except PermissionError as exc:  # one unreadable run: it, not the whole listing
            found = None
            if on_damaged is not None:
                on_damaged(f"{exc.filename or path}: permission denied")
        if found is not None:
            records.append(found)
    return sorted(records, key=lambda r: (r.started, r.path.name), reverse=True)


def _listed(path: Path, on_damaged: Callable[[str], None] | None) -> Record | None:
    """The record in `path` for `list_records`, or None (said to `on_damaged` if damaged)."""
    if not path.is_dir() or is_partial(path):
        return None
    if not (path / "result.json").exists() and (inside := _records_inside(path)):
        if on_damaged is not None:  # a sweep's records/, say: not a damaged record
            many = counted(len(inside), "run record")
            on_damaged(
                f"{path} is a folder of {many}: `stratplan runs {quote(str(path))}` lists them"
            )
        return None
    if not any((path / name).exists() for name in ("result.json", "manifest.json")):
        return None  # no file of a record: some other folder, not a damaged record
    try:
        return read_record(path)
    except InputError as exc:
        if on_damaged is not None:
            on_damaged(str(exc))
        return None
