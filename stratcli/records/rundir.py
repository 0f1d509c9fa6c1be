"""Run directories: one per planning job, written atomically.

Files are written into a hidden temporary directory beside the final one, then the directory
is renamed into place as the very last step, so a run interrupted at any moment never leaves a
directory that looks complete (`runs/<UTC time>-<scenario>-<hash>/`).

The scenario part of the name is cut to `MAX_NAME_BYTES` bytes (the hash of the scenario text
keeps truncated names distinct), so every name fits the usual 255-byte file-name limit with
room for the temporary prefix and suffix. Any `OSError` while writing becomes a `RecordError`
after the temporary directory has been removed. JSON files are strict JSON: a NaN or ±inf
(e.g. the energy of a plan whose legs overflowed) is written as `null`.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import tempfile
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from ..errors import RecordError

MAX_NAME_BYTES = 100


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
    try:
        return _write_run(out, name, files)
    except RecordError:
        raise
    except OSError as exc:
        where = exc.filename or out
        raise RecordError(f"cannot write the run record in {where}: {exc.strerror or exc}") from exc


def _write_run(out: Path, name: str, files: dict[str, Any]) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{name}.", suffix=".partial", dir=out))
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
        for k in range(1, 1000):
            final = out / (name if k == 1 else f"{name}-{k}")
            try:
                os.rename(tmp, final)  # fails if `final` exists and is not empty
                return final
            except OSError:
                if not final.exists():
                    raise
        raise RecordError(f"no free run directory name for {name} in {out}")
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
