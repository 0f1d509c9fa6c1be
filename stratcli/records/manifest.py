"""`manifest.json`: what produced a run (versions, command, scenario hash, timings)."""

from __future__ import annotations

import hashlib
import platform
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import scipy

from .. import __version__


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(
            ["git", *args],
            cwd=Path(__file__).resolve().parent,
            capture_output=True,
            text=True,
            timeout=5,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def manifest(text: str, argv: list[str], seed: int, timings: dict[str, Any], exit_code: int):
    commit = _git("rev-parse", "HEAD")
    return {
        "schema": "stratplan.manifest/1",
        "stratplan": __version__,
        "git_commit": commit,
        "git_dirty": bool(_git("status", "--porcelain", "--untracked-files=no"))
        if commit
        else None,
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "platform": platform.platform(),
        "command": argv,
        "scenario_sha256": hashlib.sha256(text.encode("utf-8")).hexdigest(),
        "seeds": {"planner": seed},
        **timings,
        "exit_code": exit_code,
    }
