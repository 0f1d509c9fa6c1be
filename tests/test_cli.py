"""The command line: exit codes, one clear line per problem naming file and field, records."""

from __future__ import annotations

import json
import re

import pytest
from conftest import ROOT
from typer.testing import CliRunner

from stratcli.cli import app

runner = CliRunner()
TASK_D = (ROOT / "scenarios" / "sim4_task_d.toml").read_text()


def run(tmp_path, text: str, *args: str):
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path / "runs"), *args])
    return result, path


def _one_line_errors(result, path) -> list[str]:
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    lines = [x for x in result.output.splitlines() if x.startswith("error:")]
    assert lines and all(str(path) in x for x in lines)
    return lines


def test_plan_writes_a_record_and_prints_the_table(tmp_path):
    result, _ = run(tmp_path, TASK_D)
    assert result.exit_code == 0, result.output
    assert "total energy" in result.output and "paper: 124.59" in result.output
    (run_dir,) = (tmp_path / "runs").iterdir()
    assert re.fullmatch(r"\d{8}T\d{6}Z-sim4_task_d-[0-9a-f]{8}", run_dir.name)
    doc = json.loads((run_dir / "result.json").read_text())
    assert doc["schema"] == "stratplan.result/1" and doc["status"] == "ok"
    assert doc["coordinates"] == ["q1", "q2", "q3", "theta"]
    assert (run_dir / "scenario.toml").read_text() == TASK_D
    assert json.loads((run_dir / "manifest.json").read_text())["exit_code"] == 0


def test_time_scaled_plan_is_compared_with_the_paper_at_its_own_speed(tmp_path):
    """--time-scale 2 doubles the energy; the paper's value is for 1 s legs, so the ratio is
    taken at time scale 1, and the table's energies are the scaled ones."""
    result, _ = run(tmp_path, TASK_D, "--time-scale", "2", "--no-animation")
    assert result.exit_code == 0, result.output
    (run_dir,) = (tmp_path / "runs").iterdir()
    doc = json.loads((run_dir / "result.json").read_text())
    own = doc["total_energy"] / 2
    text = " ".join(result.output.split())
    assert f"at time scale 1: {own:,.2f}; paper: 124.59, ratio {own / 124.59:.2f}" in text
    assert "before time scaling" in text


def test_json_output_is_the_result_document(tmp_path):
    result, _ = run(tmp_path, TASK_D, "--json")
    assert result.exit_code == 0
    doc = json.loads(result.stdout)
    assert [leg["stratum"] for leg in doc["legs"]] == ["S3", "S1"]


BAD = {
    "malformed TOML": (TASK_D.replace('name = "one-arm"', 'name = "one-arm'), "not valid TOML"),
    "unknown key": (
        TASK_D.replace("tolerance = 1e-3", "tolerence = 1e-3"),
        "planner.tolerence: unknown key (allowed: continuity",
    ),
    "wrong type": (
        TASK_D.replace("tolerance = 1e-3", 'tolerance = "small"'),
        "planner.tolerance: ",
    ),
    "bad angle": (
        TASK_D.replace('start = [0, "pi/4", 0, 0]', 'start = [0, "pi/4x", 0, 0]'),
        "task.start[1]",
    ),
    "wrong vector length": (
        TASK_D.replace('start = [0, "pi/4", 0, 0]', 'start = [0, "pi/4", 0]'),
        "task.start: needs 4 values (q1, q2, q3, theta), got 3",
    ),
    "unknown preset": (
        TASK_D.replace('name = "one-arm"', 'name = "three-arm"'),
        "model.name: Input should be 'one-arm' or 'two-arm'",
    ),
    "unknown stratum": (
        TASK_D.replace('stratum = "S3"', 'stratum = "S5"'),
        "legs[0].stratum: unknown stratum 'S5' (this model has: S1, S2, S3)",
    ),
    "locked coordinate moved": (
        TASK_D.replace('stratum = "S3"', 'stratum = "S1"'),
        "legs[0].goal: leg 1 on S1: q1 is locked at 0",
    ),
    "too few coefficients": (
        TASK_D.replace(
            "tolerance = 1e-3", "tolerance = 1e-3\nsoft_start = true\nbasis.harmonics = 1"
        ),
        "leave 1 free coefficients for 3 goal coordinates: 2 missing",
    ),
    "missing field": (TASK_D.replace('name = "sim4_task_d"\n', ""), "name: required field"),
    # strict types: nothing is coerced silently
    "string for a bool": (
        TASK_D.replace("tolerance = 1e-3", 'tolerance = 1e-3\nsoft_start = "yes"'),
        "planner.soft_start: Input should be a valid boolean",
    ),
    "string for an int": (
        TASK_D.replace("tolerance = 1e-3", 'tolerance = 1e-3\nbasis.harmonics = "3"'),
        "planner.basis.harmonics: Input should be a valid integer",
    ),
    "string for an energy": (
        TASK_D.replace("energy = 124.59", 'energy = "124"'),
        "reference.energy: Input should be a valid number",
    ),
    # non-finite and out-of-range numbers name their field
    "nan start": (
        TASK_D.replace('start = [0, "pi/4", 0, 0]', "start = [0, nan, 0, 0]"),
        "task.start[1]: must be a finite number",
    ),
    "nan goal": (
        TASK_D.replace('goal = ["-pi/3", "pi/3", "pi/4", "-pi/12"]', "goal = [nan, 0, 0, 0]"),
        "task.goal[0]: must be a finite number",
    ),
    "huge angle": (
        TASK_D.replace('start = [0, "pi/4", 0, 0]', "start = [0, 1e38, 0, 0]"),
        "task.start[1]: Input should be less than or equal to 10000",
    ),
    "huge time scale": (
        TASK_D.replace("tolerance = 1e-3", "tolerance = 1e-3\ntime_scale = 1e308"),
        "planner.time_scale: Input should be less than or equal to 1000",
    ),
    "huge leg duration": (
        TASK_D.replace("tolerance = 1e-3", "tolerance = 1e-3\nleg_duration = 1e308"),
        "planner.leg_duration: Input should be less than or equal to 1000",
    ),
    "infinite tolerance": (
        TASK_D.replace("tolerance = 1e-3", "tolerance = inf"),
        "planner.tolerance: must be a finite number",
    ),
    "tiny period": (
        TASK_D.replace("tolerance = 1e-3", "tolerance = 1e-3\nbasis.period = 1e-12"),
        "spans 1e+12 basis periods",
    ),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_input_exits_2_naming_the_field(tmp_path, case):
    text, expected = BAD[case]
    result, path = run(tmp_path, text)
    lines = _one_line_errors(result, path)
    assert any(expected in line for line in lines), lines
    assert not (tmp_path / "runs").exists()  # nothing written for bad input


def test_missing_file_exits_2(tmp_path):
    result = runner.invoke(app, ["plan", str(tmp_path / "nope.toml")])
    assert result.exit_code == 2 and "cannot read scenario file" in result.output


UNSAFE = [
    "__import__('os').system('true')",
    "theta.__class__",
    "open('/etc/passwd')",
    "(lambda: 1)()",
    "[1][0]",
]


@pytest.mark.parametrize("expression", UNSAFE)
def test_expressions_are_never_evaluated(tmp_path, expression):
    text = (ROOT / "scenarios" / "biped.toml").read_text()
    text = text.replace('"alpha1*cos(theta)"', json.dumps(expression))
    result, path = run(tmp_path, text)
    lines = _one_line_errors(result, path)
    assert any("model.fields.u1[0]" in line and "not allowed" in line for line in lines), lines


def test_failed_leg_exits_1_and_still_writes_a_failed_record(tmp_path):
    text = TASK_D.replace("tolerance = 1e-3", "tolerance = 1e-12\nmax_iterations = 1\nrestarts = 0")
    result, _ = run(tmp_path, text)
    assert result.exit_code == 1
    assert "leg 1 on S3 did not reach its goal" in result.output and "try" in result.output
    (run_dir,) = (tmp_path / "runs").iterdir()
    doc = json.loads((run_dir / "result.json").read_text())
    assert doc["status"] == "failed" and "leg 1 on S3" in doc["message"]
    assert json.loads((run_dir / "manifest.json").read_text())["exit_code"] == 1


def test_models_lists_presets():
    result = runner.invoke(app, ["models"])
    assert result.exit_code == 0
    assert "one-arm" in result.output and "S24" in result.output


def test_models_describes_a_scenario_model():
    result = runner.invoke(app, ["models", str(ROOT / "scenarios" / "biped.toml")])
    assert result.exit_code == 0, result.output
    assert "x, y, theta, phi1, phi2" in result.output
    assert "S12" in result.output and "asks for the ode evaluator" in result.output


EXP_EXP = """
name = "exp_exp"
[model]
kind = "custom"
states = ["x", "y"]
inputs = ["u", "v"]
fields = { u = ["exp(exp(x))", "0"], v = ["0", "1"] }
[[model.strata]]
name = "S"
active = ["u", "v"]
[task]
start = [0, 0]
goal = [5, 1]
[planner]
objective = "newton"
[[legs]]
stratum = "S"
"""


def test_numerical_failure_is_a_failed_leg_with_a_record_not_a_traceback(tmp_path):
    """x' = exp(exp(x))·u overflows: the leg fails with its status, the record is written."""
    result, _ = run(tmp_path, EXP_EXP, "--no-check", "--no-animation")
    assert result.exit_code == 1, result.output
    assert "Traceback" not in result.output
    assert "leg 1 on S was stopped by a numerical failure" in result.stderr
    (run_dir,) = (tmp_path / "runs").iterdir()
    doc = json.loads((run_dir / "result.json").read_text())
    assert doc["status"] == "failed" and doc["legs"][0]["status"] == "numerical_failure"
    assert "numerical failure" in doc["message"]
