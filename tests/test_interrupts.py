"""Interrupts and damaged files (issue 13, item 5).

Ctrl-C (or SIGTERM) at any moment: one line, exit 130 (143), never a traceback; a record
finished before the signal says so in its manifest; killing `compare-sequences` never leaves
its workers alive; partial directories of killed runs are cleaned up; damaged records and
garbled baselines give one `error:` line and exit 2; the manifest's git query takes no lock.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from conftest import ROOT
from typer.testing import CliRunner

import stratcli
from stratcli.cli import app
from stratcli.errors import InputError
from stratcli.records import rundir
from stratcli.records.manifest import _git, source_commit
from stratcli.records.store import read_record

runner = CliRunner()
TASK_C = ROOT / "scenarios" / "sim4_task_c.toml"
AUTO = ROOT / "scenarios" / "sim4_auto.toml"
ENV = dict(os.environ, PYTHONUNBUFFERED="1", PYTHONPATH=str(ROOT))


@pytest.fixture(scope="module")
def planned(tmp_path_factory) -> Path:
    """One real record of sim4_task_c (planned once for the module)."""
    out = tmp_path_factory.mktemp("records")
    result = runner.invoke(app, ["plan", str(TASK_C), "--out", str(out), "-q", "--no-animation"])
    assert result.exit_code == 0, result.output
    (run,) = [p for p in out.iterdir() if p.is_dir()]
    return run


@pytest.fixture
def record(planned, tmp_path) -> Path:
    """A copy of the planned record, free to damage."""
    return Path(shutil.copytree(planned, tmp_path / "runs" / planned.name))


def _one_error_line(result, *words: str) -> None:
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:"), result.stderr
    for word in words:
        assert word in lines[0], lines[0]
    assert "Traceback" not in result.output


# ------------------------------------------------------------------------------------------
# Signals
# ------------------------------------------------------------------------------------------


def _wait_for_handlers(proc: subprocess.Popen, timeout: float = 20.0) -> None:
    """Until `main` has taken over SIGTERM (Python itself never catches it).

    Before that the interpreter is still starting (site, the editable install's path hook)
    and a Ctrl-C there is Python's own KeyboardInterrupt, which no program can intercept."""
    deadline = time.monotonic() + timeout
    bit = 1 << (signal.SIGTERM - 1)
    while time.monotonic() < deadline and proc.poll() is None:
        try:
            status = Path(f"/proc/{proc.pid}/status").read_text()
        except OSError:
            return
        caught = next(line for line in status.splitlines() if line.startswith("SigCgt:"))
        if int(caught.split()[1], 16) & bit:
            return
        time.sleep(0.002)


@pytest.mark.slow  # two full runs, then up to four runs cut short: ~6 s, more under load
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/PID/status")
def test_ctrl_c_at_any_moment_prints_one_line_and_exits_130(tmp_path):
    """During imports (at once), model compile, planning and around the record writing.

    The moments are fractions of an uninterrupted run measured first, so that a faster
    stratplan (or a slower machine) still has each signal land while the command runs."""
    argv = [sys.executable, "-m", "stratcli", "plan", str(TASK_C), "--out", str(tmp_path), "-q"]

    def start() -> subprocess.Popen:
        proc = subprocess.Popen(
            argv, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        _wait_for_handlers(proc)
        return proc

    lengths = []
    for _ in range(3):  # the first may fill the model cache; the shortest of the others
        proc = start()
        began = time.monotonic()
        proc.communicate(timeout=120)
        assert proc.returncode == 0
        lengths.append(time.monotonic() - began)  # from main's handlers to the end
    length = min(lengths[1:])  # (a run slowed by the machine would put the signals late)
    interrupted = 0
    for fraction in (0.0, 0.25, 0.5, 0.7):
        proc = start()
        time.sleep(fraction * length)
        if proc.poll() is not None:  # finished before the signal: nothing to judge
            continue
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        if (proc.returncode, err) == (0, "") and fraction >= 0.5:
            continue  # it ended between poll() and the signal (a CI run, once at 0.5): as above
        assert (proc.returncode, err) == (130, "interrupted\n"), (fraction, err)
        interrupted += 1
    assert interrupted >= 2


@pytest.mark.skipif(not hasattr(signal, "SIGINT"), reason="POSIX signals")
def test_a_ctrl_c_that_code_caught_and_went_on_from_still_interrupts():
    """A Ctrl-C at the start of a run once ended it with exit 0 and nothing printed (a CI run
    under load): its `Interrupted` was caught by code that went on (a bare `except:`). The
    handler notes what it raised, so the command still ends `interrupted`, exit 130."""
    script = textwrap.dedent(
        """
        import os, signal, sys
        sys.argv = ["stratplan", "models"]
        import stratcli.__main__ as entry
        import stratcli.cli
        plain = stratcli.cli.app
        def app(**kwargs):
            try:  # as a library's bare except would
                os.kill(os.getpid(), signal.SIGINT)
                for _ in range(10000):
                    pass
            except BaseException:
                pass
            return plain(**kwargs)
        stratcli.cli.app = app
        entry.entry()
        """
    )
    proc = subprocess.run(
        [sys.executable, "-c", script], env=ENV, capture_output=True, text=True, timeout=60
    )
    assert (proc.returncode, proc.stderr) == (130, "interrupted\n"), proc.stderr


def _run_with_signal_after_record(tmp_path, sig: signal.Signals) -> subprocess.CompletedProcess:
    """`stratplan plan` that receives `sig` right after its record is written (while it
    prints the footer)."""
    code = textwrap.dedent(
        f"""
        import os, signal, sys, time
        from stratcli.cli import render
        def footer(*args):
            os.kill(os.getpid(), {int(sig)})
            time.sleep(30)
        render.plan_footer = footer
        sys.argv = ["stratplan", "plan", {str(TASK_C)!r}, "--out", {str(tmp_path)!r},
                    "--no-animation"]
        from stratcli.__main__ import main
        main()
        """
    )
    return subprocess.run(
        [sys.executable, "-c", code], env=ENV, capture_output=True, text=True, timeout=120
    )


@pytest.mark.slow  # a real plan of ~2.5 s and a Python start-up per signal: ~5.5 s each
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=lambda s: s.name)
def test_a_record_finished_before_the_signal_says_so(tmp_path, sig):
    done = _run_with_signal_after_record(tmp_path, sig)
    word = "interrupted" if sig == signal.SIGINT else "terminated"
    (run,) = [p for p in tmp_path.iterdir() if p.is_dir()]
    kept = f"{word}; the record written before it is kept: {run}\n"  # (its table was not shown)
    assert (done.returncode, done.stderr) == (128 + sig, kept), done.stderr
    record = read_record(run)  # complete and readable
    assert record.result["status"] == "ok"
    assert record.manifest["interrupted"] is True
    assert record.manifest["signal"] == sig.name
    assert record.manifest["exit_code"] == 128 + sig
    assert sorted(p.name for p in run.iterdir() if p.name.startswith(".")) == []
    # still a manifest by its schema (which was closed to `interrupted` and `signal`)
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(record.manifest, stratcli.record_schema("manifest"))


def test_a_signal_python_drops_in_a_finaliser_still_stops_the_command(tmp_path):
    """CPython runs signal handlers inside finalisers and weakref callbacks too (a process
    pool keeps one), and drops what they raise with an "Exception ignored" report. Such an
    interrupt must still end the command with one line and exit 130, before any record."""
    code = textwrap.dedent(
        f"""
        import os, signal, sys
        from stratcli import stratified
        class Finaliser:
            def __del__(self):
                os.kill(os.getpid(), signal.SIGINT)  # handled right here, in __del__
        original = stratified.plan_next_leg
        def plan_next_leg(*args, **kwargs):
            Finaliser()  # collected at once: the handler's exception is dropped
            return original(*args, **kwargs)
        stratified.plan_next_leg = plan_next_leg
        sys.argv = ["stratplan", "plan", {str(TASK_C)!r}, "--out", {str(tmp_path)!r}, "-q"]
        from stratcli.__main__ import main
        main()
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", code], env=ENV, capture_output=True, text=True, timeout=120
    )
    assert (done.returncode, done.stderr) == (130, "interrupted\n"), done.stderr
    assert not list(tmp_path.iterdir())  # no record, no partial directory


@pytest.mark.slow  # one whole plan run: ~4.5 s
def test_a_signal_started_ignored_stays_ignored(tmp_path):
    """`cmd &` in a script or `nohup cmd`: SIGINT was ignored on start and is left so."""
    command = ["plan", str(TASK_C), "--out", str(tmp_path), "-q", "--no-animation"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "stratcli", *command],
        env=ENV,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN),
    )
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert (proc.returncode, err) == (0, "")
    assert len([p for p in tmp_path.iterdir() if p.is_dir()]) == 1


def _children(pid: int) -> set[int]:
    kids: set[int] = set()
    for task in Path(f"/proc/{pid}/task").glob("*/children"):
        try:
            kids.update(int(k) for k in task.read_text().split())
        except OSError:
            pass
    return kids


def _alive(pid: int) -> bool:
    """Running (a zombie waiting for its reaper is dead)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state != "Z"


@pytest.mark.slow  # a comparison started and killed per signal: 3-4 s each, more under load
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc and PR_SET_PDEATHSIG")
@pytest.mark.parametrize(
    "sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT], ids=lambda s: s.name
)
def test_killing_compare_sequences_leaves_no_worker_alive(tmp_path, sig):
    # --exhaustive: all 36 searched (about 1 s on 2 workers), so that the signal 0.3 s after
    # the workers started lands while they work (the screened search, 0.45 s on a fast
    # machine, had ended before it once: exit 0)
    cmd = [sys.executable, "-m", "stratcli", "compare-sequences", str(AUTO), "--jobs", "2"]
    cmd.append("--exhaustive")
    proc = subprocess.Popen(
        [*cmd, "--out", str(tmp_path), "-q"],
        env=ENV,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 30
    workers: set[int] = set()
    # two workers and the process drawing the record's figures (`records.drawing`)
    expected = 2 + (len(os.sched_getaffinity(0)) >= 2)
    while len(workers) < expected and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.1)
        workers = _children(proc.pid)
    assert len(workers) == expected, "the workers never started"
    time.sleep(0.3)  # let them get to work
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=30)
    if sig != signal.SIGKILL:
        word = "interrupted" if sig == signal.SIGINT else "terminated"
        assert (proc.returncode, err) == (128 + sig, f"{word}\n")
    deadline = time.monotonic() + 5
    while any(_alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [w for w in workers if _alive(w)]
    assert not list(tmp_path.iterdir())  # no record, no partial directory


# ------------------------------------------------------------------------------------------
# Partial directories of killed runs
# ------------------------------------------------------------------------------------------


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def _partial(out: Path, name: str, age_s: float = 0.0) -> Path:
    path = out / name
    path.mkdir(parents=True)
    (path / "result.json").write_text("{}")
    if age_s:
        then = time.time() - age_s
        os.utime(path, (then, then))
    return path


def test_partials_of_killed_runs_are_removed_and_running_ones_kept(tmp_path):
    host = rundir._host_tag()
    dead = _partial(tmp_path, f".20260101T000000Z-a-12345678.{_dead_pid()}@{host}.x1.partial")
    running = _partial(tmp_path, f".20260101T000000Z-a-12345678.{os.getpid()}@{host}.x2.partial")
    elsewhere = _partial(tmp_path, f".20260101T000000Z-a-12345678.{_dead_pid()}@000000.x3.partial")
    old = _partial(tmp_path, ".20260101T000000Z-a-12345678.abc.partial", age_s=2 * 3600)
    recent = _partial(tmp_path, ".20260101T000000Z-a-12345678.def.partial")
    hidden = _partial(tmp_path, ".git", age_s=2 * 3600)  # not ours: never touched
    rundir.write_run(tmp_path, "next", {"result.json": {}})  # the next run cleans up
    assert not dead.exists() and not old.exists()
    assert running.exists() and elsewhere.exists() and recent.exists() and hidden.exists()
    assert (tmp_path / "next").is_dir()


def test_runs_clean_removes_partials_and_says_which(tmp_path):
    partial = _partial(tmp_path, f".r.{_dead_pid()}@{rundir._host_tag()}.x1.partial")
    result = runner.invoke(app, ["runs", "--out", str(tmp_path), "--clean"])
    assert result.exit_code == 0, result.output
    assert not partial.exists()
    assert result.stderr == f"removed {partial} (left by a killed run)\n"
    again = runner.invoke(app, ["runs", "--out", str(tmp_path), "--clean"])
    assert again.exit_code == 0 and again.stderr == ""


def test_a_partial_name_carries_its_writer(tmp_path, monkeypatch):
    seen = []
    monkeypatch.setattr(rundir.os, "chmod", lambda path, mode: seen.append(Path(path).name))
    rundir.write_run(tmp_path, "r", {"a.txt": "x"})
    assert rundir._PARTIAL.match(seen[0])
    assert f".{os.getpid()}@{rundir._host_tag()}." in seen[0]


# ------------------------------------------------------------------------------------------
# Damaged records and baselines
# ------------------------------------------------------------------------------------------

DAMAGE = {
    "null result": ("result.json", None, "not a JSON object"),
    "a list": ("result.json", [1, 2], "not a JSON object"),
    "missing key": ("result.json", lambda d: d.pop("legs"), "legs is missing"),
    "string energy": ("result.json", lambda d: d.update(total_energy="12"), "total_energy"),
    "leg energy": ("result.json", lambda d: d["legs"][0].update(energy=[1]), "legs[0].energy"),
    "basis": ("result.json", lambda d: d["legs"][0]["pieces"][0]["basis"].pop("period"), "period"),
    "null manifest": ("manifest.json", None, "not a JSON object"),
    "string time": ("manifest.json", lambda d: d.update(planning_time_s="1"), "planning_time_s"),
    "not JSON": ("result.json", "{", "damaged record"),
    # a hand-edited record's fields show read (each was a TypeError or AttributeError)
    "number message": ("result.json", lambda d: d.update(message=5), "message is 5"),
    "text legs count": ("result.json", lambda d: d.update(planned_legs="x"), "planned_legs"),
    "text constraints": ("result.json", lambda d: d.update(constraints="x"), "constraints"),
    "number constraints": ("result.json", lambda d: d.update(constraints=5), "constraints"),
    # fields show and load_run read apart (show 'failed', load_run ok; a numpy ValueError)
    "unknown status": ("result.json", lambda d: d.update(status="weird"), 'status is "weird"'),
    "unknown leg status": (
        "result.json",
        lambda d: d["legs"][0].update(status="weird"),
        'legs[0].status is "weird"',
    ),
    "ok with a failed leg": (
        "result.json",
        lambda d: d["legs"][0].update(status="diverged"),
        'status is "ok" but legs[0].status is "diverged"',
    ),
    "short coefficients": ("result.json", lambda d: _short_row(d), "coefficients.u1 is not 7"),
    "total not the legs' sum": (
        "result.json",
        lambda d: d.update(total_energy=1.0),
        "total_energy is 1, not the sum",
    ),
    "NaN": ("result.json", lambda d: d["legs"][0].update(energy=math.nan), "legs[0].energy is nan"),
    "Infinity": ("result.json", lambda d: d.update(total_energy=math.inf), "total_energy is inf"),
    "best past the starts": (  # (show indexed the starts with it: an IndexError traceback)
        "result.json",
        lambda d: d["optimisation"].update(best=len(d["optimisation"]["starts"])),
        "optimisation.best is not the index of a start",
    ),
}


def _short_row(doc: dict) -> None:
    rows = doc["legs"][0]["pieces"][0]["coefficients"]
    rows["u1"] = rows["u1"][:3]


def _damage(run: Path, file: str, change) -> None:
    path = run / file
    if callable(change):
        doc = json.loads(path.read_text())
        change(doc)
        path.write_text(json.dumps(doc))
    elif isinstance(change, str):
        path.write_text(change)
    else:
        path.write_text(json.dumps(change))


@pytest.mark.parametrize("case", DAMAGE)
def test_show_of_a_damaged_record_is_one_error_line(record, case):
    file, change, words = DAMAGE[case]
    _damage(record, file, change)
    _one_error_line(runner.invoke(app, ["show", str(record)]), str(record / file), words)


@pytest.mark.parametrize("case", DAMAGE)
def test_load_run_of_a_damaged_record_is_the_same_one_line(record, case):
    file, change, words = DAMAGE[case]
    _damage(record, file, change)
    with pytest.raises(InputError) as caught:
        stratcli.load_run(record)
    assert str(record / file) in str(caught.value) and words in str(caught.value)


def test_show_of_a_damaged_mcap_log_is_one_error_line(record):
    (record / "run.mcap").write_bytes(b"\x89MCAP0\r\n" + b"\xff" * 64)
    _one_error_line(runner.invoke(app, ["show", str(record)]), "run.mcap", "damaged MCAP")


def test_runs_skips_a_damaged_record_with_a_note(record, planned):
    good = Path(shutil.copytree(planned, record.parent / "good"))
    (record / "result.json").write_text("null")
    result = runner.invoke(app, ["runs", "--out", str(record.parent), "--json"])
    assert result.exit_code == 0, result.output
    assert [r["run"] for r in json.loads(result.stdout)] == [good.name]
    (note,) = result.stderr.strip().splitlines()
    assert note.startswith("skipped: ") and str(record / "result.json") in note
    table = runner.invoke(app, ["runs", "--out", str(record.parent)])
    assert table.exit_code == 0 and good.name in table.stdout


GOOD_ENTRY = {"status": "ok", "total_energy": 1.0, "errors": [1e-9], "energies": [1.0]}
BASELINES = {
    "a list": ([], "not a JSON object"),
    "missing key": ({"scenarios": {"s": {"status": "ok"}}}, "scenarios.s.total_energy is missing"),
    "no scenarios": ({"scenarios": None}, "scenarios is missing"),
    "string energy": ({"scenarios": {"s": {**GOOD_ENTRY, "total_energy": "1"}}}, "total_energy"),
    "NaN": ({"scenarios": {"s": {**GOOD_ENTRY, "errors": [math.nan]}}}, "errors[0] is nan"),
    "negative tolerance": ({"tolerances": {"energy_rel": -1}}, "tolerances.energy_rel"),
    "unknown tolerance": ({"tolerances": {"energy": 1}}, "tolerances.energy: unknown key"),
    "misspelt tolerance": (
        {"tolerances": {"energy_rell": 1}},
        "tolerances.energy_rell: unknown key (did you mean 'energy_rel'?)",
    ),
    "bad status": ({"scenarios": {"s": {**GOOD_ENTRY, "status": "fine"}}}, "status"),
    # a misspelt key was passed over (the defaults stayed in force without a word)
    "misspelt tolerances": (
        {"tolerance": {"energy_rel": 1}, "scenarios": {}},
        "tolerance: unknown key (did you mean 'tolerances'?)",
    ),
    "unknown entry key": (
        {"scenarios": {"s": {**GOOD_ENTRY, "energy": 1.0}}},
        "scenarios.s.energy: unknown key (did you mean 'energies'?)",
    ),
    "not JSON": ("{", "not JSON"),
}


@pytest.mark.parametrize("case", BASELINES)
def test_regress_with_a_garbled_baseline_is_one_error_line(tmp_path, case):
    doc, words = BASELINES[case]
    if isinstance(doc, dict):
        doc = {"schema": "stratplan.baseline/1", "scenarios": {"s": GOOD_ENTRY}, **doc}
    text = doc if isinstance(doc, str) else json.dumps(doc)
    baseline = tmp_path / "baseline.json"
    baseline.write_text(text)
    (tmp_path / "s.toml").write_text(TASK_C.read_text())
    result = runner.invoke(app, ["regress", str(tmp_path), "--baseline", str(baseline)])
    _one_error_line(result, str(baseline), words)


# ------------------------------------------------------------------------------------------
# The manifest's git query
# ------------------------------------------------------------------------------------------


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_git_query_never_writes_the_index(tmp_path):
    """Plain `git status` rewrites a stat-dirty index (taking index.lock); ours does not."""
    env = dict(os.environ, GIT_AUTHOR_NAME="a", GIT_AUTHOR_EMAIL="a@b", GIT_COMMITTER_NAME="a")
    env["GIT_COMMITTER_EMAIL"] = "a@b"
    (tmp_path / "f").write_text("a\n")
    for args in (["init", "-q"], ["add", "f"], ["commit", "-qm", "x"]):
        subprocess.run(["git", *args], cwd=tmp_path, env=env, check=True)
    index = tmp_path / ".git" / "index"
    later = time.time() + 5
    os.utime(tmp_path / "f", (later, later))  # the index's stat data is now stale
    before = index.read_bytes()
    assert _git("status", "--porcelain", "--untracked-files=no", cwd=tmp_path) == ""
    assert index.read_bytes() == before
    subprocess.run(["git", "status", "--porcelain"], cwd=tmp_path, check=True, capture_output=True)
    assert index.read_bytes() != before  # the control: plain status would have written it


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_manifest_commit_is_of_stratplans_sources_only(tmp_path):
    """Installed into a `.venv` inside another repository (ignored there), the sources are not
    git's: the manifest had that repository's commit and dirty flag as stratplan's."""
    env = dict(os.environ, GIT_AUTHOR_NAME="a", GIT_AUTHOR_EMAIL="a@b", GIT_COMMITTER_NAME="a")
    env["GIT_COMMITTER_EMAIL"] = "a@b"
    (tmp_path / ".gitignore").write_text(".venv/\n")
    for args in (["init", "-q"], ["add", ".gitignore"], ["commit", "-qm", "x"]):
        subprocess.run(["git", *args], cwd=tmp_path, env=env, check=True)
    installed = tmp_path / ".venv" / "lib" / "stratcli" / "records"
    installed.mkdir(parents=True)
    (installed / "manifest.py").write_text("# a copy\n")
    assert _git("rev-parse", "HEAD", cwd=installed)  # git answers for the project...
    assert source_commit(installed) == (None, None)  # ...which is not stratplan's
    commit, dirty = source_commit(tmp_path)  # a checkout's own files: its commit
    assert commit == _git("rev-parse", "HEAD", cwd=tmp_path) and dirty is False


@pytest.mark.parametrize("command", [["models"], ["plan", str(TASK_C), "--no-animation"]])
def test_a_reader_leaving_early_ends_the_output_not_the_command(tmp_path, command):
    """`stratplan … | head -1`: the pipe's reader is gone before the first line; the command
    still does its work (the record), exits with its own code and prints no traceback."""
    out = tmp_path / "runs"
    args = [*command, "--out", str(out)] if command[0] == "plan" else command
    proc = subprocess.Popen(
        [sys.executable, "-m", "stratcli", *args],
        cwd=ROOT,
        env=ENV,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    proc.stdout.close()  # before the process has written anything: every write breaks
    stderr = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 0, stderr
    assert stderr == ""
    if command[0] == "plan":
        (run,) = out.iterdir()
        assert json.loads((run / "result.json").read_text())["status"] == "ok"


def test_an_interrupt_python_wrapped_in_another_error_is_still_one_line_and_130():
    """A Ctrl-C while a pydantic model class was being made (an import) reached the entry
    point as Python 3.11's "RuntimeError: Error calling __set_name__ ...", its cause our
    Interrupted: a traceback and exit 1 (a CI run). Other errors still propagate."""
    code = (
        "import stratcli.__main__ as m, stratcli.cli as cli\n"
        "from stratcli.interrupts import Interrupted\n"
        "def app(**kw):\n"
        "    try:\n"
        "        raise Interrupted({signum})\n"
        "    except Interrupted as e:\n"
        "        raise RuntimeError('Error calling __set_name__') from e\n"
        "def plain(**kw):\n"
        "    raise RuntimeError('not an interrupt')\n"
        "cli.app = {which}\n"
        "m.main()\n"
    )
    for signum, which, expected in (
        (2, "app", (130, "interrupted\n")),
        (15, "app", (143, "terminated\n")),
    ):
        run = subprocess.run(
            [sys.executable, "-c", code.format(signum=signum, which=which)],
            env=ENV, capture_output=True, text=True, timeout=60,
        )  # fmt: skip
        assert (run.returncode, run.stderr) == expected
    plain = subprocess.run(
        [sys.executable, "-c", code.format(signum=2, which="plain")],
        env=ENV, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert plain.returncode == 1 and "not an interrupt" in plain.stderr
