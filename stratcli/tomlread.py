"""Guarded reading of scenario files: bounded size, UTF-8, bounded nesting, finite numbers.

A scenario is a small hand-written file. These checks make anything else (``/dev/zero``, a
FIFO, a file of hundreds of MB, binary bytes, a 100,000-deep nested array, ``nan`` or ``inf``
values) end in one `InputError` line instead of a traceback, a hang or a memory blow-up.

Limits
------
* `MAX_BYTES` (1 MB): at most `MAX_BYTES + 1` bytes are ever read.
* `MAX_DEPTH` (64): arrays and inline tables nested deeper are refused before parsing.
* Every float in the parsed document must be finite (TOML allows ``nan`` and ``inf``).
"""

from __future__ import annotations

import math
import os
import re
import stat
import tomllib
from collections.abc import Mapping
from pathlib import Path
from shlex import quote  # a path in a command to paste: spaces, quotes
from typing import Any, NoReturn

from .errors import InputError, Problem

MAX_BYTES = 1_000_000
MAX_DEPTH = 64

__all__ = [
    "MAX_BYTES",
    "MAX_DEPTH",
    "finite_stand_ins",
    "is_toml_text",
    "is_xml_text",
    "parse_toml",
    "plain",
    "raise_non_finite",
    "read_scenario_text",
    "read_source",
    "reject_non_finite",
]


def is_toml_text(source: str) -> bool:
    """Whether a string given for a file is TOML text rather than a path: it has a newline,
    or an "=" and names no existing file (a path such as ``runs/lr=0.1/sweep.toml`` is one)."""
    return "\n" in source or ("=" in source and not os.path.exists(source))


def read_scenario_text(path: str | Path, limit: int = MAX_BYTES, kind: str = "scenario") -> str:
    """The text of a scenario file, read with bounded memory.

    Parameters
    ----------
    path : file to read; must be a regular file.
    limit : largest accepted size in bytes.
    kind : what the file is, as messages name it ("scenario", "sweep").

    Returns
    -------
    The file decoded as UTF-8.

    Raises
    ------
    InputError
        Not a regular file, unreadable, larger than `limit`, or not UTF-8 (the offset of the
        first bad byte is named).
    """
    source = str(path)
    try:
        # stat before opening: opening a FIFO would block until someone writes to it
        if not stat.S_ISREG(os.stat(path).st_mode):
            raise InputError(f"not a regular file (a {kind} must be a .toml file)", source)
        with open(path, "rb") as fh:
            if not stat.S_ISREG(os.fstat(fh.fileno()).st_mode):
                raise InputError(f"not a regular file (a {kind} must be a .toml file)", source)
            data = fh.read(limit + 1)
    except OSError as exc:
        raise InputError(f"cannot read {kind} file: {exc.strerror or exc}", source) from None
    if len(data) > limit:
        raise InputError(f"file is larger than {limit} bytes; a {kind} is a small file", source)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(
            f"not UTF-8 text: byte 0x{data[exc.start]:02x} at offset {exc.start}", source
        ) from None
    if (nul := text.find("\x00")) >= 0:  # TOML's message quoted the raw bytes
        raise InputError(f"not a text file: a NUL byte at offset {nul}", source)
    return text.removeprefix("\ufeff")  # a byte-order mark (Windows editors): not TOML's


def _nesting_depth(text: str) -> int:
    """Deepest nesting of [ ] and { } outside strings and comments (an upper bound is enough).

    Table headers (``[a]``, ``[[a]]``) count as depth 1 or 2 only, so they never trip the limit.
    """
    depth = deepest = 0
    i, n = 0, len(text)
    quote = ""
    while i < n:
        c = text[i]
        if quote:
            if c == "\\" and quote in ('"', '"""'):
                i += 2
                continue
            if text.startswith(quote, i):
                i += len(quote)
                quote = ""
                continue
        elif c == "#":
            j = text.find("\n", i)
            i = n if j < 0 else j
            continue
        elif c in "\"'":
            quote = c * 3 if text.startswith(c * 3, i) else c
            i += len(quote)
            continue
        elif c in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif c in "]}":
            depth = max(0, depth - 1)
        i += 1
    return deepest


def parse_toml(text: str, source: str = "<scenario>", max_depth: int = MAX_DEPTH) -> dict:
    """Parse TOML text with bounded nesting.

    Parameters
    ----------
    text : the document.
    source : file name used in error messages.
    max_depth : deepest accepted nesting of arrays and inline tables.

    Returns
    -------
    The parsed document.

    Raises
    ------
    InputError
        Invalid TOML, nesting deeper than `max_depth`, or a document tomllib cannot handle.
    """
    brackets = text.count("[") + text.count("{")
    if brackets > max_depth and _nesting_depth(text) > max_depth:
        raise InputError(f"arrays or inline tables nested more than {max_depth} levels", source)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"not valid TOML: {_with_line(str(exc), text)}", source) from None
    except (RecursionError, MemoryError):
        raise InputError("arrays or inline tables nested too deeply to parse", source) from None


def plain(raw: Mapping[str, Any], max_depth: int = MAX_DEPTH) -> dict[str, Any]:
    """A dict source as the TOML file it stands for: numpy scalars (``np.int64(5)``,
    ``np.True_``) as Python's (``.item()``), numpy arrays and tuples as lists, mappings as
    dicts, paths (`os.PathLike`) as strings; a copy, `raw` is left as it is.

    Raises
    ------
    InputError
        Nested more than `max_depth` levels (as a TOML file may not be).
    """

    def convert(value: Any, depth: int) -> Any:
        if depth > max_depth:
            raise InputError(f"tables or lists nested more than {max_depth} levels")
        if isinstance(value, Mapping):
            return {key: convert(item, depth + 1) for key, item in value.items()}
        if type(value).__module__ == "numpy" and hasattr(value, "tolist"):
            value = value.tolist()  # np.generic: the Python scalar; np.ndarray: nested lists
        if isinstance(value, list | tuple):
            return [convert(item, depth + 1) for item in value]
        if isinstance(value, os.PathLike):  # a notebook's pathlib.Path: the file's string
            return os.fspath(value)
        return value

    return convert(raw, 0)


def read_source(
    source: Any, name: str | None = None, kind: str = "scenario"
) -> tuple[dict[str, Any], str | None, str, Path | None]:
    """A scenario or sweep as `load_scenario` and `load_sweep` take it: a path (of a TOML
    file, or a JSON one: a record's resolved.json), TOML text (`is_toml_text`) or a dict of
    the file's structure (`plain`).

    Returns
    -------
    tuple
        Its tables; its TOML text (None for a dict); how messages name it (`name`, else the
        path, "<text>" or "<dict>", those two with the source's own name where it has one:
        "<dict 'mine'>"); the folder its relative paths are relative to (None:
        the working directory).

    Raises
    ------
    InputError
        The file cannot be read, is not TOML, or the dict is nested too deeply.
    TypeError
        `source` is none of these.
    """
    from .arguments import wrong_type  # (stdlib only)

    if isinstance(source, Mapping):
        where = name or _anonymous("<dict>", source, kind)
        try:  # numpy values as Python's, here for every caller (sweeps' tasks too)
            tables = plain(source)
        except InputError as exc:
            raise exc.with_source(where) from None
        _of_kind(tables, kind, None, where)
        return tables, None, where, None
    if not isinstance(source, str | os.PathLike):
        raise wrong_type("source", f"a {kind} path, TOML text or a dict", source)
    if isinstance(source, str) and not source.strip():  # Path("") is ".", "not a regular file"
        raise InputError(f"an empty string is no {kind}: give a path, TOML text or a dict")
    if isinstance(source, str) and is_toml_text(source):
        tables = parse_toml(source, name or "<text>")
        where = name or _anonymous("<text>", tables, kind)
        _of_kind(tables, kind, None, where)
        return tables, source, where, None
    path = Path(source)
    where = name or str(path)
    try:
        text = read_scenario_text(path, kind=kind)
    except InputError as exc:
        raise exc.with_source(where) from None
    if path.suffix.lower() == ".json":  # a record's resolved.json, or a script's own
        tables = _json_tables(text, where)
        _of_kind(tables, kind, path, where)
        return tables, None, where, path.parent
    if is_xml_text(text):  # else "not valid TOML: Invalid statement (at line 1, column 1)"
        raise InputError(
            f"XML, not a {kind} file (TOML); a URDF robot is named in a scenario's [model] "
            f'table (kind = "urdf", path = "{path.name}"), and '
            f"`stratplan models {quote(str(path))}` describes it",
            where,
        )
    tables = parse_toml(text, where)
    _of_kind(tables, kind, path, where)
    return tables, text, where, path.parent


def file_tables(text: str, path: Path, where: str) -> dict[str, Any]:
    """The tables of a scenario or sweep file's `text`: JSON for a `.json` path, else TOML."""
    if Path(path).suffix.lower() == ".json":
        return _json_tables(text, where)
    return parse_toml(text, where)


def _json_tables(text: str, where: str) -> dict[str, Any]:
    """The tables of a JSON scenario or sweep file (as a dict source: TOML's structure)."""
    import json

    try:
        tables = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(
            f"not valid JSON: {exc.msg} (at line {exc.lineno}, column {exc.colno})", where
        ) from None
    if not isinstance(tables, dict):
        raise InputError(f"JSON of a {type(tables).__name__}, not an object of tables", where)
    try:
        return plain(tables)
    except InputError as exc:
        raise exc.with_source(where) from None


def _of_kind(tables: Mapping, kind: str, path: Path | None, where: str) -> None:
    """Refuse, in one line, a sweep file given as a scenario or a scenario as a sweep (each
    table of the one was a problem of the other: 4 and 8 lines that did not say so)."""
    file = f" {quote(str(path))}" if path is not None else ""
    sweep = "sweep" in tables and not ({"model", "task"} & set(tables))
    scenario = "sweep" not in tables and bool({"model", "task"} & set(tables))
    if kind == "scenario" and sweep:
        raise InputError(
            "a sweep file (a [sweep] table, no [model] or [task]), not a scenario: run it with "
            f"`stratplan sweep{file}` (in Python: run_sweep)",
            where,
        )
    if kind == "sweep" and scenario:
        raise InputError(
            "a scenario file (a [model] or [task] table, no [sweep]), not a sweep: plan it "
            f"with `stratplan plan{file}`; a sweep file's [sweep] table names it as its "
            "`scenario` (README: Sweeps)",
            where,
        )


def _anonymous(what: str, tables: Mapping, kind: str) -> str:
    """How messages name a scenario or sweep given as a dict or text: by its own `name` where
    it has one (`<dict 'mine'>`; a notebook may build several), else `what`."""
    named = tables.get("sweep") if kind == "sweep" else tables
    name = named.get("name") if isinstance(named, Mapping) else None
    if isinstance(name, str) and re.fullmatch(r"[A-Za-z0-9_-][A-Za-z0-9_.-]{0,99}", name):  # valid
        return f"{what[:-1]} {name!r}>"
    return what


def _with_line(message: str, text: str) -> str:
    """tomllib's message with the line it names quoted ("Cannot overwrite a value (at line
    10, column 17)" did not say which key was given twice)."""
    found = re.search(r"\(at line (\d+), column \d+\)$", message)
    lines = text.splitlines()
    if found is None or not 1 <= int(found.group(1)) <= len(lines):
        return message
    line = lines[int(found.group(1)) - 1].strip()
    line = "".join(c if c.isprintable() else repr(c)[1:-1] for c in line)  # (shown, escaped)
    line = line if len(line) <= 80 else line[:77] + "..."
    twice = " (a key given twice)" if message.startswith("Cannot overwrite a value") else ""
    return f"{message[: found.start()].rstrip()}{twice} {found.group(0)[:-1]}: {line})"


def is_xml_text(text: str) -> bool:
    """Whether a file's text is XML (a URDF, most likely): TOML never starts with "<"."""
    return text.lstrip("\ufeff \t\r\n").startswith("<")


def finite_stand_ins(raw: Any, value: float = 1.0) -> Any:
    """`raw` (parsed TOML) with every NaN or ±inf float replaced by `value`."""
    if isinstance(raw, dict):
        return {k: finite_stand_ins(v, value) for k, v in raw.items()}
    if isinstance(raw, list):
        return [finite_stand_ins(v, value) for v in raw]
    if isinstance(raw, float) and not math.isfinite(raw):
        return value
    return raw


def raise_non_finite(raw: Any, non_finite: list[Problem], attempt, where: str) -> NoReturn:
    """Raise the problems `non_finite` of `raw` (`reject_non_finite`) with every other
    problem of it: those that `attempt` (a loader that raises InputError) finds alike with
    the non-finite values replaced by 1.0 and by 2.0 (a stand-in's own problems, at its
    place or naming its value, differ). A nan no longer hid a misspelt key or a vector of
    the wrong length."""
    found = []
    for value in (1.0, 2.0):
        try:
            attempt(finite_stand_ins(raw, value))
            found.append([])
        except InputError as exc:
            found.append(exc.problems)
    places = [p.path for p in non_finite]
    others = [
        p
        for p in found[0]
        if p in found[1]
        and not any(p.path == at or p.path.startswith((f"{at}.", f"{at}[")) for at in places)
    ]
    raise InputError([*non_finite, *others], where)


def reject_non_finite(raw: Any, prefix: str = "") -> list[Problem]:
    """Problems for every NaN or ±inf float anywhere in a parsed document.

    Parameters
    ----------
    raw : parsed TOML (dicts, lists, scalars).
    prefix : dotted path of `raw` in the document.

    Returns
    -------
    One `Problem` per non-finite value, e.g. ``task.start[1]: must be a finite number
    (got nan)``.
    """
    out: list[Problem] = []
    stack: list[tuple[str, Any]] = [(prefix, raw)]
    while stack:
        where, value = stack.pop()
        if isinstance(value, dict):
            for key, item in reversed(value.items()):
                name = f'"{key}"' if "." in str(key) else str(key)  # a sweep's key: quoted
                stack.append((f"{where}.{name}" if where else name, item))
        elif isinstance(value, list):
            for i in reversed(range(len(value))):
                stack.append((f"{where}[{i}]", value[i]))
        elif isinstance(value, float) and not math.isfinite(value):
            out.append(Problem(where, f"must be a finite number (got {value})"))
    return out
