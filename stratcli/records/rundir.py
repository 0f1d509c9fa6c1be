"""Run directories: one per planning job, written atomically.

Files are written into a hidden temporary directory beside the final one, then the directory
is renamed into place as the very last step, so a run interrupted at any moment never leaves a
directory that looks complete (`runs/<UTC time>-<scenario>-<hash>/`).

The scenario part of the name is cut to `MAX_NAME_BYTES` bytes (the hash of the scenario text
keeps truncated names distinct), so every name fits the usual 255-byte file-name limit with
room for the temporary prefix and suffix. Any `OSError` while writing becomes a `RecordError`
after the temporary directory has been removed. JSON files are strict JSON: a NaN or ±inf
(e.g. the energy of a plan whose legs overflowed) is written as `null`.

The temporary name carries the writer's pid and a tag of its host
(`.<name>.<pid>@<host>.<random>.partial`), so that the partial directories of killed runs can
be told from those of runs still writing: `clean_partials` (called before every write and by
`stratplan runs --clean`) removes the ones whose writer on this host is dead, and any older
than `STALE_AFTER_S`. The directories this process completed are remembered, so that
`mark_interrupted` can say in their manifest.json that the command was interrupted after
writing them.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import shutil
import socket
import tempfile
import time
from collections import deque
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from ..errors import RecordError
from ..interrupts import checkpoint, signals_held

MAX_NAME_BYTES = 100
STALE_AFTER_S = 3600.0  # a partial directory older than this is a killed run's, whoever wrote it
_PARTIAL = re.compile(r"^\..+\.(?P<pid>\d+)@(?P<host>[0-9a-f]{6})\.[^.]+\.partial$")
WRITTEN: deque[Path] = deque(maxlen=16)  # run directories this process completed, newest last


def _host_tag() -> str:
    return hashlib.sha256(socket.gethostname().encode("utf-8", "replace")).hexdigest()[:6]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # e.g. another user's process
        return True
    return True


def _stale(path: Path, now: float, max_age: float) -> bool:
    """A partial directory left by a killed run (never one a running writer is filling)."""
    try:
        age = now - path.lstat().st_mtime
    except OSError:
        return False
    if age > max_age:
        return True
    m = _PARTIAL.match(path.name)
    return bool(m) and m["host"] == _host_tag() and not _alive(int(m["pid"]))


def clean_partials(out: Path, max_age: float = STALE_AFTER_S) -> list[Path]:
    """Remove the hidden `.partial` directories that killed runs left in `out`.

    Parameters
    ----------
    out : Path
        Directory of run records.
    max_age : float
        Seconds after which a partial directory is removed whatever its writer.

    Returns
    -------
    list of Path
        The directories removed. Those of writers still running on this host are kept.
    """
    removed: list[Path] = []
    try:
        entries = list(out.iterdir())
    except OSError:
        return removed
    now = time.time()
    for path in entries:
        hidden_partial = path.name.startswith(".") and path.name.endswith(".partial")
        if not hidden_partial or path.is_symlink() or not path.is_dir():
            continue
        if _stale(path, now, max_age):
            shutil.rmtree(path, ignore_errors=True)
            if not path.exists():
                removed.append(path)
    return removed


def mark_interrupted(exit_code: int, signal_name: str) -> list[Path]:
    """Say in the manifest.json of every record this process completed that the command
    was interrupted afterwards (`interrupted`, `signal`, `exit_code`); each file is replaced
    atomically.

    Parameters
    ----------
    exit_code : int
        The exit code of the interrupted command (130 for SIGINT).
    signal_name : str
        E.g. "SIGINT".

    Returns
    -------
    list of Path
        The manifests rewritten (a record that cannot be updated is left as it is).
    """
    done = []
    for run in WRITTEN:
        path = run / "manifest.json"
        tmp = run / f".manifest.json.{os.getpid()}.tmp"
        try:
            doc = json.loads(path.read_text())
            if not isinstance(doc, dict):
                continue
            doc.update(interrupted=True, signal=signal_name, exit_code=exit_code)
            with open(tmp, "wb") as fh:
                fh.write(_json_bytes(doc))
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, path)
            done.append(path)
        except (OSError, ValueError):
            tmp.unlink(missing_ok=True)
    return done


def run_name(scenario: str, text: str, when: datetime | None = None) -> str:
    """`<UTC time>-<scenario name>-<short hash of the scenario text>`.

    Parameters
    ----------
    scenario : scenario name; cut to `MAX_NAME_BYTES` bytes of UTF-8 (and "/" replaced).
    text : scenario text, hashed.
    when : start time (default now).

    Returns
    -------
    A directory name of at most 128 bytes.
    """
    when = when or datetime.now(UTC)
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()[:8]
    part = scenario.replace("/", "_").replace("\x00", "_")
    part = part.encode("utf-8")[:MAX_NAME_BYTES].decode("utf-8", errors="ignore")
    return f"{when.strftime('%Y%m%dT%H%M%SZ')}-{part}-{digest}"


def finite_or_none(obj: Any) -> Any:
    """`obj` with every non-finite float (at any depth) replaced by None (JSON null)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite_or_none(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [finite_or_none(v) for v in obj]
    return obj


def _json_bytes(content: Any) -> bytes:
    try:
        text = json.dumps(content, indent=2, allow_nan=False)
    except ValueError:  # NaN or inf somewhere: null, as documented above
        text = json.dumps(finite_or_none(content), indent=2, allow_nan=False)
    return (text + "\n").encode()


def write_run(out: Path, name: str, files: dict[str, Any]) -> Path:
    """Write `files` as the run directory `out/name[-k]/`, atomically.

    Parameters
    ----------
    out : directory holding run directories (created if missing).
    name : run directory name (see `run_name`).
    files : file name → content: dict or list (JSON), str (UTF-8) or bytes.

    Returns
    -------
    The path of the complete run directory.

    Raises
    ------
    RecordError
        The directory could not be written; the partial directory has been removed.
    """
    if Path(out).exists() and not Path(out).is_dir():  # ("File exists" said nothing)
        raise RecordError(f"cannot write the run record in {out}: it is a file, not a directory")
    if gone := dangling_link(out):  # (also "File exists")
        raise RecordError(f"cannot write the run record in {out}: it is {gone}")
    try:
        return _write_run(out, name, files)
    except RecordError:
        raise
    except OSError as exc:
        where = exc.filename or out
        raise RecordError(f"cannot write the run record in {where}: {exc.strerror or exc}") from exc


def dangling_link(path: Path) -> str:
    """ "a link to TARGET, which does not exist" where `path` is a symbolic link to nothing
    (making it a directory fails with "File exists", which named neither), else ""."""
    path = Path(path)
    if path.is_symlink() and not path.exists():
        return f"a link to {os.readlink(path)}, which does not exist"
    return ""


def _write_run(out: Path, name: str, files: dict[str, Any]) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    clean_partials(out)
    writer = f"{os.getpid()}@{_host_tag()}"
    tmp = Path(tempfile.mkdtemp(prefix=f".{name}.{writer}.", suffix=".partial", dir=out))
    try:
        for filename, content in files.items():
            if isinstance(content, dict | list):
                data = _json_bytes(content)
            elif isinstance(content, str):
                data = content.encode("utf-8")
            else:
                data = bytes(content)
            with open(tmp / filename, "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
        os.chmod(tmp, 0o755)
        checkpoint()  # an interrupt Python had to drop: no record for an interrupted command
        for k in range(1, 1000):
            final = out / (name if k == 1 else f"{name}-{k}")
            try:
                with signals_held():  # a completed record is always known to mark_interrupted
                    os.rename(tmp, final)  # fails if `final` exists and is not empty
                    WRITTEN.append(final)
                return final
            except OSError:
                if not final.exists():
                    raise
        raise RecordError(f"no free run directory name for {name} in {out}")
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
