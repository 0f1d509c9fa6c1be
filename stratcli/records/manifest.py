"""`manifest.json`: what produced a run (versions, command, scenario hash, timings)."""

from __future__ import annotations

import hashlib
import os
import platform
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import scipy

from .. import __version__


def _git(*args: str, cwd: Path | None = None) -> str | None:
    """Output of a read-only git query in the installed checkout (None outside one).

    `--no-optional-locks` (and GIT_OPTIONAL_LOCKS=0 for older gits): `git status` would
    otherwise refresh the index and take `.git/index.lock` in the source tree.
    """
    try:
        out = subprocess.run(
            ["git", "--no-optional-locks", *args],
            cwd=cwd or Path(__file__).resolve().parent,
            capture_output=True,
            text=True,
            timeout=5,
            env={**os.environ, "GIT_OPTIONAL_LOCKS": "0"},
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
