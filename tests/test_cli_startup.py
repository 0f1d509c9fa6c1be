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
TWO_CORES = len(os.sched_getaffinity(0)) >= 2  # `records.drawing` forks on two cores

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


def _run(args: list[str], **env_vars: str) -> dict:
    env = {**os.environ, "PYTHONPATH": str(ROOT), **env_vars}
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


TWO_ARM = """
name = "two"
[model]
kind = "preset"
name = "two-arm"
[task]
start = [0, 0, 0, 0, 0]
goal = [0, 0.3, 0.3, 0.2, 0.1]
[[legs]]
stratum = "S1"
"""


@pytest.mark.parametrize("scenario", ["sim4_task_d", "two-arm"])
def test_planning_a_preset_from_a_warm_cache_imports_no_sympy_or_scipy(tmp_path, scenario):
    """The first run derives and compiles the strata; the next finds them by the preset's
    identity and plans, checks and writes its record without sympy. Neither needs scipy: the
    energy search uses numpy's linear algebra and re-integration `stratcli.odeint`. The
    two-arm leg on S1 alone: its check needs the closure across strata (eq. 2), cached too."""
    path = ROOT / "scenarios" / "sim4_task_d.toml"
    if scenario == "two-arm":
        path = tmp_path / "two.toml"
        path.write_text(TWO_ARM, encoding="utf-8")
    args = ["plan", str(path), "--out", str(tmp_path), "-q"]
    cache = str(tmp_path / "cache")
    # matplotlib: in this process on one core; on two the drawing process draws the figures
    plots = [] if TWO_CORES else ["matplotlib"]
    assert _run(args, XDG_CACHE_HOME=cache) == {"code": 0, "heavy": [*plots, "sympy"]}
    assert _run(args, XDG_CACHE_HOME=cache) == {"code": 0, "heavy": plots}


@pytest.mark.parametrize("name", sorted(PRESET_TABLE))
def test_the_static_preset_table_equals_the_built_models(name):
    """The table a preset is made from agrees with its printed fields: each stratum `Sij`
    locks joints i and j, whose columns are the only ones that move them."""
    info, system = PRESET_TABLE[name], preset(name)
    assert info.description == system.description
    assert system.fields.shape == (len(info.states), len(info.inputs))
    for stratum in system.strata.values():
        locked = tuple(int(c) - 1 for c in stratum.name[1:])
        assert stratum.locked == locked
        assert set(stratum.active) == set(range(len(info.inputs))) - set(locked)
    system.check()  # no locked coordinate is moved by an active input
    for i in range(len(info.inputs)):  # joint i is driven by u_i alone
        assert [system.fields[i, j] for j in range(len(info.inputs))] == [
            int(i == j) for j in range(len(info.inputs))
        ]


QUICK = """
import atexit, gc, sys
sys.argv = ["stratplan", *sys.argv[1:]]
atexit.register(lambda: print(f"exit handler ran, collector {gc.isenabled()}", file=sys.stderr))
from stratcli.__main__ import entry
entry()
print("not reached", file=sys.stderr)
"""


@pytest.mark.parametrize(
    ("args", "code"),
    [(["models"], 0), (["plan", "no-such-file.toml"], 2), (["models", "--bogus"], 2)],
    ids=["ok", "bad-file", "bad-option"],
)
def test_the_console_script_exits_with_the_command_s_code_output_and_exit_handlers(args, code):
    """`entry` skips the interpreter's teardown, not the command's exit code, its buffered
    output or the exit handlers (and commands run with the cyclic collector paused)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run(
        [sys.executable, "-c", QUICK, *args], capture_output=True, text=True, env=env, cwd=ROOT
    )
    assert proc.returncode == code, proc.stderr
    assert proc.stderr.splitlines()[-1] == "exit handler ran, collector False"
    assert "not reached" not in proc.stderr and "Traceback" not in proc.stderr
    if code == 0:  # the whole table, flushed
        assert "two-arm" in proc.stdout and proc.stdout.endswith("\n")
    else:
        assert proc.stderr.startswith("error:")


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
@pytest.mark.parametrize("unbuffered", ["1", ""], ids=["unbuffered", "buffered"])
def test_output_that_cannot_be_written_is_one_line_and_exit_120(unbuffered):
    """A full disk under stdout: no traceback, the command's work done, one `error:` line and
    Python's own exit code for a failed final flush (120), not a silent 0."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONUNBUFFERED": unbuffered}
    code = (
        "import sys; sys.argv = ['stratplan', 'models']\n"
        "from stratcli.__main__ import entry; entry()"
    )
    with open("/dev/full", "w") as full:
        proc = subprocess.run(
            [sys.executable, "-c", code], stdout=full, stderr=subprocess.PIPE, text=True, env=env
        )
    assert proc.returncode == 120, proc.stderr
    assert proc.stderr == "error: cannot write the output: No space left on device\n"


@pytest.mark.parametrize("closed", [1, 2], ids=["stdout", "stderr"])
def test_a_command_started_with_stdout_or_stderr_closed_ends_without_a_traceback(closed):
    """`stratplan models >&-` (Python's sys.stdout is then None): the command did its work
    and then failed on flushing None, a traceback and exit 1."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    code = (
        "import sys; sys.argv = ['stratplan', 'models']\n"
        "from stratcli.__main__ import entry; entry()"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env=env,
        preexec_fn=lambda: os.close(closed),
    )
    assert proc.returncode == 0
    assert "Traceback" not in proc.stderr and "Error" not in proc.stderr
    assert ("two-arm" in proc.stdout) == (closed == 2)


DENIED = """
import pathlib, sys
sys.argv = ["stratplan", *sys.argv[1:]]
real = pathlib.Path.is_file
def denied(self):  # a directory the user cannot search (as root, chmod 000 is no bar)
    if "locked" in str(self):
        raise PermissionError(13, "Permission denied", str(self))
    return real(self)
pathlib.Path.is_file = denied
pathlib.Path.exists = denied
from stratcli.__main__ import entry
entry()
"""


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (["models", "locked/d.toml"], "error: locked/d.toml: permission denied"),
        (["runs", "locked/runs"], "error: locked/runs: permission denied"),
    ],
    ids=["models", "runs"],
)
def test_a_path_that_cannot_be_searched_is_one_line_and_exit_2(args, line):
    """`chmod 000 locked`: `models locked/d.toml`, `runs locked/runs` (and `plan --out`,
    `show`, `check`) printed a PermissionError traceback and exited 1, "a leg failed"."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run(
        [sys.executable, "-c", DENIED, *args], capture_output=True, text=True, env=env, cwd=ROOT
    )
    assert proc.returncode == 2 and proc.stderr.strip() == line, proc.stderr


def test_an_out_that_cannot_be_searched_is_refused_before_planning(monkeypatch, tmp_path):
    from stratcli import InputError, api

    def denied(self):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(Path, "exists", denied)
    with pytest.raises(InputError, match=r"out=.*: cannot write there \(Permission denied\)"):
        api.prepare_out(tmp_path / "locked" / "runs")


def test_an_ascii_terminal_gets_question_marks_not_a_traceback():
    """PYTHONIOENCODING=ascii: `plan` wrote its record, then died printing "·" (exit 1)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONIOENCODING": "ascii"}
    proc = subprocess.run(
        [sys.executable, "-c", QUICK, "check", "one-arm"],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
    )
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr


def test_an_unwritable_matplotlib_config_directory_is_no_noise(tmp_path):
    """A read-only HOME: every run printed matplotlib's two warnings (mkdir failed, a
    temporary cache made), --quiet or not; matplotlib copes by itself, so nothing is said."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLCONFIGDIR": "/dev/null/matplotlib"}
    scenario = str(ROOT / "scenarios" / "sim1_l_c1.toml")
    proc = subprocess.run(
        [sys.executable, "-c", QUICK, "plan", scenario, "--out", str(tmp_path), "--quiet"],
        capture_output=True, text=True, env=env, cwd=ROOT,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.splitlines() == ["exit handler ran, collector False"], proc.stderr
    assert list(tmp_path.glob("*/configuration.png"))  # (the figures drawn all the same)
