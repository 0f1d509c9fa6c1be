"""`manifest.json`: what produced a run (versions, command, scenario hash, timings).

`phases` holds the wall and CPU seconds of each phase of the run, in order: `import` (from
`import stratcli` to the planner imported; its CPU counts from the interpreter's start; on
the command line it includes reading the scenario), `check`, `compile`, `planning`
(comparing: `planning` alone, the whole comparison with its compiling, CPU of this process
only), then the record's parts: `record imports` (matplotlib and mcap, loaded by a process's
first record; on the command line matplotlib loads in the drawing process instead,
`records.drawing`), comparing `comparison files` (comparison.json and .csv), `sample` (the
re-integration the log and plots draw), `plots` (every PNG, the GIF and a comparison's
ranking chart; drawn by the drawing process: wall from asking for them to having them, the
record's layout and URDF copy being built meanwhile, and the CPU of the drawing process and
its fork for them, not their loading of matplotlib), `run.mcap`. The MCAP's copy of
the manifest is taken before its own entry; writing the directory comes after the manifest
is frozen, so `write` and `total` are in the outcome (`PlanOutcome.phases`), not in
manifest.json.
"""

from __future__ import annotations

import functools
import hashlib
import os
import platform
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np

from .. import _STARTED, __version__

Phases = dict[str, dict[str, float]]  # name -> {"wall_s": ..., "cpu_s": ...}
# the phases `api.write_record` adds to an outcome's (a record's own, not the planning's): a
# second record of one outcome took the first's into its manifest
RECORD_PHASES = (
    "record imports",
    "comparison files",
    "sample",
    "run.mcap",
    "plots",
    "write",
    "total",
)


def _version(package: str) -> str | None:
    """An installed package's version without importing it (scipy costs 0.1 s to import)."""
    try:
        return version(package)
    except PackageNotFoundError:
        return None


def since_start() -> dict[str, float]:
    """Wall seconds since `import stratcli` and CPU seconds since the process started."""
    return {"wall_s": time.perf_counter() - _STARTED, "cpu_s": time.process_time()}


@contextmanager
def phase(phases: Phases, name: str) -> Iterator[None]:
    """Time the block into `phases[name]` (wall and CPU seconds)."""
    wall, cpu = time.perf_counter(), time.process_time()
    try:
        yield
    finally:
        phases[name] = {
            "wall_s": time.perf_counter() - wall,
            "cpu_s": time.process_time() - cpu,
        }


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


def source_commit(cwd: Path | None = None) -> tuple[str | None, bool | None]:
    """The git commit of stratplan's sources and whether their checkout is dirty, or
    (None, None) where they are not files git tracks: installed into a virtual environment
    inside another repository (a project's `.venv`), git would answer for that repository.

    Parameters
    ----------
    cwd : Path, optional
        The source directory asked about (default: this package's).
    """
    here = cwd or Path(__file__).resolve().parent
    if _git("ls-files", "--error-unmatch", "--", ".", cwd=here) is None:
        return None, None
    commit = _git("rev-parse", "HEAD", cwd=here)
    if commit is None:
        return None, None
    return commit, bool(_git("status", "--porcelain", "--untracked-files=no", cwd=here))


@functools.cache
def _this_checkout() -> tuple[str | None, bool | None]:
    """`source_commit` of this package, asked once a process: the code it runs was read at
    import (its three git calls took 17 ms, in a sweep for each task's record)."""
    return source_commit()


def manifest(
    text: str,
    argv: list[str],
    seed: int,
    timings: dict[str, Any],
    exit_code: int,
    phases: Phases | None = None,
):
    """manifest.json's document: versions, the checkout's commit, platform, the command
    line `argv`, the scenario `text`'s sha256, `seed`, `timings`, `exit_code`, `phases`."""
    commit, dirty = _this_checkout()
    return {
        "schema": "stratplan.manifest/1",
        "stratplan": __version__,
        "git_commit": commit,
        "git_dirty": dirty,
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "scipy": _version("scipy"),
        "platform": platform.platform(),
        "command": argv,
        "scenario_sha256": hashlib.sha256(text.encode("utf-8")).hexdigest(),
        "seeds": {"planner": seed},
        **timings,
        "exit_code": exit_code,
        "phases": dict(phases or {}),
    }
