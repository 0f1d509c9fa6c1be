"""One sweep task: a row of the plan's own numbers, the same as planning the task's scenario
directly; a task that fails or raises is a row with its status and message."""

from __future__ import annotations

import copy
import json
import math

import pytest
from reintegrate import verify
from sweep_files import AUTO, GRID, ROOT, write

from stratcli.api import plan_auto, plan_run
from stratcli.scenario import load_scenario
from stratcli.sweep import load_sweep, run_task
from stratcli.time_scaling import peaks


def _payload(task, mode="legs", records="none", **changes):
    scenario = copy.deepcopy(task.scenario)
    for key, value in changes.items():
        scenario["planner"][key] = value
    return {
        "index": task.index, "inputs": task.inputs, "seed": task.seed, "scenario": scenario,
        "mode": mode, "check": True, "exhaustive": False, "records": records, "name": "t",
    }  # fmt: skip


def test_a_row_holds_the_plan_of_the_tasks_scenario(tmp_path):
    task = list(load_sweep(write(tmp_path, GRID)).tasks())[3]
    result = run_task(_payload(task))
    row = result["row"]
    direct = plan_run(load_scenario(task.scenario))
    assert row["status"] == "ok" and result["record"] is None
    assert row["energy"] == direct.result.total_energy and row["legs"] == 2
    assert row["sequence"] == "S1,S2" and row["goal.q1"] == task.inputs["goal.q1"]
    assert row["peak_control"] > 0 and row["excursion"] > 0
    json.dumps(row, allow_nan=False)  # plain, finite data
    loaded = load_scenario(task.scenario)
    verify(loaded, direct.document)  # the goal is reached on independent re-integration


def test_auto_mode_rows_name_the_sequence_chosen(tmp_path):
    task = next(load_sweep(write(tmp_path, GRID, scenario=AUTO, mode="auto")).tasks())
    row = run_task(_payload(task, mode="auto"))["row"]
    direct = plan_auto(load_scenario(task.scenario), jobs=1)
    assert row["status"] == "ok"
    assert row["sequence"] == ",".join(leg.stratum for leg in direct.best.result.legs)
    assert row["energy"] == direct.best.result.total_energy
    assert row["candidates"] == len(direct.comparison.outcomes) and row["reached"] >= 1


def test_failed_invalid_and_erroring_tasks_are_rows(tmp_path):
    task = next(load_sweep(write(tmp_path, GRID)).tasks())
    failed = run_task(_payload(task, records="failed", max_iterations=1, restarts=0))
    assert failed["row"]["status"] == "failed" and failed["row"]["message"]
    name, files = failed["record"]  # the failed task's run record, as file contents
    assert name == "task-000000" and "result.json" in files
    assert json.loads(files["result.json"])["status"] == "failed"
    invalid = run_task(_payload(task, tolerance=7))["row"]
    assert invalid["status"] == "invalid" and "planner.tolerance" in invalid["message"]
    broken = _payload(task)
    broken["scenario"] = None  # not a scenario at all: an exception inside the task
    row = run_task(broken)["row"]
    assert row["status"] == "error" and row["message"]


def test_a_constrained_tasks_row_holds_its_smallest_margins(tmp_path):
    task = list(load_sweep(write(tmp_path, GRID)).tasks())[3]
    payload = _payload(task)
    payload["scenario"]["constraints"] = {"joint_limits": [-3.0, 3.0], "max_rate": 5.0}
    row = run_task(payload)["row"]
    direct = plan_run(load_scenario(payload["scenario"])).result
    legs = direct.constraints.legs
    assert row["margin_joint_limit"] == min(m.joint_limit for m in legs)
    assert row["margin_rate"] == min(m.rate for m in legs)
    assert "margin_self_clearance" not in row  # not asked for
    assert "margin_joint_limit" not in run_task(_payload(task))["row"]


def test_a_rows_peak_control_is_the_plans_as_run(tmp_path):
    # the plan slowed to its rate limit (0.5 rad/s) has a longer basis period than the
    # task's settings: a row measured with those read 7.06 rad/s and a 39 rad excursion
    rated = ROOT / "scenarios" / "sim4_task_d_rate_limited.toml"
    body = '[[sweep.task]]\n"planner.tolerance" = 1e-3\n'
    task = next(load_sweep(write(tmp_path, body, scenario=rated)).tasks())
    row = run_task(_payload(task))["row"]
    plan = plan_run(load_scenario(task.scenario)).result
    assert row["status"] == "ok" and plan.time_scale < 0.1
    assert row["peak_control"] == pytest.approx(0.5, rel=1e-3)
    assert row["peak_control"] == pytest.approx(peaks(plan)[0].max(), rel=1e-3)
    assert row["excursion"] < 2 * math.pi


def test_auto_mode_rows_measure_the_chosen_plan_after_time_scaling(tmp_path):
    body = '[[sweep.task]]\n"planner.time_scale" = 2.0\n'
    task = next(load_sweep(write(tmp_path, body, scenario=AUTO, mode="auto")).tasks())
    row = run_task(_payload(task, mode="auto"))["row"]
    direct = plan_auto(load_scenario(task.scenario), jobs=1)
    as_planned = direct.comparison.best.peak_control
    assert row["status"] == "ok" and direct.best.result.time_scale == 2.0
    assert row["peak_control"] == pytest.approx(2.0 * as_planned, rel=1e-9)
    assert row["peak_control"] == pytest.approx(peaks(direct.best.result)[0].max(), rel=1e-3)


def test_a_tasks_record_names_the_command_that_plans_it_again(tmp_path):
    """The record's manifest gives a command that runs (there is none that plans one task of
    a sweep): planning the record's own scenario.toml with it gives the row's energy."""
    import subprocess
    import sys

    task = list(load_sweep(write(tmp_path, GRID)).tasks())[3]
    result = run_task(_payload(task, records="all"))
    _, files = result["record"]
    command = json.loads(files["manifest.json"])["command"]
    assert command == ["stratplan", "plan", "scenario.toml"] and result["record_lost"] is None
    (tmp_path / "scenario.toml").write_bytes(files["scenario.toml"])
    again = subprocess.run(
        [sys.executable, "-m", "stratcli", *command[1:], "--out", "runs", "--json", "-q"],
        cwd=tmp_path, capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert again.returncode == 0, again.stderr
    energy = json.loads(next((tmp_path / "runs").glob("*/result.json")).read_text())
    assert energy["total_energy"] == result["row"]["energy"]


def test_a_record_that_cannot_be_made_says_why_and_keeps_the_row(tmp_path, monkeypatch):
    import stratcli.api

    def broken(*args, **kwargs):
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(stratcli.api, "write_record", broken)
    task = list(load_sweep(write(tmp_path, GRID)).tasks())[3]
    result = run_task(_payload(task, records="all"))
    assert result["row"]["status"] == "ok" and result["record"] is None
    assert result["record_lost"] == "RuntimeError: disk on fire"
