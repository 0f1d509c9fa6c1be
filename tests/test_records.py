"""Run records: atomic directories, show/runs, reproducibility, regress."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest
from conftest import ROOT
from typer.testing import CliRunner

from stratcli.cli import app
from stratcli.records.store import REQUIRED, is_partial, read_record
from stratcli.scenario import load_scenario
from stratcli.stratified import plan_sequence

runner = CliRunner()
TASK_C = ROOT / "scenarios" / "sim4_task_c.toml"


def _plan(tmp_path, scenario=TASK_C, *args):
    result = runner.invoke(
        app, ["plan", str(scenario), "--out", str(tmp_path), "--quiet", "--no-animation", *args]
    )
    assert result.exit_code == 0, result.output
    (run,) = [p for p in tmp_path.iterdir() if p.is_dir()]
    return run


def test_record_holds_every_file_and_never_overwrites(tmp_path):
    first = _plan(tmp_path)
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


def test_replanning_a_record_reproduces_it(tmp_path):
    """Energy and coefficients to 1e-9 from the record's own scenario.toml."""
    run = _plan(tmp_path)
    record = read_record(run)
    task = load_scenario(run / "scenario.toml")
    again = plan_sequence(task.system, task.start, task.legs, task.settings)
    assert again.total_energy == pytest.approx(record.result["total_energy"], rel=1e-9, abs=1e-9)
    for leg, old in zip(again.legs, record.result["legs"], strict=True):
        for a, k in enumerate(leg.active):
            coeffs = old["pieces"][0]["coefficients"][task.system.inputs[k]]
            assert leg.coefficients[a].tolist() == pytest.approx(coeffs, abs=1e-9)


def test_show_reads_the_record_back(tmp_path):
    run = _plan(tmp_path)
    shown = runner.invoke(app, ["show", str(run)])
    assert shown.exit_code == 0
    assert "sim4_task_c" in shown.output and "S3" in shown.output and "total energy" in shown.output
    data = json.loads(runner.invoke(app, ["show", str(run), "--json"]).stdout)
    assert data["result"]["total_energy"] == read_record(run).result["total_energy"]
    assert data["mcap"]["topics"]["/state"] >= 200 * 3  # read back from run.mcap
    assert "run.mcap:" in shown.output
    listed = json.loads(runner.invoke(app, ["runs", "--out", str(tmp_path), "--json"]).stdout)
    assert [r["run"] for r in listed] == [run.name]


def test_show_refuses_missing_and_incomplete_records(tmp_path):
    missing = runner.invoke(app, ["show", str(tmp_path / "nope")])
    assert missing.exit_code == 2 and "no run record" in missing.output
    run = _plan(tmp_path)
    (run / "result.json").unlink()
    broken = runner.invoke(app, ["show", str(run)])
    assert broken.exit_code == 2 and "missing result.json" in broken.output
    partial = tmp_path / ".x.partial"
    partial.mkdir()
    assert runner.invoke(app, ["show", str(partial)]).exit_code == 2
    assert json.loads(runner.invoke(app, ["runs", "--out", str(tmp_path), "--json"]).stdout) == []


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


def test_regress_detects_a_regression(tmp_path):
    scen = tmp_path / "scen"
    scen.mkdir()
    (scen / "d.toml").write_text((ROOT / "scenarios" / "sim4_task_d.toml").read_text())
    base = tmp_path / "baseline.json"
    assert (
        runner.invoke(app, ["regress", str(scen), "--baseline", str(base), "--update"]).exit_code
        == 0
    )
    same = runner.invoke(app, ["regress", str(scen), "--baseline", str(base)])
    assert same.exit_code == 0 and "no regressions" in same.output
    doc = json.loads(base.read_text())
    doc["scenarios"]["d"]["total_energy"] *= 0.5  # the baseline was cheaper: now a regression
    base.write_text(json.dumps(doc))
    worse = runner.invoke(app, ["regress", str(scen), "--baseline", str(base)])
    assert worse.exit_code == 1 and "regression" in worse.output
    doc["scenarios"]["d"]["total_energy"] *= 4.0  # the baseline was dearer: changed, not failed
    doc["scenarios"]["gone"] = doc["scenarios"]["d"]
    base.write_text(json.dumps(doc))
    out = runner.invoke(app, ["regress", str(scen), "--baseline", str(base)])
    assert out.exit_code == 1 and "missing" in out.output  # a scenario vanished


def test_shipped_baseline_matches():
    result = runner.invoke(app, ["regress", str(ROOT / "scenarios"), "--baseline",
                                 str(ROOT / "scenarios" / "baseline.json")])  # fmt: skip
    assert result.exit_code == 0, result.output
