"""A sweep file where a scenario is expected, and a scenario where a sweep is: one line that
says which it is and which command takes it (each table of the one was a problem of the
other: 4 and 8 lines that did not say so)."""

from __future__ import annotations

import tomllib

import pytest
from conftest import ROOT
from typer.testing import CliRunner

import stratcli
from stratcli.cli import app
from stratcli.errors import InputError
from stratcli.sweep.spec import load_sweep

SWEEP = ROOT / "scenarios" / "sweeps" / "sim4_goal_map.toml"
SCENARIO = ROOT / "scenarios" / "sim4_task_d.toml"


@pytest.mark.parametrize("command", ["plan", "check", "models", "decompose"])
def test_a_sweep_file_given_as_a_scenario_says_to_sweep_it(command):
    result = CliRunner().invoke(app, [command, str(SWEEP)])
    assert result.exit_code == 2, result.output
    (line,) = result.output.strip().splitlines()
    assert line == (
        f"error: {SWEEP}: a sweep file (a [sweep] table, no [model] or [task]), not a scenario: "
        f"run it with `stratplan sweep {SWEEP}` (in Python: run_sweep)"
    )


def test_a_scenario_given_as_a_sweep_says_to_plan_it(tmp_path):
    result = CliRunner().invoke(app, ["sweep", str(SCENARIO), "--out", str(tmp_path / "s")])
    assert result.exit_code == 2, result.output
    (line,) = result.output.strip().splitlines()
    assert line.startswith(f"error: {SCENARIO}: a scenario file (a [model] or [task] table, no ")
    assert f"plan it with `stratplan plan {SCENARIO}`" in line
    assert not (tmp_path / "s").exists()


def test_the_library_refuses_either_as_the_other_whatever_the_source_kind():
    sweep, scenario = SWEEP.read_text(), SCENARIO.read_text()
    for source in (SWEEP, sweep, tomllib.loads(sweep)):
        with pytest.raises(InputError, match=r"a sweep file \(a \[sweep\] table.*run_sweep\)$"):
            stratcli.load_scenario(source)
    for source in (SCENARIO, scenario, tomllib.loads(scenario)):
        with pytest.raises(InputError, match=r"a scenario file \(a \[model\] or \[task\] table"):
            load_sweep(source)
    assert load_sweep(SWEEP).name and stratcli.load_scenario(SCENARIO).scenario.name


def test_a_records_resolved_json_is_a_scenario_on_the_command_line(tmp_path):
    """The README says a record's resolved.json re-plans it; the command line read it as
    TOML: `not valid TOML: Invalid statement (at line 1, column 1: {)`."""
    import json

    runner = CliRunner()
    result = runner.invoke(app, ["plan", str(SCENARIO), "--out", str(tmp_path / "a"), "-q"])
    assert result.exit_code == 0, result.output
    (run,) = (tmp_path / "a").iterdir()
    again = runner.invoke(
        app, ["plan", str(run / "resolved.json"), "--out", str(tmp_path / "b"), "-q", "--json"]
    )
    assert again.exit_code == 0, again.output
    first = json.loads((run / "result.json").read_text())
    assert json.loads(again.stdout)["total_energy"] == first["total_energy"]
    (tmp_path / "bad.json").write_text('{"model": ')
    bad = runner.invoke(app, ["check", str(tmp_path / "bad.json")])
    assert bad.exit_code == 2
    assert bad.output.strip() == (
        f"error: {tmp_path / 'bad.json'}: not valid JSON: Expecting value (at line 1, column 11)"
    )
