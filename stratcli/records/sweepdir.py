"""A sweep directory: the durable log of rows, the results table and the summary.

Layout of ``SWEEPDIR``::

    sweep.toml      the sweep file as given, naming   spec.json   what --resume must match
    scenario.toml   its base scenario's copy (and a URDF base's robot: `model_files`)
    rows.jsonl      one JSON object per finished task, appended and fsync'd as it completes
    results.csv     the rows in task order (written at the end, rewritten by --resume)
    sweep.json      summary: counts, success rate, executor and workers, wall time
    *.png           plots (`sweep_plots`)                 records/    run records asked for

`rows.jsonl` is the only file the planning writes while it runs: a task's row is one line,
written whole with one `write`, flushed and fsync'd before the next task's row. A sweep killed
at any instant leaves complete lines and at most one torn last line, which `read_rows` ignores
(and `RowLog` cuts off before appending), so the task is planned again on `--resume`.

The table is CSV, not Parquet: a sweep of thousands of tasks is well under a megabyte of CSV,
every tool reads it, and floats are written with `repr` (they read back exactly). pyarrow
would add a ~100 MB dependency for typed columns and compression that this size does not need.
"""

from __future__ import annotations

import csv
import io
import json
import os
from pathlib import Path
from typing import Any

from ..errors import InputError, Problem
from .rundir import dangling_link, finite_or_none
from .sweeplock import CLAIM

ROWS = "rows.jsonl"
SPEC = "spec.json"
TABLE = "results.csv"
SUMMARY = "sweep.json"
FILE_TEXT = "sweep.toml"
FORMAT = "stratplan.sweep/1"
RECORDS_DIR = "records"
NAMES = (ROWS, SPEC, TABLE, SUMMARY, FILE_TEXT, RECORDS_DIR, CLAIM)  # none a copy may take
# the columns after the task's inputs, in order; compare mode adds "ranking"
COLUMNS = (
    "status",
    "energy",
    "peak_control",
    "excursion",
    "duration",
    "legs",
    "sequence",
    "candidates",
    "reached",
    "seed",
    "planning_time_s",
    "task_time_s",
    "worker",
    "message",
)


def is_sweep_dir(path: Path) -> bool:
    """Whether `path` is a sweep directory (it holds spec.json and rows.jsonl)."""
    return (Path(path) / SPEC).is_file()


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:  # pragma: no cover - not every platform opens directories
        return
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_atomic(path: Path, data: bytes) -> None:
    """Write `path` whole or not at all (temporary file, fsync, rename); a symbolic link's
    target is written, the link kept (the rename had put a plain file in its place)."""
    path = Path(os.path.realpath(path))
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    _fsync_dir(path.parent)


def write_json(path: Path, doc: Any) -> None:
    """`doc` as indented JSON in `path`, whole or not at all, with NaN and infinities as null
    (`regress --update` wrote a failed scenario's NaN energy, and the next `regress` refused
    its own baseline; a run killed while writing had left it truncated)."""
    text = json.dumps(finite_or_none(doc), indent=2, allow_nan=False)
    write_atomic(Path(path), (text + "\n").encode())


def prepare(
    out: Path, spec: dict[str, Any], files: dict[str, str], resume: bool
) -> dict[int, dict]:
    """Create (or, with `resume`, reopen) the sweep directory; the rows already in it.

    Raises
    ------
    InputError
        `out` is not a usable directory, holds other files than a sweep's, already holds a
        sweep (without `resume`), or holds a different sweep than `spec` (with `resume`).
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError([Problem("out", "not a directory", given=str(out))])
    existing = out / SPEC
    if not existing.exists() and out.is_dir():
        _refuse_foreign_files(out, set(files))
    if existing.exists():
        try:
            found = json.loads(existing.read_text())
        except (OSError, ValueError) as exc:
            raise InputError(f"{existing}: cannot be read ({exc})") from None
        if not resume:
            raise InputError([_already(out, found)])
        if found.get("digest") != spec["digest"]:
            why = f"{out} holds the sweep of another sweep file (or a changed one); "
            raise InputError(
                [
                    Problem(
                        "resume",
                        why + "use the same file, or another out",
                        flag_message=why + "use the same file, or another --out",
                    )
                ]
            )
        return read_rows(out / ROWS)
    if gone := dangling_link(out):
        raise InputError([Problem("out", gone, given=str(out))])
    try:
        out.mkdir(parents=True, exist_ok=True)
        for name, text in files.items():  # (before spec.json, which makes it a sweep's)
            write_atomic(out / name, text.encode())
        write_atomic(out / SPEC, (json.dumps(spec, indent=2) + "\n").encode())
    except OSError as exc:
        why = f"cannot write there ({exc.strerror or exc})"
        raise InputError([Problem("out", why, given=str(out))]) from None
    return {}


def finished_summary(out: Path, rows: dict[int, Any], count: Any) -> dict[str, Any] | None:
    """sweep.json of a finished sweep in `out`, or None: finished means a row for every one
    of its `count` tasks and a sweep.json that counts them all (a sweep killed after its last
    row, before its summary, is not finished: --resume writes the summary)."""
    if not isinstance(count, int) or sum(0 <= k < count for k in rows) < count:
        return None
    summary = read_summary(out)
    return summary if isinstance(summary, dict) and summary.get("done") == count else None


def read_summary(out: Path) -> Any:
    """sweep.json in `out` as parsed, or None when there is none or it does not parse."""
    try:
        return json.loads((Path(out) / SUMMARY).read_text())
    except (OSError, ValueError):
        return None


def _already(out: Path, spec: dict[str, Any]) -> Problem:
    """Why `out`, a sweep directory, is refused without `resume`: finished or not (in
    Python's words, and the command line's, which name its flags)."""
    count = spec.get("count")
    rows = read_rows(out / ROWS)
    done = sum(0 <= k < count for k in rows) if isinstance(count, int) else len(rows)
    if finished_summary(out, rows, count) is not None:
        tasks = "1 task, done" if count == 1 else f"{count} tasks, all done"
        what = f"already holds a finished sweep ({tasks}); "
        return Problem(
            "out",
            what + "resume=True would only return it again (as stratcli.read_sweep reads it); "
            "choose another out to run it again",
            given=str(out),
            flag_message=what + "--resume would only print its summary again (as stratplan "
            f"show {out} does); choose another --out to run it again",
        )
    if isinstance(count, int) and done >= count:
        what = "already holds a sweep, all tasks done, its summary not written; "
        return Problem(
            "out",
            what + "resume=True writes it (or choose another out)",
            given=str(out),
            flag_message=what + "--resume writes it (or choose another --out)",
        )
    of = f" of {count}" if isinstance(count, int) else ""
    what = f"already holds a sweep, unfinished ({done}{of} tasks done); add "
    return Problem(
        "out",
        what + "resume=True to finish it, or choose another out",
        given=str(out),
        flag_message=what + "--resume to finish it, or choose another --out",
    )


def _refuse_foreign_files(out: Path, ours: set[str]) -> None:
    """A sweep is not written among other files (run records, say): `out` must be empty, or
    hold only what a sweep killed at its very start left (`ours`: its copies of the sweep
    file and base scenario; temporary files)."""
    foreign = sorted(
        p.name
        for p in out.iterdir()
        if p.name not in (*ours, FILE_TEXT, CLAIM)
        and not (p.name.startswith(".") and p.name.endswith(".tmp"))
    )
    if foreign:
        more = f" and {len(foreign) - 1} more" if len(foreign) > 1 else ""
        held = f"it holds {foreign[0]!r}{more}"
        why = f"not a sweep directory and not empty ({held}); choose a new or empty directory"
        raise InputError([Problem("out", why, given=str(out))])


def read_rows(path: Path) -> dict[int, dict[str, Any]]:
    """The complete rows of a rows.jsonl, by task index (a torn or damaged line is skipped;
    the first row of an index wins)."""
    rows: dict[int, dict[str, Any]] = {}
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        return rows
    for line in data.split(b"\n"):
        try:
            row = json.loads(line)
        except ValueError:
            continue
        if isinstance(row, dict) and isinstance(row.get("index"), int):
            rows.setdefault(row["index"], row)
    return rows


class RowLog:
    """rows.jsonl opened for appending: `append(row)` returns once the row is on disk."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self._fh = open(self.path, "ab")  # closed by close()
        self._cut_torn_tail()
        _fsync_dir(self.path.parent)

    def _cut_torn_tail(self) -> None:
        size = self._fh.seek(0, os.SEEK_END)
        if size == 0:
            return
        with open(self.path, "rb") as fh:
            data = fh.read()
        keep = data.rfind(b"\n") + 1
        if keep != size:  # a line torn by a kill: cut it, the task is planned again
            self._fh.truncate(keep)
            self._fh.seek(keep)

    def append(self, row: dict[str, Any]) -> None:
        line = json.dumps({k: finite_or_none(v) for k, v in row.items()}, allow_nan=False) + "\n"
        self._fh.write(line.encode())
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def close(self) -> None:
        self._fh.close()

    def __enter__(self) -> RowLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def columns(keys: list[str], rows: list[dict[str, Any]]) -> list[str]:
    """The table's columns: index, the inputs, then `COLUMNS` (and any other key rows have)."""
    cols = ["index", *keys, *COLUMNS]
    for row in rows:
        cols.extend(k for k in row if k not in cols)
    return cols


def in_table_order(keys: list[str], rows: dict[int, dict[str, Any]]) -> dict[int, dict]:
    """The rows by task index, each row's keys in results.csv's column order (`columns`):
    ``pandas.DataFrame(list(rows.values())).set_index("index")`` is the table (the rows came
    in the order their tasks finished, and two sweeps' frames compared unequal until sorted)."""
    order = sorted(rows)
    cols = columns(keys, [rows[k] for k in order])
    return {k: {c: rows[k][c] for c in cols if c in rows[k]} for k in order}


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def table_text(keys: list[str], rows: dict[int, dict[str, Any]]) -> str:
    """The rows as CSV, in task order."""
    ordered = [rows[k] for k in sorted(rows)]
    cols = columns(keys, ordered)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(cols)
    for row in ordered:
        writer.writerow([_cell(row.get(c)) for c in cols])
    return buf.getvalue()


def write_outputs(out: Path, keys: list[str], rows: dict[int, dict], summary: dict) -> None:
    """results.csv and sweep.json, each written atomically."""
    write_atomic(Path(out) / TABLE, table_text(keys, rows).encode())
    write_json(Path(out) / SUMMARY, summary)  # (a NaN at any depth: null)


def read_sweep_dir(out: Path) -> tuple[dict[str, Any], dict[int, dict], dict[str, Any] | None]:
    """(spec.json, the rows, sweep.json or None when the sweep never finished)."""
    out = Path(out)
    try:
        spec = json.loads((out / SPEC).read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"{out / SPEC}: not a sweep directory's spec ({exc})") from None
    if not isinstance(spec, dict) or spec.get("format") != FORMAT:
        raise InputError(f"{out / SPEC}: not a {FORMAT} file")
    return spec, read_rows(out / ROWS), read_summary(out)
