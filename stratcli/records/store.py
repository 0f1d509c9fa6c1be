"""Reading run records back: find, validate and list run directories (no re-planning)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.reader import make_reader

from ..errors import InputError

REQUIRED = ("scenario.toml", "result.json", "manifest.json")


@dataclass
class Record:
    path: Path
    result: dict[str, Any]
    manifest: dict[str, Any]

    @property
    def started(self) -> str:
        return str(self.manifest.get("started", ""))


def is_partial(path: Path) -> bool:
    """A directory still being written (or left by a killed run) has a temporary name."""
    return path.name.startswith(".") or path.name.endswith(".partial")


def read_record(path: Path) -> Record:
    """The record in `path`; InputError when it is missing, incomplete or unreadable."""
    if not path.is_dir():
        raise InputError(f"no run record at {path}")
    if is_partial(path):
        raise InputError(f"{path} is an incomplete record (the run was interrupted)")
    missing = [f for f in REQUIRED if not (path / f).is_file()]
    if missing:
        raise InputError(f"{path} is not a complete run record: missing {', '.join(missing)}")
    try:
        result = json.loads((path / "result.json").read_text())
        manifest = json.loads((path / "manifest.json").read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: unreadable record ({exc})") from None
    if result.get("schema") != "stratplan.result/1":
        raise InputError(f"{path}/result.json: unknown schema {result.get('schema')!r}")
    return Record(path, result, manifest)


def mcap_summary(path: Path) -> dict[str, Any] | None:
    """Topics of a record's run.mcap with message counts and time span, read back from the
    file's summary section (no re-planning); None when the record has no MCAP."""
    file = path / "run.mcap"
    if not file.is_file():
        return None
    with open(file, "rb") as fh:
        summary = make_reader(fh).get_summary()
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


def list_records(out: Path) -> list[Record]:
    """Complete records under `out`, newest first."""
    if not out.is_dir():
        return []
    records = []
    for path in out.iterdir():
        if path.is_dir() and not is_partial(path):
            try:
                records.append(read_record(path))
            except InputError:
                continue
    return sorted(records, key=lambda r: (r.started, r.path.name), reverse=True)
