"""Start-up speed: the commands that plan nothing import no scipy, sympy or matplotlib.

Each command runs in a fresh interpreter (`sys.modules` is per process) through the real
entry point, `stratcli.__main__.main`, with a patched `sys.argv`.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from stratcli.models.presets import PRESET_TABLE, preset

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("scipy", "sympy", "matplotlib")

PROBE = """
import json, sys
args, watched = json.loads(sys.argv[1]), set(json.loads(sys.argv[2]))
sys.argv = ["stratplan", *args]
from stratcli.__main__ import main
try:
    main()
except SystemExit as exc:
    code = exc.code
else:
    code = 0
heavy = sorted({m.split(".")[0] for m in sys.modules} & watched)
print(json.dumps({"code": code, "heavy": heavy}), file=sys.stderr)
"""


def _run(args: list[str]) -> dict:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run(
        [sys.executable, "-c", PROBE, json.dumps(args), json.dumps(HEAVY)],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
        timeout=120,
    )
    return json.loads(proc.stderr.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    """A real run record to `show` and list (planned in this process)."""
    import stratcli

    out = tmp_path_factory.mktemp("runs")
    return stratcli.write_record(out, stratcli.plan(ROOT / "scenarios" / "sim1_l_c1.toml"))


@pytest.mark.parametrize(
    "args", [["--help"], ["--version"], ["models"], ["plan", "--help"]], ids=" ".join
)
def test_commands_that_plan_nothing_import_no_heavy_library(args):
    seen = _run(args)
    assert seen == {"code": 0, "heavy": []}


def test_runs_and_show_read_records_without_the_planner(run_dir):
    assert _run(["runs", "--out", str(run_dir.parent)]) == {"code": 0, "heavy": []}
    assert _run(["show", str(run_dir)]) == {"code": 0, "heavy": []}


@pytest.mark.parametrize("name", sorted(PRESET_TABLE))
def test_the_static_preset_table_equals_the_built_models(name):
    info, system = PRESET_TABLE[name], preset(name)
    assert info.states == system.states
    assert info.inputs == system.inputs
    assert info.strata == tuple(system.strata)
    assert info.description == system.description
