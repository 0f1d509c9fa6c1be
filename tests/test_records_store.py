"""Reading records back: a record's own scenario re-plans it exactly."""

from __future__ import annotations

import pytest
from conftest import ROOT
from typer.testing import CliRunner

from stratcli.cli import app
from stratcli.objectives import plan_sequence
from stratcli.records.store import read_record
from stratcli.scenario import load_scenario

runner = CliRunner()


TASK_C = ROOT / "scenarios" / "sim4_task_c.toml"


def _plan(tmp_path, scenario=TASK_C, *args):
    result = runner.invoke(
        app, ["plan", str(scenario), "--out", str(tmp_path), "--quiet", "--no-animation", *args]
    )
    assert result.exit_code == 0, result.output
    (run,) = [p for p in tmp_path.iterdir() if p.is_dir()]
    return run


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
