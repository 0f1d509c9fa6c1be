"""Run-record use cases: writing, listing and reading records back."""

from __future__ import annotations

import json

from conftest import ROOT

from stratcli import api
from stratcli.scenario import load_scenario


def test_plan_returns_the_result_document_and_write_record_writes_it(tmp_path):
    outcome = api.plan_run(load_scenario(ROOT / "scenarios" / "sim4_task_d.toml"))
    assert outcome.ok and outcome.document["status"] == "ok"
    assert outcome.planning_time > 0 and outcome.compile_time > 0
    run_dir = api.write_record(tmp_path, outcome, animation=False, argv=["notebook"])
    assert json.loads((run_dir / "result.json").read_text()) == outcome.document
    assert json.loads((run_dir / "manifest.json").read_text())["command"] == ["notebook"]
    assert api.list_runs(tmp_path)[0]["run"] == run_dir.name
    record, _ = api.read_run(run_dir)
    assert record.result == outcome.document


def test_plans_are_equal_by_value_as_values_should_be(tmp_path):
    """A plan equals its pickle and its record read back (== was identity: a plan compared
    with its own round trip was unequal); the same scenario planned again differs in its
    times, and equal plans hash alike."""
    import pickle

    plan = api.plan_run(load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")).result
    again = pickle.loads(pickle.dumps(plan))
    assert again == plan and hash(again) == hash(plan) and not (again != plan)
    assert api.load_run(api.write_record(tmp_path, plan, animation=False)) == plan
    replanned = api.plan_run(load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")).result
    assert replanned != plan and replanned.total_energy == plan.total_energy
    assert plan != plan.to_dict() and {plan: 1}[again] == 1


def test_load_run_of_the_runs_folder_names_the_latest_record_in_it(tmp_path):
    """`load_run("runs")`, where `write_record("runs", plan)` wrote, said only "missing
    scenario.toml, result.json, manifest.json"."""
    import pytest

    from stratcli.errors import InputError

    plan = api.plan_run(load_scenario(ROOT / "scenarios" / "unicycle.toml")).result
    first = api.write_record(tmp_path, plan, animation=False)
    (tmp_path / "notes").mkdir()  # not a record: not counted
    with pytest.raises(InputError) as info:
        api.load_run(tmp_path)
    assert str(info.value) == (
        f"{tmp_path} is a folder of 1 run record, not one: give one of them (the latest: {first})"
    )
    second = api.write_record(tmp_path, plan, animation=False)
    with pytest.raises(InputError, match=f"folder of 2 run records, .*latest: {second}\\)$"):
        api.load_run(tmp_path)
    with pytest.raises(InputError, match="notes is not a complete run record: missing "):
        api.load_run(tmp_path / "notes")
