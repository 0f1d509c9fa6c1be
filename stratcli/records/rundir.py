"""Run directories: one per planning job, written atomically.

Files are written into a hidden temporary directory beside the final one, then the directory
is renamed into place as the very last step, so a run interrupted at any moment never leaves a
directory that looks complete (`runs/<UTC time>-<scenario>-<hash>/`).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from datetime import UTC, datetime
from pathlib import Path
from typing import Any


def run_name(scenario: str, text: str, when: datetime | None = None) -> str:
    """`<UTC time>-<scenario name>-<short hash of the scenario text>`."""
    when = when or datetime.now(UTC)
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()[:8]
    return f"{when.strftime('%Y%m%dT%H%M%SZ')}-{scenario}-{digest}"


def write_run(out: Path, name: str, files: dict[str, Any]) -> Path:
    """Write `files` (name → dict for JSON, str or bytes) as the run `out/name[-k]/`."""
    out.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{name}.", suffix=".partial", dir=out))
    try:
        for filename, content in files.items():
            if isinstance(content, dict | list):
                data = (json.dumps(content, indent=2, allow_nan=False) + "\n").encode()
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
        raise FileExistsError(f"no free run directory name for {name} in {out}")
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
