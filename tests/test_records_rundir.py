"""Faults while writing and filling a run record: nothing complete-looking is ever left.

`write_run` is interrupted at each of its system calls in turn (fsync of every file, chmod,
rename); each time the cleanup branch must remove the hidden `.partial` directory, raise
`RecordError` and leave `list_records` empty. Records are never
overwritten, and a killed `stratplan plan` never leaves a record that looks complete.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import TASK_C, plan_record
from typer.testing import CliRunner

from stratcli.cli import app
from stratcli.errors import RecordError
from stratcli.records import rundir
from stratcli.records.rundir import run_name, write_run
from stratcli.records.store import REQUIRED, is_partial, list_records, read_record

FILES = {
    "scenario.toml": 'name = "x"\n',
    "result.json": {  # the least `read_record` accepts: every field `show` and `runs` read
        "schema": "stratplan.result/1",
        **{"scenario": "x", "model": "m", "continuity": "lr", "tolerance": 1e-6},
        **{"status": "ok", "total_energy": 0.0, "legs": [], "switches": []},  # (the legs' sum)
    },
    "manifest.json": {"started": "2026-01-01T00:00:00Z"},
    "run.mcap": b"\x89MCAP",
}


class Boom(OSError):
    pass


def _failing(real, counter: dict, when: int):
    def wrapper(*args, **kwargs):
        counter["n"] += 1
        if counter["n"] == when:
            raise Boom(28, "No space left on device")
        return real(*args, **kwargs)

    return wrapper


def _calls(monkeypatch, name: str, out: Path) -> int:
    """How many times write_run calls os.<name> on a clean write."""
    counter = {"n": 0}
    monkeypatch.setattr(os, name, _failing(getattr(os, name), counter, -1))
    write_run(out, "probe", FILES)
    monkeypatch.undo()
    return counter["n"]


@pytest.mark.parametrize("call", ["fsync", "chmod", "rename"])
def test_interrupted_writer_leaves_no_record(tmp_path, monkeypatch, call):
    total = _calls(monkeypatch, call, tmp_path / "count")
    assert total >= 1
    real_rmtree = shutil.rmtree
    cleaned: list = []

    def rmtree(path, *args, **kwargs):
        cleaned.append(path)
        return real_rmtree(path, *args, **kwargs)

    for when in range(1, total + 1):
        out = tmp_path / f"{call}-{when}"
        cleaned.clear()
        counter = {"n": 0}
        monkeypatch.setattr(os, call, _failing(getattr(os, call), counter, when))
        monkeypatch.setattr(shutil, "rmtree", rmtree)
        with pytest.raises(RecordError, match="No space left on device"):
            write_run(out, "run", FILES)
        monkeypatch.undo()
        assert cleaned, "the cleanup branch did not run"
        assert list(out.iterdir()) == []  # not even a hidden .partial directory
        assert list_records(out) == []


def test_out_that_is_a_file_is_a_record_error(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(RecordError, match="cannot write the run record"):
        write_run(tmp_path / "file", "run", FILES)


def test_long_and_odd_names_are_cut_and_written(tmp_path):
    for scenario in ("n" * 300, "é" * 200, "a/b\x00c"):
        name = run_name(scenario, "text")
        assert len(name.encode()) <= 128 and "/" not in name and "\x00" not in name
        assert write_run(tmp_path, name, FILES).is_dir()
    assert len(list_records(tmp_path)) == 3  # readable back as records
    names = {run_name("n" * 300, "a"), run_name("n" * 300, "b")}
    assert len(names) == 2  # the hash of the text keeps truncated names apart


def test_rundir_module_names_its_limit():
    assert rundir.MAX_NAME_BYTES <= 128


def test_non_finite_json_values_are_written_as_null(tmp_path):
    files = dict(FILES, **{"result.json": {"schema": "stratplan.result/1", "e": float("nan")}})
    run = write_run(tmp_path, "nan", files)
    assert json.loads((run / "result.json").read_text())["e"] is None


runner = CliRunner()


def test_record_holds_every_file_and_never_overwrites(tmp_path):
    first = plan_record(tmp_path)
    for name in (*REQUIRED, "resolved.json"):
        assert (first / name).is_file()
    resolved = json.loads((first / "resolved.json").read_text())
    assert resolved["planner"]["basis"] == {"harmonics": 3, "period": 2.17}  # defaults filled
    manifest = json.loads((first / "manifest.json").read_text())
    for key in ("stratplan", "python", "numpy", "scipy", "platform", "command", "seeds"):
        assert key in manifest
    assert len(manifest["scenario_sha256"]) == 64
    # same scenario, same second: a second directory, the first untouched
    before = (first / "result.json").read_bytes()
    runner.invoke(app, ["plan", str(TASK_C), "--out", str(tmp_path), "-q", "--no-animation"])
    runner.invoke(app, ["plan", str(TASK_C), "--out", str(tmp_path), "-q", "--no-animation"])
    assert len([p for p in tmp_path.iterdir() if p.is_dir()]) == 3
    assert (first / "result.json").read_bytes() == before


@pytest.mark.slow  # five real processes killed at up to 3 s: ~9 s per signal
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT])
def test_a_killed_run_never_leaves_a_record_that_looks_complete(tmp_path, sig):
    """Kill `stratplan plan` at several moments; every directory left is complete or partial."""
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    for delay in (0.3, 1.0, 1.6, 2.2, 3.0):
        proc = subprocess.Popen(
            [sys.executable, "-m", "stratcli", "plan", str(TASK_C), "--out", str(tmp_path), "-q"],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        time.sleep(delay)
        proc.send_signal(sig)
        proc.wait(timeout=60)
    for path in tmp_path.iterdir():
        if is_partial(path):
            assert runner.invoke(app, ["show", str(path)]).exit_code == 2
            continue
        record = read_record(path)  # raises if anything is missing or unreadable
        assert record.result["status"] == "ok"
