"""Matplotlib without docstrings in the command's process: same figures, a kept cache, and
the usual import wherever that cache cannot be kept.

Each case runs in a fresh interpreter (imports are per process) with its bytecode cache
redirected to a temporary directory (`PYTHONPYCACHEPREFIX`), so the installed packages'
`__pycache__` directories are not touched.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

PROBE = """
import hashlib, io, json, sys
if sys.argv[1] == "lean":
    from stratcli import lean_imports
    lean_imports.install()
if sys.argv[2] == "no-write":
    sys.dont_write_bytecode = True
import numpy as np
import matplotlib.figure
from stratcli.records.figure_common import save_figure
fig = matplotlib.figure.Figure(figsize=(4, 3))
ax = fig.add_subplot()
t = np.linspace(0, 2, 200)
ax.plot(t, np.sin(3 * t), label="u1")
ax.set_xlabel("time [s]")
ax.set_title("a figure")
ax.legend()
png = save_figure(fig)
print(json.dumps({
    "documented": matplotlib.figure.Figure.savefig.__doc__ is not None,
    "png": hashlib.sha256(png).hexdigest(),
}))
"""


def _probe(mode: str, write: str, cache: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONPYCACHEPREFIX": str(cache)}
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    done = subprocess.run(
        [sys.executable, "-c", PROBE, mode, write],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def _optimised(cache: Path) -> list[Path]:
    return [p for p in cache.rglob("*.opt-2.pyc") if "matplotlib" in p.parts]


@pytest.mark.slow  # three interpreters compiling matplotlib into a fresh cache: ~6 s
def test_matplotlib_loads_without_docstrings_and_draws_the_same_pixels(tmp_path):
    usual = _probe("usual", "write", tmp_path / "usual")
    lean = _probe("lean", "write", tmp_path / "lean")
    assert usual["documented"] and not lean["documented"]
    assert lean["png"] == usual["png"]  # byte for byte
    assert _optimised(tmp_path / "lean") and not _optimised(tmp_path / "usual")
    again = _probe("lean", "write", tmp_path / "lean")  # now from the kept cache
    assert again == lean


def test_without_bytecode_writing_matplotlib_is_imported_the_usual_way(tmp_path):
    seen = _probe("lean", "no-write", tmp_path / "cache")
    assert seen["documented"]  # nothing cached, nothing written: the usual import
    assert not _optimised(tmp_path / "cache")


@pytest.mark.slow  # two interpreters compiling matplotlib into a fresh cache: ~4 s
def test_a_stale_cache_that_cannot_be_rewritten_means_the_usual_import(tmp_path):
    """Optimised bytecode that no longer matches its source, where no new file may be
    written, must not make every run compile matplotlib: the module loads the usual way."""
    cache = tmp_path / "cache"
    assert not _probe("lean", "write", cache)["documented"]
    stale = _optimised(cache)
    for path in stale:  # as if matplotlib had been upgraded since
        data = bytearray(path.read_bytes())
        data[8:12] = b"\0\0\0\0"  # the source's modification time
        path.write_bytes(bytes(data))
    seen = _probe("lean", "no-write", cache)
    assert seen["documented"]  # the usual (docstring-keeping) bytecode
    assert all(p.read_bytes()[8:12] == b"\0\0\0\0" for p in stale)  # nothing rewritten
