"""Reading records back: a record's own scenario re-plans it exactly."""

from __future__ import annotations

import pytest
from conftest import plan_record
from typer.testing import CliRunner

from stratcli.objectives import plan_sequence
from stratcli.records.store import read_record
from stratcli.scenario import load_scenario

runner = CliRunner()


def test_replanning_a_record_reproduces_it(tmp_path):
    """Energy and coefficients to 1e-9 from the record's own scenario.toml."""
    run = plan_record(tmp_path)
    record = read_record(run)
    task = load_scenario(run / "scenario.toml")
    again = plan_sequence(task.system, task.start, task.legs, task.settings)
    assert again.total_energy == pytest.approx(record.result["total_energy"], rel=1e-9, abs=1e-9)
    for leg, old in zip(again.legs, record.result["legs"], strict=True):
        for a, k in enumerate(leg.active):
            coeffs = old["pieces"][0]["coefficients"][task.system.inputs[k]]
            assert leg.coefficients[a].tolist() == pytest.approx(coeffs, abs=1e-9)


def test_a_record_from_before_targets_reads_its_free_goals_as_free(tmp_path):
    """Records written before each leg's `targets`: the unlocked coordinates with a goal
    (a free "*" goal is none), as the planner chose them."""
    import json
    from pathlib import Path

    import stratcli

    root = Path(__file__).resolve().parents[1]
    plan = stratcli.plan(root / "scenarios" / "biped.toml", check=False)
    assert any(len(leg.targets) < len(plan.coordinates) - len(leg.locked) for leg in plan.legs)
    run = stratcli.write_record(tmp_path / "runs", plan)
    doc = json.loads((run / "result.json").read_text())
    for leg in doc["legs"]:
        del leg["targets"]
    (run / "result.json").write_text(json.dumps(doc))
    again = stratcli.load_run(run)
    assert [leg.targets for leg in again.legs] == [leg.targets for leg in plan.legs]
