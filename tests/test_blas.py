"""Single-threaded BLAS: known only if the variables were 1 before numpy loaded.

Each case runs in a fresh interpreter: what numpy read at its import is per process."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")

PROBE = """
import json, sys
from stratcli import blas
seen = {"before": blas.limited()}
if sys.argv[1] == "numpy-first":
    import numpy
blas.single_threaded()  # what a sweep's local pool does
import numpy
seen["after"] = blas.limited()
print(json.dumps(seen))
"""


def _probe(order: str, preset: str | None) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in VARIABLES}
    env["PYTHONPATH"] = str(ROOT)
    if preset is not None:
        env.update(dict.fromkeys(VARIABLES, preset))
    done = subprocess.run(
        [sys.executable, "-c", PROBE, order], env=env, capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.mark.parametrize(
    ("order", "preset", "expected"),
    [
        ("numpy-first", "4", {"before": False, "after": False}),  # four threads asked for
        ("set-first", None, {"before": False, "after": True}),  # set before numpy loaded
        ("numpy-first", "1", {"before": True, "after": True}),  # set in the environment
    ],
)
def test_blas_is_limited_only_if_the_variables_were_1_before_numpy_loaded(order, preset, expected):
    assert _probe(order, preset) == expected


def test_a_script_that_set_the_variables_before_numpy_is_known_to_be_limited():
    """Set by the script itself (not the shell), with stratcli imported after numpy: OpenBLAS
    is asked for its thread count."""
    code = (
        "import os\n"
        "for v in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS'):\n"
        "    os.environ[v] = '1'\n"
        "import numpy\n"
        "from stratcli import blas\n"
        "print(blas.limited())\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in VARIABLES}
    env["PYTHONPATH"] = str(ROOT)
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert done.stdout.strip() == "True", done.stderr
