"""Run-record use cases: writing, listing and reading records back."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from conftest import ROOT

import stratcli
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
    assert api.list_runs(tmp_path)[0]["path"] == str(run_dir)  # (a script shows or loads it)
    record, _ = api.read_run(run_dir)
    assert record.result == outcome.document


def test_plans_are_equal_by_value_as_values_should_be(tmp_path):
    """A plan equals its pickle and its record read back (== was identity: a plan compared
    with its own round trip was unequal), and the same scenario planned again (from its file
    or a dict of its tables: the times its starts took aside, which made it unequal); equal
    plans hash alike, and another task's plan is another plan."""
    import pickle
    import tomllib

    plan = api.plan_run(load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")).result
    again = pickle.loads(pickle.dumps(plan))
    assert again == plan and hash(again) == hash(plan) and not (again != plan)
    assert api.load_run(api.write_record(tmp_path, plan, animation=False)) == plan
    replanned = api.plan_run(load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")).result
    assert replanned == plan and hash(replanned) == hash(plan)
    tables = tomllib.loads((ROOT / "scenarios" / "sim4_task_d.toml").read_text())
    assert api.plan_run(load_scenario(tables)).result == plan  # no comments, other layout
    tables["planner"]["tolerance"] = 1e-4
    assert api.plan_run(load_scenario(tables)).result != plan
    assert plan != plan.to_dict() and {plan: 1}[again] == 1


def test_a_urdf_plan_equals_its_record_read_back(tmp_path):
    """The record names its own copy of the URDF (`path = "arm3.urdf"`), so the scenario
    texts differ: a URDF plan read back was unequal to the plan; another URDF is not."""
    pytest.importorskip("pinocchio")
    scenario = ROOT / "scenarios" / "spatial" / "arm3_reorient.toml"
    plan = api.plan_run(load_scenario(scenario).with_changes({"planner.objective": "newton"}))
    plan = plan.result
    run = api.write_record(tmp_path / "a", plan, animation=False)
    back = api.load_run(run)
    assert 'path = "arm3.urdf"' in back.scenario_text and back.scenario_text != plan.scenario_text
    # resolved.json names the record's copy too (it named the original, absolute)
    assert json.loads((run / "resolved.json").read_text())["model"]["path"] == "arm3.urdf"
    assert load_scenario(run / "resolved.json").system.spatial.text == plan.system.spatial.text
    assert back == plan and hash(back) == hash(plan)
    moved = tmp_path / "robot"
    moved.mkdir()
    urdf = (ROOT / "robots" / "arm3.urdf").read_text()
    (moved / "arm3.urdf").write_text(urdf.replace("<robot", "<!-- edited -->\n<robot", 1))
    other = plan.scenario_text.replace("../../robots/arm3.urdf", str(moved / "arm3.urdf"))
    replanned = api.plan_run(load_scenario(other)).result
    assert replanned.to_dict()["total_energy"] == plan.to_dict()["total_energy"]
    assert replanned != plan  # (the same numbers, another URDF text)


def test_comparisons_and_decompositions_are_equal_by_value_as_values_should_be():
    """A new user found `pickle.loads(pickle.dumps(out)) == out` False for a comparison and
    `decompose(f) == decompose(f)` False: legs compared by identity, and the NaN energies of
    sequences not searched never equal to themselves. Both are values now; the screened and
    the exhaustive comparisons differ (rows not searched against rows searched)."""
    import pickle

    out = stratcli.compare_sequences(ROOT / "scenarios" / "sim4_auto.toml", jobs=1)
    again = pickle.loads(pickle.dumps(out))
    assert again == out and not (again != out)
    assert hash(again) == hash(out) and hash(out.best) == hash(out.best.result)  # (unhashable)
    bounded = [o for o in out.comparison.outcomes if o.screened]
    assert bounded and all(np.isnan(o.energy) for o in bounded)  # NaN still means unknown
    assert {o: 1 for o in out.comparison.outcomes}[again.comparison.outcomes[0]] == 1
    dec = stratcli.decompose(ROOT / "scenarios" / "sim4_auto.toml")
    assert dec == stratcli.decompose(ROOT / "scenarios" / "sim4_auto.toml")
    assert dec == pickle.loads(pickle.dumps(dec))
    assert hash(dec) == hash(pickle.loads(pickle.dumps(dec)))
    report = stratcli.check_controllability("one-arm", samples=3)
    assert {report: 1}[pickle.loads(pickle.dumps(report))] == 1
    legs = dec.decomposition.candidates[0].legs
    leg = legs[0]
    assert hash(leg) == hash(pickle.loads(pickle.dumps(leg)))
    # equal goals hash alike, a zero of either sign among them (a review found -0.0 did not)
    signed = dataclasses.replace(leg, goal=np.where(leg.goal == 0.0, -0.0, leg.goal))
    assert signed == leg and hash(signed) == hash(leg) and len({signed, leg}) == 1
    moved = dataclasses.replace(leg, goal=leg.goal + 1e-9)
    assert moved != leg
    # a comparison without a reference duration (NaN) equals its pickle too
    plain = dataclasses.replace(out.comparison, reference_duration=float("nan"))
    assert pickle.loads(pickle.dumps(plain)) == plain
    full = stratcli.compare_sequences(ROOT / "scenarios" / "sim4_auto.toml", exhaustive=True)
    assert full != out


def test_load_run_of_the_runs_folder_names_the_latest_record_in_it(tmp_path):
    """`load_run("runs")`, where `write_record("runs", plan)` wrote, said only "missing
    scenario.toml, result.json, manifest.json"."""

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


def test_a_record_asked_into_a_file_says_it_is_a_file(tmp_path):
    from stratcli.errors import RecordError

    plan = api.plan_run(load_scenario(ROOT / "scenarios" / "unicycle.toml")).result
    (tmp_path / "afile").write_text("")
    with pytest.raises(RecordError, match=r"afile: it is a file, not a directory$"):
        api.write_record(tmp_path / "afile", plan, animation=False)


def test_a_record_asked_into_a_dangling_link_names_the_link(tmp_path):
    """A symbolic link to a folder that is gone said only "File exists"."""
    from stratcli.errors import RecordError

    plan = api.plan_run(load_scenario(ROOT / "scenarios" / "unicycle.toml")).result
    (tmp_path / "runs").symlink_to(tmp_path / "gone")
    with pytest.raises(RecordError, match=r"runs: it is a link to .*gone, which does not exist$"):
        api.write_record(tmp_path / "runs", plan, animation=False)


def test_a_plan_from_a_document_that_is_not_one_is_one_input_error():
    """`SequencePlan.from_dict` is public: `{}` raised KeyError: 'coordinates' from inside
    the package, a leg's pieces given as text a TypeError. Each is an `InputError` saying
    what was wrong, and a whole document still reads back as its plan."""
    plan = api.plan_run(load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")).result
    doc = plan.to_dict()
    broken = {
        "no coordinates": ({}, "no 'coordinates'"),
        "a list": ([], "a dict, not list"),
        "pieces as text": (
            {**doc, "legs": [{**doc["legs"][0], "pieces": "x"}]},
            "not a result document",
        ),
        "legs a number": ({**doc, "legs": 5}, "not a result document"),
    }
    for bad, words in broken.values():
        with pytest.raises(stratcli.InputError, match=words):
            stratcli.SequencePlan.from_dict(bad)
    assert stratcli.SequencePlan.from_dict(doc).to_dict() == doc


def test_an_outcomes_document_is_read_only_and_writing_its_record_keeps_its_value(tmp_path):
    """Outcomes said they were frozen values, each equal to its pickle, but their documents
    were plain dicts (`outcome.document["status"] = ...` was taken), and after
    `write_record` added the record's phases to it an outcome no longer equalled its own
    pickle from before. Documents refuse changes, are still dicts and lists to json and ==,
    and a deep copy is a plain one to edit; the phases (timings) are no part of the value."""
    import copy
    import pickle

    task = load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")
    outcome = api.plan_run(task)
    report = stratcli.check_controllability(task)
    for doc in (outcome.document, report.document):
        with pytest.raises(TypeError, match="read-only"):
            doc["status"] = "changed"
        first_list = next(v for v in doc.values() if isinstance(v, list))
        with pytest.raises(TypeError, match="read-only"):
            first_list.append(1)
        assert json.loads(json.dumps(doc)) == doc
        mine = copy.deepcopy(doc)
        mine["status"] = "mine"
        assert type(mine) is dict and doc.get("status") != "mine"
    with pytest.raises(TypeError, match="read-only"):
        outcome.document["legs"][0]["pieces"][0].update(energy=0)
    # copies are plain and changeable; a pickled document needs no stratplan to be read;
    # an outcome pickled or deep-copied holds its document read-only again
    assert type(copy.copy(outcome.document)) is dict
    assert type(pickle.loads(pickle.dumps(outcome.document))) is dict
    for again in (pickle.loads(pickle.dumps(outcome)), copy.deepcopy(outcome)):
        assert again == outcome
        with pytest.raises(TypeError, match="read-only"):
            again.document["status"] = "changed"
    assert dataclasses.asdict(outcome)["document"] == outcome.document  # (it recursed)
    before = pickle.dumps(outcome)
    run = api.write_record(tmp_path, outcome, animation=False)
    assert "write" in outcome.phases and pickle.loads(before) == outcome
    assert json.loads((run / "result.json").read_text()) == outcome.document
    # a second record of it has the planning's phases and its own, not the first record's
    # ("write" and "total" had come into the second manifest from the first)
    again = api.write_record(tmp_path / "again", outcome, animation=False)
    first, second = (json.loads((r / "manifest.json").read_text())["phases"] for r in (run, again))
    assert sorted(first) == sorted(second) and "write" not in second and "total" not in second
    assert second["planning"] == first["planning"]


def test_a_plans_constraints_and_what_it_met_of_them_are_read_only_values():
    """A task's resolved [constraints] compared by identity (`==` of its pickle raised: an
    array's truth value) and its limits could be changed in place under a plan that had used
    them; the plan's report of them (spec, first violation, joint limits) was plain dicts
    inside a frozen result. Both are values now: equal to their pickles, read-only."""
    import copy
    import pickle

    task = load_scenario(ROOT / "scenarios" / "sim4_task_d_constrained.toml")
    limits = task.constraints
    again = pickle.loads(pickle.dumps(limits))
    assert again == limits and again is not limits
    assert again != dataclasses.replace(limits, clearance=limits.clearance + 0.01)
    with pytest.raises(ValueError, match="read-only"):
        limits.lower[0] = 0.0
    report = api.plan_run(task, check=False).result.constraints
    assert report.joint_limits and report.spec["self_collision"] is True
    for value in (limits, again, report, pickle.loads(pickle.dumps(report)), copy.deepcopy(report)):
        with pytest.raises(TypeError, match="read-only"):
            value.spec["self_collision"] = False
    with pytest.raises(TypeError, match="read-only"):
        report.joint_limits["q1"]["lower"] = 0.0
    assert pickle.loads(pickle.dumps(report)) == report
    assert json.loads(json.dumps(report.to_dict())) == report.to_dict()


def test_values_read_back_from_a_pickle_are_read_only_as_made():
    """numpy pickles arrays writable and a FrozenDict pickles as a dict: a plan that came
    back from a `--jobs` worker had writable controls, a comparison's outcomes were a list,
    and a LegSpec's goal (which it hashes by) could be changed under a set holding it."""
    import pickle

    task = load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")
    plan = pickle.loads(pickle.dumps(api.plan_run(task, check=False).result))
    arrays = [plan.start, plan.goal, plan.legs[0].start, plan.legs[0].pieces[0].coefficients]
    arrays.append(plan.switches[0].jump)
    assert arrays and not any(a.flags.writeable for a in arrays)
    leg = pickle.loads(pickle.dumps(stratcli.LegSpec("S1", [0.0, 1.0, 2.0, 3.0])))
    mine = [0.0, 1.0, 2.0, 3.0]
    assert not stratcli.LegSpec("S1", np.array(mine)).goal.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        leg.goal[0] = 5.0
    auto = api.plan_auto(load_scenario(ROOT / "scenarios" / "sim4_auto.toml"), check=False)
    for value in (auto, pickle.loads(pickle.dumps(auto))):
        comparison = value.comparison
        assert type(comparison.outcomes) is tuple and type(comparison.ranking) is tuple
        with pytest.raises(TypeError, match="read-only"):
            value.settings.origin["strata"] = "mine"
        if comparison.screen is not None:
            with pytest.raises(TypeError, match="read-only"):
                comparison.screen.bounds[0] = 0.0


def test_one_run_that_cannot_be_read_is_skipped_not_the_whole_listing(tmp_path, monkeypatch):
    """`chmod 000` on one run directory: `stratplan runs` printed "permission denied" for it
    and listed none of the others (exit 2); it is skipped with that line, as damaged ones are."""
    from pathlib import Path

    task = load_scenario(ROOT / "scenarios" / "sim1_l_c1.toml")
    outcome = api.plan_run(task)
    kept = api.write_record(tmp_path, outcome, animation=False)
    locked = api.write_record(tmp_path, outcome, animation=False)
    real = Path.exists

    def exists(self):  # as root, chmod 000 is no bar: the error it would raise
        if self.parent == locked:
            raise PermissionError(13, "Permission denied", str(self))
        return real(self)

    monkeypatch.setattr(Path, "exists", exists)
    said = []
    listed = api.list_runs(tmp_path, on_damaged=said.append)
    assert [run["path"] for run in listed] == [str(kept)]
    assert said == [f"{locked / 'result.json'}: permission denied"]
