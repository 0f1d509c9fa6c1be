"""The use cases without the command line: outcomes are values, failures are exceptions."""

from __future__ import annotations

import inspect
import json

import pytest
from conftest import ROOT

from stratcli import api
from stratcli.errors import InputError, NotControllableError
from stratcli.scenario import load_scenario, parse_scenario

TURN_ONLY = """
name = "turn-only"
[model]
kind = "custom"
states = ["x", "y", "theta"]
inputs = ["v", "w"]
[model.fields]
v = ["cos(theta)", "sin(theta)", 0]
w = [0, 0, 1]
[[model.strata]]
name = "turn"
active = ["w"]
[task]
start = [0, 0, 0]
goal = [1, 0, 0]
[[legs]]
stratum = "turn"
"""


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


def test_a_leg_its_stratum_cannot_steer_raises_before_planning():
    task = parse_scenario(TURN_ONLY)
    with pytest.raises(NotControllableError) as caught:
        api.plan_run(task)
    assert any("leg 1 on turn" in p for p in caught.value.problems)
    report = api.check_controllability(task, samples=3)
    assert not report.controllable and report.problems == caught.value.problems


def test_check_a_preset_at_a_configuration_and_name_the_option_when_it_is_bad():
    report = api.check_controllability("one-arm", at="0, pi/3, 0, 0", samples=3)
    assert report.controllable and report.document["target"] == "one-arm"
    with pytest.raises(InputError, match="--at: needs 4 values"):
        api.check_controllability("one-arm", at="0, 1", samples=3)


def test_decompose_lists_the_candidates_without_planning():
    task = load_scenario(ROOT / "scenarios" / "sim4_auto.toml")
    outcome = api.decompose(task, max_length=2, strategy="both")
    assert outcome.document["strategies"] == ["conservative", "postponed"]
    assert len(outcome.document["sequences"]) == len(outcome.decomposition.candidates)
    with pytest.raises(InputError, match="--strategy"):
        api.decompose(task, strategy="eager")


PUBLIC = sorted(
    n for n in dir(api) if not n.startswith("_") and inspect.isfunction(getattr(api, n))
)


@pytest.mark.parametrize("name", PUBLIC)
def test_public_functions_document_their_parameters(name):
    obj = getattr(api, name)
    doc = inspect.getdoc(obj) or ""
    assert "Returns\n-------" in doc, name
    for parameter in inspect.signature(obj).parameters:
        assert f"\n{parameter} :" in doc, (name, parameter)
