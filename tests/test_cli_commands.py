"""The command line: exit codes, one clear line per problem naming file and field, every
command (plan, check, models, show, runs, decompose, compare-sequences)."""

from __future__ import annotations

import json
import re
import shutil
import tomllib
from csv import DictReader
from dataclasses import replace
from pathlib import Path

import pytest
from conftest import ROOT, UNICYCLE, plan_record
from typer.testing import CliRunner

import stratcli.cli as cli
from stratcli import load_scenario
from stratcli.api import plan_run
from stratcli.cli import app
from stratcli.objectives import plan_sequence
from stratcli.records.comparison import without_timings
from stratcli.records.store import read_record

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
    assert f"duration {doc['duration']:.4g} s" in text and doc["duration"] == 1.0  # 2 s / 2
    # the record holds the scenario as run: planning its scenario.toml gives the same plan
    # (it held the file unchanged, so that re-planning it gave half the energy)
    recorded = load_scenario(run_dir / "scenario.toml")
    assert recorded.scenario.planner.time_scale == 2.0
    again = plan_run(recorded, check=False).result
    assert again.total_energy == pytest.approx(doc["total_energy"], rel=1e-9)
    assert json.loads((run_dir / "resolved.json").read_text())["planner"]["time_scale"] == 2.0


TASK_A = (ROOT / "scenarios" / "sim4_task_a.toml").read_text()


@pytest.mark.parametrize(
    ("text", "key", "value", "misspelt", "choices", "meant"),
    [
        (TASK_D, "objective", "newton", "newtn", "energy or newton", "newton"),
        (TASK_A, "search", "starts", "loop", "loops, starts or legwise", "loops"),
    ],
)
def test_a_planner_option_plans_with_it_and_records_the_changed_scenario(
    tmp_path, text, key, value, misspelt, choices, meant
):
    """--objective newton plans sim4_task_d.toml (energy objective by default) by the paper's
    method, --search starts plans Sim 4 task A without loop starts: the energy of the plan
    with that setting, and the recorded scenario says it; a misspelt value is one line naming
    the option, as --format's, exit 2 (it named the planner field it sets, which a user did
    not write)."""
    result, path = run(tmp_path, text, f"--{key}", value, "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    task = load_scenario(path)
    expected = plan_sequence(
        task.system, task.start, task.legs, replace(task.settings, **{key: value})
    )
    assert doc["total_energy"] == pytest.approx(expected.total_energy, rel=1e-12)
    recorded = tomllib.loads((Path(doc["record"]) / "scenario.toml").read_text())
    assert recorded["planner"][key] == value
    bad, _ = run(tmp_path, text, f"--{key}", misspelt)
    assert bad.exit_code == 2
    assert bad.output.strip() == (
        f"error: --{key}: must be {choices} (got '{misspelt}': did you mean '{meant}'?)"
    )


def test_the_objective_option_plans_by_newton_and_the_search_option_without_loop_starts(
    tmp_path,
):
    """What the two options change: no energy search with newton; no loop start with
    starts (task A's default plan has one, lower). The --search choices are the settings'."""
    from typing import get_args

    from stratcli.cli.options import SearchChoice
    from stratcli.settings import SEARCHES

    assert get_args(SearchChoice) == SEARCHES  # (in the same order: the errors list them)
    result, _ = run(tmp_path, TASK_D, "--objective", "newton", "--json")
    doc = json.loads(result.output)
    assert doc["objective"] == "newton" and doc["optimisation"] is None
    result, path = run(tmp_path, TASK_A, "--search", "starts", "--json")
    doc = json.loads(result.output)
    assert "loop" not in [s["from"] for s in doc["optimisation"]["starts"]]
    task = load_scenario(path)
    default = plan_sequence(task.system, task.start, task.legs, task.settings)
    assert "loop" in [s.kind for s in default.optimisation.starts]
    assert default.total_energy < doc["total_energy"]


def test_json_output_is_the_result_document(tmp_path):
    result, _ = run(tmp_path, TASK_D, "--json")
    assert result.exit_code == 0
    doc = json.loads(result.stdout)
    assert [leg["stratum"] for leg in doc["legs"]] == ["S3", "S1"]


BAD = {
    "malformed TOML": (TASK_D.replace('name = "one-arm"', 'name = "one-arm'), "not valid TOML"),
    "unknown key": (
        TASK_D.replace("tolerance = 1e-3", "tolerence = 1e-3"),
        "planner.tolerence: unknown key: did you mean 'tolerance'? (allowed: continuity",
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
        "model.name: must be 'one-arm' or 'two-arm'",
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
        "planner.soft_start: must be a valid boolean",
    ),
    "string for an int": (
        TASK_D.replace("tolerance = 1e-3", 'tolerance = 1e-3\nbasis.harmonics = "3"'),
        "planner.basis.harmonics: must be a valid integer",
    ),
    "string for an energy": (
        TASK_D.replace("energy = 124.59", 'energy = "124"'),
        "reference.energy: must be a valid number",
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
        "task.start[1]: must be at most 10000",
    ),
    "huge time scale": (
        TASK_D.replace("tolerance = 1e-3", "tolerance = 1e-3\ntime_scale = 1e308"),
        "planner.time_scale: must be at most 1000",
    ),
    "huge leg duration": (
        TASK_D.replace("tolerance = 1e-3", "tolerance = 1e-3\nleg_duration = 1e308"),
        "planner.leg_duration: must be at most 1000",
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
    # the budget the scenario lowered comes first in the advice; counts agree in number
    assert "allow more planner.max_iterations (now 1, default 100)" in result.output
    assert "planner.restarts (now 0, default 11)" in result.output
    assert "in 1 attempt " in result.output
    # other strata too (a new user's leg failed at 7.5e5 where auto mode found 68.13)
    assert "or other strata (stratplan compare-sequences, or auto mode" in " ".join(
        result.output.split()
    )
    # the leg that was not planned is listed, and one leg's energy is not set beside the
    # paper's total
    assert "not planned" in result.output and "leg 1 of 2 only" in result.output
    assert "paper:" not in result.output
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


def test_models_json_lists_presets_and_describes_a_model_as_the_table_does():
    """`models` was the one command without --json."""
    presets = json.loads(runner.invoke(app, ["models", "--json"]).stdout)
    assert [p["model"] for p in presets] == ["one-arm", "two-arm"]
    assert (
        presets[0]["coordinates"] == ["q1", "q2", "q3", "theta"] and "S24" in presets[1]["strata"]
    )
    biped = json.loads(
        runner.invoke(app, ["models", str(ROOT / "scenarios" / "biped.toml"), "--json"]).stdout
    )
    assert biped["coordinates"] == ["x", "y", "theta", "phi1", "phi2"]
    assert [s["stratum"] for s in biped["strata"]] == ["S1", "S2", "S12"]
    assert all({"locked", "active", "dimension", "evaluator"} <= set(s) for s in biped["strata"])
    missing = runner.invoke(app, ["models", "nosuch", "--json"])
    assert missing.exit_code == 2 and "not a preset" in missing.output


def test_models_describes_a_scenarios_model_though_its_legs_are_wrong(tmp_path):
    """The strata's names are what legs must use: `models` refused to show them while a leg
    named one the model has not. The model is described, then the problems (exit 2)."""
    path = tmp_path / "badleg.toml"
    path.write_text(TASK_D.replace('stratum = "S1"', 'stratum = "S9"'))
    result = runner.invoke(app, ["models", str(path)])
    assert result.exit_code == 2
    assert result.stdout.startswith("one-arm model of badleg.toml") and "S3" in result.stdout
    assert "legs[1].stratum: unknown stratum 'S9'" in result.stderr
    broken = tmp_path / "badmodel.toml"  # a wrong [model] table: only its problem
    broken.write_text(TASK_D.replace('name = "one-arm"', 'name = "one-arms"'))
    result = runner.invoke(app, ["models", str(broken)])
    assert result.exit_code == 2 and result.stdout == ""


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
restarts = 0           # the search grinds (see issue 14): one short attempt shows it
max_iterations = 5
[[legs]]
stratum = "S"
"""


def test_numerical_failure_is_a_failed_leg_with_a_record_not_a_traceback(tmp_path):
    """x' = exp(exp(x))·u overflows: the leg fails with its status, the record is written."""
    result, _ = run(tmp_path, EXP_EXP, "--no-check", "--no-animation")
    assert result.exit_code == 1, result.output
    assert "Traceback" not in result.output
    assert "planning failed: leg 1 on S" in result.stderr
    (run_dir,) = (tmp_path / "runs").iterdir()
    doc = json.loads((run_dir / "result.json").read_text())
    assert doc["status"] == "failed" and doc["legs"][0]["status"] != "success"
    assert doc["message"].startswith("leg 1 on S") and "try" in doc["message"]


def test_show_reads_the_record_back(tmp_path, monkeypatch):
    run = plan_record(tmp_path)
    shown = runner.invoke(app, ["show", str(run)])
    assert shown.exit_code == 0
    assert "sim4_task_c" in shown.output and "S3" in shown.output and "total energy" in shown.output
    data = json.loads(runner.invoke(app, ["show", str(run), "--json"]).stdout)
    assert data["result"]["total_energy"] == read_record(run).result["total_energy"]
    assert data["mcap"]["topics"]["/state"] >= 200 * 3  # read back from run.mcap
    assert "run.mcap:" in shown.output
    listed = json.loads(runner.invoke(app, ["runs", "--out", str(tmp_path), "--json"]).stdout)
    assert [r["run"] for r in listed] == [run.name]
    # by its name as `runs` lists it, where the record is under ./runs (the default --out)
    runs = tmp_path / "here" / "runs"
    runs.mkdir(parents=True)
    shutil.copytree(run, runs / run.name)
    monkeypatch.chdir(tmp_path / "here")
    by_name = runner.invoke(app, ["show", run.name])
    assert by_name.exit_code == 0 and by_name.output == shown.output.replace(
        str(run), f"runs/{run.name}"
    )
    monkeypatch.chdir(runs / run.name)  # from inside it: its name, not "run  · started"
    here = runner.invoke(app, ["show", "."])
    assert here.exit_code == 0 and f"run {run.name} · started" in here.output


def test_show_refuses_missing_and_incomplete_records(tmp_path):
    missing = runner.invoke(app, ["show", str(tmp_path / "nope")])
    assert missing.exit_code == 2  # show reads sweeps too: the message says so
    assert f"no run record or sweep directory at {tmp_path / 'nope'}" in missing.output
    run = plan_record(tmp_path)
    (run / "comparison.json").write_text("[1, 2")  # a damaged comparison beside the plan
    damaged = runner.invoke(app, ["show", str(run)])
    assert damaged.exit_code == 2 and "Traceback" not in damaged.output
    assert f"{run / 'comparison.json'}: damaged record" in " ".join(damaged.output.split())
    (run / "comparison.json").unlink()
    inside = runner.invoke(app, ["show", str(run / "result.json")])  # a file of the record
    assert inside.exit_code == 2 and f"give its directory, {run}" in inside.output
    (run / "result.json").unlink()
    broken = runner.invoke(app, ["show", str(run)])
    assert broken.exit_code == 2 and "missing result.json" in broken.output
    partial = tmp_path / ".x.partial"
    partial.mkdir()
    assert runner.invoke(app, ["show", str(partial)]).exit_code == 2
    assert json.loads(runner.invoke(app, ["runs", "--out", str(tmp_path), "--json"]).stdout) == []


def test_runs_refuses_a_directory_that_is_not_there_and_points_into_a_folder_of_records(
    tmp_path,
):
    """`runs /nonexistent` said "no run records in /nonexistent" with exit 0 (a typo looked
    like an empty folder); on a sweep's folder it said its records/ was "a folder of 2 run
    records, not one: give one of them", then "no run records"."""
    for args in (["runs", str(tmp_path / "nope")], ["runs", "--out", str(tmp_path / "nope")]):
        missing = runner.invoke(app, args)
        assert missing.exit_code == 2
        assert missing.output.strip().endswith(
            f"{tmp_path / 'nope'}: no such directory (a folder of run records)"
        )
    records = tmp_path / "sweep" / "records"
    records.mkdir(parents=True)
    (tmp_path / "plans").mkdir()
    shutil.copytree(plan_record(tmp_path / "plans"), records / "task-000000")
    listed = runner.invoke(app, ["runs", str(tmp_path / "sweep")])
    assert listed.exit_code == 0
    assert (
        f"skipped: {records} is a folder of 1 run record: `stratplan runs {records}` lists them"
        in listed.output
    )
    inside = runner.invoke(app, ["runs", str(records)])
    assert f"{records / 'task-000000'}" in inside.output
    assert "a sweep's task is named task-<its index in the sweep>" in inside.output


def test_biped_is_not_controllable_on_its_strata_but_is_stratified_controllable(scenarios_dir):
    result = runner.invoke(app, ["check", str(scenarios_dir / "biped.toml"), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    strong = {s["stratum"]: s["strong"] for s in doc["strata"]}
    # the paper: not controllable on S1, S2, S12 (each reaches only 2 of 5 directions) ...
    assert strong == {"S1": False, "S2": False, "S12": False}
    assert doc["eq2"]["sum_min_rank"] == 4  # each stratum's closure alone: not enough
    # ... but stratified controllable by switching between them
    assert doc["eq2"]["by_switching"] and doc["stratified_controllable"]
    assert all(leg["ok"] for leg in doc["legs"])


TURN = 'active = ["v", "w"]\n[[model.strata]]\nname = "turn"\nactive = ["w"]'


def test_check_exit_code_3_names_the_stratum_and_configuration(tmp_path):
    scenario = tmp_path / "bad.toml"
    scenario.write_text(
        UNICYCLE.replace("goal = [0, 0.1, 0]", "goal = [1, 0, 0]")
        .replace('active = ["v", "w"]', TURN)
        .replace('stratum = "drive"', 'stratum = "turn"')
    )
    result = runner.invoke(app, ["check", str(scenario)])
    assert result.exit_code == 3
    assert "leg 1 on turn" in result.stderr and "q = (0, 0, 0)" in result.stderr
    planned = runner.invoke(app, ["plan", str(scenario), "--out", str(tmp_path / "runs")])
    assert planned.exit_code == 3 and "not controllable" in planned.stderr
    assert not any((tmp_path / "runs").iterdir())  # the directory is made, no record in it


def test_check_command_on_a_preset_prints_ranks_and_spanning_brackets():
    result = runner.invoke(app, ["check", "one-arm", "--at", "0, pi/3, 0, 0", "--samples", "5"])
    assert result.exit_code == 0, result.output
    assert "strongly controllable on every stratum" in result.output
    assert "[u2,u3]" in result.output
    bad = runner.invoke(app, ["check", "one-arm", "--at", "0, 1"])
    assert bad.exit_code == 2
    huge = runner.invoke(app, ["check", "one-arm", "--samples", "100000000"])  # was 137: killed
    assert huge.exit_code == 2 and "--samples" in huge.stderr and "100000" in huge.stderr


AUTO = ROOT / "scenarios" / "sim4_auto.toml"


AUTO_TEXT = AUTO.read_text()


@pytest.fixture
def newton(tmp_path):
    """The auto-mode scenario with the Newton objective (fast), as a file the CLI reads."""
    path = tmp_path / "scenario" / "sim4_auto.toml"
    path.parent.mkdir()
    path.write_text(AUTO_TEXT.replace("[planner]", '[planner]\nobjective = "newton"', 1))
    return path


def test_compare_sequences_takes_plans_objective_option(tmp_path):
    """compare-sequences lacked plan's --objective and --search: the comparison ran the
    scenario's objective only (sim4_auto's is energy: 2 s; --objective newton, 0.3 s)."""
    out = str(tmp_path / "runs")
    args = ["compare-sequences", str(AUTO), "--jobs", "1", "--out", out, "--json"]
    result = runner.invoke(app, [*args, "--objective", "newton"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["settings"]["objective"] == "newton"
    recorded = tomllib.loads((Path(doc["record"]) / "scenario.toml").read_text())
    assert recorded["planner"]["objective"] == "newton"
    ignored = runner.invoke(app, [*args, "--objective", "newton", "--search", "legwise",
                                  "--exhaustive"])  # fmt: skip
    assert ignored.exit_code == 0  # options that do nothing there say so
    assert "note: --search legwise is the energy objective's search: the Newton objective " in (
        ignored.stderr
    )
    assert "note: --exhaustive is for the energy objective's screen" in ignored.stderr
    bad = runner.invoke(app, [*args, "--search", "loop"])
    assert bad.exit_code == 2
    assert bad.output.strip() == (
        "error: --search: must be loops, starts or legwise (got 'loop': did you mean 'loops'?)"
    )


def test_a_suggested_command_names_a_path_with_spaces_as_a_shell_reads_it(tmp_path):
    """decompose ends with the compare-sequences command to run next: a scenario in a folder
    with spaces was printed bare, and pasting it split the path into extra arguments."""
    import shlex

    folder = tmp_path / "my tasks ü"
    folder.mkdir()
    scenario = folder / "auto task.toml"
    scenario.write_text(AUTO.read_text())
    result = runner.invoke(cli.app, ["decompose", str(scenario)])
    assert result.exit_code == 0, result.output
    command = " ".join(result.output.split()).rpartition("Plan and rank them: ")[2]
    assert shlex.split(command) == ["stratplan", "compare-sequences", str(scenario)]


def test_decompose_command_lists_the_papers_sequences(tmp_path):
    result = runner.invoke(cli.app, ["decompose", str(AUTO)])
    assert result.exit_code == 0, result.output
    assert "essential coordinates: q1, q2, q3, theta" in result.output
    out = result.output
    assert "S3 → S2 → S1" in out and "-π/12" in out and "-0.2618" in out  # π and radians
    doc = json.loads(runner.invoke(cli.app, ["decompose", str(AUTO), "--json"]).stdout)
    rows = {tuple(r["sequence"]): r for r in doc["sequences"]}
    assert rows[("S3", "S2", "S1")]["vias_pi"] == [
        ["-π/3", "π/3", "0", "-π/12"],
        ["-π/3", "π/3", "π/4", "-π/12"],
    ]
    assert rows[("S1", "S2")]["vias_pi"] == [["0", "π/3", "π/4", "-π/12"]]
    # what each candidate stratum moves, in the document the table is rendered from
    assert doc["moves"]["S1"] == ["q2", "q3", "theta"]
    assert "S1 moves q2, q3, theta" in out
    both = json.loads(
        runner.invoke(
            cli.app, ["decompose", str(AUTO), "--json", "--strategy", "both", "--max-length", "2"]
        ).stdout
    )
    assert len(both["sequences"]) == 12 and both["strategies"] == ["conservative", "postponed"]
    # its hint ranks the candidates listed: with the options asked (they were dropped)
    listed = runner.invoke(
        cli.app, ["decompose", str(AUTO), "--strategy", "both", "--max-length", "2"]
    )
    hint = " ".join(listed.output.split())
    assert f"stratplan compare-sequences {AUTO} --max-length 2 --strategy both" in hint


def test_compare_sequences_writes_the_record_and_jobs_do_not_matter(tmp_path, newton):
    docs, results = [], []
    for jobs in ("1", "2"):
        out = tmp_path / jobs
        args = ["compare-sequences", str(newton), "--max-length", "2", "--strategy", "both"]
        as_json = ["--json"] if jobs == "2" else []  # the table once, --json once
        result = runner.invoke(
            cli.app, [*args, "--jobs", jobs, "--out", str(out), "--no-animation", *as_json]
        )
        assert result.exit_code == 0, result.output
        (run_dir,) = out.iterdir()
        if as_json:  # comparison.json and where the record is, as `plan --json` prints
            printed = json.loads(result.stdout)
            assert printed.pop("record") == str(run_dir)
            assert printed == json.loads((run_dir / "comparison.json").read_text())
        else:
            assert "best: (" in result.output and "legs planned" in result.output
        names = {p.name for p in run_dir.iterdir()}
        assert {"comparison.json", "comparison.csv", "ranking.png", "result.json"} <= names
        assert {"manifest.json", "scenario.toml", "resolved.json"} <= names
        assert (run_dir / "ranking.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        doc = json.loads((run_dir / "comparison.json").read_text())
        csv = (run_dir / "comparison.csv").read_text().splitlines()
        assert len(csv) == 1 + len(doc["rows"]) == 13 and csv[0].startswith("rank,sequence")
        # the table has what the ranking is by (the energy in the shortest duration)
        table = list(DictReader(csv))
        ranked = [float(r["energy_equal_time"]) for r in table if r["status"] == "ok"]
        assert ranked == sorted(ranked) and len(ranked) > 1
        for line, row in zip(table, doc["rows"], strict=True):
            assert line["energy_equal_time"] == repr(row["energy_equal_time"])
        best = json.loads((run_dir / "result.json").read_text())
        assert [leg["stratum"] for leg in best["legs"]] == doc["rows"][0]["sequence"]
        assert best["total_energy"] == doc["rows"][0]["energy"]
        resolved = json.loads((run_dir / "resolved.json").read_text())
        assert [leg["stratum"] for leg in resolved["legs"]] == doc["rows"][0]["sequence"]
        # a plain scenario of the chosen sequence: it loads as it is (no [decompose] beside)
        assert resolved.get("decompose") is None
        again = load_scenario(resolved)
        assert [leg.stratum for leg in again.legs] == doc["rows"][0]["sequence"]
        shown = runner.invoke(cli.app, ["show", str(run_dir)])  # which sequence, and why
        assert shown.exit_code == 0 and f"best of 12 candidate sequences: {doc['choice']}" in (
            " ".join(shown.output.split())
        )
        read = json.loads(runner.invoke(cli.app, ["show", str(run_dir), "--json"]).stdout)
        assert read["comparison"] == doc and read["result"] == best
        docs.append(doc)
        results.append(best)
    assert docs[0]["jobs"] == 1 and docs[1]["jobs"] == 2
    assert without_timings(docs[0]) == without_timings(docs[1])
    assert results[0] == results[1]


def test_compare_sequences_none_reaching_the_goal_is_one_plain_line(tmp_path, newton):
    """Exit 1 and one `planning failed:` line as `plan` in auto mode prints (it read "no
    sequence reached the goal: no sequence reached the goal; ..."); the record is kept."""
    strict = "tolerance = 1e-12\nmax_iterations = 1\nrestarts = 0"
    newton.write_text(newton.read_text().replace("tolerance = 1e-3", strict, 1))
    args = ["compare-sequences", str(newton), "--max-length", "2", "--jobs", "1"]
    result = runner.invoke(cli.app, [*args, "--out", str(tmp_path / "r"), "--quiet"])
    assert result.exit_code == 1 and result.stdout == ""
    (line,) = result.stderr.splitlines()
    assert line.startswith("planning failed: no sequence reached the goal; the one that got")
    assert line.count("no sequence reached the goal") == 1
    (run_dir,) = (tmp_path / "r").iterdir()
    assert json.loads((run_dir / "result.json").read_text())["status"] == "failed"


def test_plan_in_auto_mode_chooses_and_says_why(tmp_path, newton):
    out = tmp_path / "runs"
    result = runner.invoke(cli.app, ["plan", str(newton), "--out", str(out), "--no-animation"])
    assert result.exit_code == 0, result.output
    assert "auto mode: 18 candidate sequences" in result.output
    assert "lowest total energy" in result.output and "total energy" in result.output
    (run_dir,) = out.iterdir()
    doc = json.loads((run_dir / "result.json").read_text())
    comparison = json.loads((run_dir / "comparison.json").read_text())
    assert doc["status"] == "ok" and doc["scenario"] == "sim4_auto" and doc["objective"] == "newton"
    ok = [r["energy"] for r in comparison["rows"] if r["status"] == "ok"]
    assert doc["total_energy"] == min(ok)
    assert [leg["stratum"] for leg in doc["legs"]] == comparison["rows"][0]["sequence"]
    # --json: the best plan's result.json and the choice (a script had to open the record's
    # comparison.json to learn which sequence won); --jobs as compare-sequences has it
    args = ["plan", str(newton), "--out", str(tmp_path / "j"), "--json", "--jobs", "1"]
    printed = json.loads(runner.invoke(cli.app, args).stdout)
    assert printed["comparison"]["rows"][0]["sequence"] == comparison["rows"][0]["sequence"]
    assert printed["total_energy"] == doc["total_energy"] and printed["record"]
    assert printed["comparison"]["jobs"] == 1


def test_auto_mode_with_a_free_goal_coordinate_plans_and_records_it_free(tmp_path, newton):
    """A goal with "*" (theta free) planned every candidate, then died writing the chosen
    sequence: `ValidationError ... goal.3 must be a finite number (got nan)`, exit 1, no
    record. Its resolved.json keeps the coordinate free and plans the same sequence again."""
    text = newton.read_text().replace(
        'goal = ["-pi/3", "pi/3", "pi/4", "-pi/12"]', 'goal = ["-pi/3", "pi/3", "pi/4", "*"]'
    )
    assert '"*"' in text
    newton.write_text(text)
    out = tmp_path / "runs"
    args = ["plan", str(newton), "--out", str(out), "--jobs", "1", "--quiet"]
    result = runner.invoke(cli.app, args)
    assert result.exit_code == 0, result.output
    (run_dir,) = out.iterdir()
    resolved = json.loads((run_dir / "resolved.json").read_text())
    assert resolved["task"]["goal"][3] is None and resolved["legs"][-1]["goal"][3] is None
    again = runner.invoke(
        cli.app,
        ["plan", str(run_dir / "resolved.json"), "--out", str(tmp_path / "again"), "--quiet"],
    )
    assert again.exit_code == 0, again.output
    (replanned,) = (tmp_path / "again").iterdir()
    first, second = (json.loads((d / "result.json").read_text()) for d in (run_dir, replanned))
    assert [leg["stratum"] for leg in second["legs"]] == [leg["stratum"] for leg in first["legs"]]
    assert second["total_energy"] == pytest.approx(first["total_energy"], rel=1e-9)


def test_auto_mode_where_no_candidate_can_be_searched_fails_as_exhaustive_does(tmp_path, newton):
    """Screened, a task whose every candidate has a leg with no plan even alone was bad input
    (exit 2) naming one candidate's leg, with no record; --exhaustive failed it properly
    (exit 1, the furthest sequence, a record). Now both fail the same way."""
    strict = "tolerance = 1e-9\nmax_iterations = 1\nrestarts = 0"
    energy = (
        newton.read_text()
        .replace('objective = "newton"\n', "")
        .replace("tolerance = 1e-3", strict, 1)
    )
    newton.write_text(energy.replace('"-pi/12"]', "1.5]", 1))
    codes = []
    for extra in ([], ["--exhaustive"]):
        out = tmp_path / f"runs{len(extra)}"
        args = [
            "compare-sequences",
            str(newton),
            "--max-length",
            "2",
            "--jobs",
            "1",
            "--out",
            str(out),
        ]
        result = runner.invoke(cli.app, [*args, *extra, "--quiet"])
        codes.append(result.exit_code)
        assert "planning failed: no sequence reached the goal" in result.stderr, result.output
        (run_dir,) = out.iterdir()
        assert json.loads((run_dir / "result.json").read_text())["status"] == "failed"
    assert codes == [1, 1]


BAD_DECOMPOSE = {
    "max_length": ("max_length = 3", "max_length = 0", "decompose.max_length: must be"),
    "strategy": (
        'strategy = "conservative"',
        'strategy = "eager"',
        "decompose.strategy: must be 'conservative', 'postponed' or 'both'",
    ),
    "criterion": (
        'criterion = "energy"',
        'criterion = "cost"',
        "decompose.criterion: must be",
    ),
    "unknown key": (
        "max_length = 3",
        "max_len = 3",
        "decompose.max_len: unknown key: did you mean 'max_length'? (allowed: max_length, "
        "strategy, criterion, strata)",
    ),
    "strata": (
        "max_length = 3",
        'max_length = 3\nstrata = ["S1", "S9"]',
        "decompose.strata[1]: unknown stratum 'S9' (this model has: S1, S2, S3)",
    ),
    "neither": ("[decompose]", "[other]", "legs: give either [[legs]]"),
    "too short": (
        "max_length = 3",
        "max_length = 1",
        "decompose.max_length: no sequence of at most 1 stratum",
    ),
    "strata move too little": (
        "max_length = 3",
        'max_length = 3\nstrata = ["S1"]',
        "decompose.strata: none of the strata listed moves q1",
    ),
}


@pytest.mark.parametrize("case", list(BAD_DECOMPOSE), ids=list(BAD_DECOMPOSE))
def test_bad_decompose_values_exit_2_naming_the_field(tmp_path, case):
    old, new, message = BAD_DECOMPOSE[case]
    text = AUTO_TEXT.replace(old, new, 1)
    if case == "neither":
        text = text.split("[other]")[0]
    path = tmp_path / "auto.toml"
    path.write_text(text)
    result = runner.invoke(cli.app, ["decompose", str(path)])
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    lines = [x for x in result.output.splitlines() if x.startswith("error:")]
    assert lines and all(str(path) in x for x in lines)
    assert any(message in x for x in lines), result.output


def test_bad_options_exit_2_naming_the_option():
    result = runner.invoke(cli.app, ["compare-sequences", str(AUTO), "--strategy", "eager"])
    assert result.exit_code == 2 and "--strategy: must be conservative, postponed or both" in (
        result.output
    )
    result = runner.invoke(cli.app, ["decompose", str(AUTO), "--max-length", "1"])
    assert result.exit_code == 2 and "--max-length: no sequence of at most 1 stratum" in (
        result.output
    )


def test_models_describes_a_preset_by_name():
    result = runner.invoke(app, ["models", "one-arm"])
    assert result.exit_code == 0, result.output
    assert "one-arm preset model" in result.output and "q1, q2, q3, theta" in result.output
    assert "cannot read scenario file" not in result.output


@pytest.mark.parametrize("command", ["check", "models"])
@pytest.mark.parametrize(
    ("target", "why"),
    [
        ("one_arm", "not a preset (did you mean 'one-arm'? presets: one-arm, two-arm), a "
         "scenario file or a URDF file"),
        ("robots/nope.urdf", "no such file (a preset is named one-arm or two-arm)"),
        ("nope.toml", "no such file (a preset is named one-arm or two-arm)"),
    ],
)  # fmt: skip
def test_check_and_models_say_the_same_of_an_unknown_argument(command, target, why):
    """A misspelt preset gets its nearest name; a missing file is called missing (it was
    "not a preset or a scenario file", and a URDF was not named)."""
    result = runner.invoke(app, [command, target])
    assert result.exit_code == 2
    assert result.stderr.strip() == f"error: {target}: {why}"


def test_plan_json_names_the_record_but_result_json_does_not(tmp_path):
    result, _ = run(tmp_path, TASK_D, "--json", "--no-animation")
    assert result.exit_code == 0
    (run_dir,) = (tmp_path / "runs").iterdir()
    assert json.loads(result.stdout)["record"] == str(run_dir)
    assert "record" not in json.loads((run_dir / "result.json").read_text())


def test_show_of_a_failed_record_prints_its_failure_and_hint(tmp_path):
    text = TASK_D.replace("tolerance = 1e-3", "tolerance = 1e-12\nmax_iterations = 1\nrestarts = 0")
    result, _ = run(tmp_path, text, "--no-animation", "--quiet")
    assert result.exit_code == 1
    (run_dir,) = (tmp_path / "runs").iterdir()
    shown = runner.invoke(app, ["show", str(run_dir)])
    assert shown.exit_code == 0
    message = json.loads((run_dir / "result.json").read_text())["message"]
    assert f"failed: {message}" in shown.stdout and "try" in message


def test_flags_help_shows_no_bool_type():
    """No flag, --help included, shows a `<bool>` type in any command's help."""
    for command in ([], ["plan"], ["compare-sequences"], ["regress"], ["check"], ["runs"]):
        text = runner.invoke(app, [*command, "--help"], terminal_width=120).output
        assert "--help" in text and "<bool>" not in text, text


def test_runs_of_a_file_is_bad_input_naming_it(tmp_path):
    afile = tmp_path / "runs"
    afile.write_text("not a folder")
    result = CliRunner().invoke(app, ["runs", "--out", str(afile)])
    assert result.exit_code == 2
    assert f"--out {afile}: not a directory" in result.stderr
    given = CliRunner().invoke(app, ["runs", str(afile)])  # the directory as an argument
    assert given.exit_code == 2 and f"DIR {afile}: not a directory" in given.stderr
    empty = CliRunner().invoke(app, ["runs", ""])  # an unset shell variable, as --out ""
    assert empty.exit_code == 2 and "DIR: empty: give a directory" in empty.stderr
    both = CliRunner().invoke(app, ["runs", str(tmp_path), "--out", str(tmp_path / "x")])
    assert both.exit_code == 2 and "give the directory once" in both.stderr


def test_a_tilde_in_out_is_the_home_directory(tmp_path, monkeypatch):
    """`--out=~/runs` (the shell leaves `~` as it is after `=` and in quotes) made a folder
    named `~` in the current directory and printed `record: ~/runs/...` as if it were home."""
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(app, ["plan", str(ROOT / "scenarios" / "unicycle.toml"), "--out=~/runs"])
    assert result.exit_code == 0, result.output
    assert not (tmp_path / "~").exists()
    (record,) = (tmp_path / "home" / "runs").iterdir()
    assert f"record: {record}" in result.stdout.replace("\n", "")
    shutil.copy(ROOT / "scenarios" / "unicycle.toml", tmp_path / "home" / "u.toml")
    for command in (["models", "~/u.toml"], ["check", "~/u.toml"]):  # (NAME|FILE arguments)
        assert runner.invoke(app, command).exit_code == 0, command


def test_an_out_that_links_to_nothing_is_bad_input_naming_the_link(tmp_path):
    """plan and sweep said "--out runs: cannot write there (File exists)" of a dangling link."""
    (tmp_path / "runs").symlink_to(tmp_path / "gone")
    sweep = ROOT / "scenarios" / "sweeps" / "sim4_goal_map.toml"
    for command in (["plan", str(ROOT / "scenarios" / "unicycle.toml")], ["sweep", str(sweep)]):
        result = runner.invoke(app, [*command, "--out", str(tmp_path / "runs")])
        assert result.exit_code == 2, result.output
        gone = tmp_path / "gone"
        assert f"--out {tmp_path / 'runs'}: a link to {gone}, which does not exist" in result.stderr


def test_runs_takes_the_directory_as_an_argument_too(tmp_path):
    """`stratplan runs DIR` was refused ("unexpected extra argument"): only --out DIR was read."""
    result, _ = run(tmp_path, TASK_D, "--quiet")
    assert result.exit_code == 0, result.output
    (run_dir,) = (tmp_path / "runs").iterdir()
    by_argument = CliRunner().invoke(app, ["runs", str(tmp_path / "runs")])
    by_option = CliRunner().invoke(app, ["runs", "--out", str(tmp_path / "runs")])
    assert by_argument.exit_code == 0 and by_argument.stdout == by_option.stdout
    assert str(run_dir) in by_argument.stdout


def test_a_model_that_overflows_is_bad_input_not_an_uncontrollable_stratum(tmp_path):
    """A field that overflows at some sampled configuration makes its brackets inf/NaN: the
    check says so (exit 2, naming model.fields and the configuration as a sample), without
    numpy's warnings, instead of reporting a rank of 0 as 'not controllable' (exit 3)."""
    text = (ROOT / "scenarios" / "unicycle.toml").read_text()
    text = text.replace('v = ["cos(theta)"', 'v = ["exp(exp(exp(50*theta)))"')
    assert "exp(exp(exp" in text
    result, path = run(tmp_path, text)
    (line,) = _one_line_errors(result, path)
    assert "model.fields" in line and "not finite" in line and "a sampled configuration" in line
    assert "RuntimeWarning" not in result.output and "not controllable" not in result.output
    checked = runner.invoke(app, ["check", str(path)])
    assert checked.exit_code == 2 and "model.fields" in checked.output
    assert "RuntimeWarning" not in checked.output
    verdict = next(x for x in checked.output.splitlines() if x.startswith("verdict:"))
    assert "cannot be evaluated" in verdict and "controllable" not in verdict
    as_json = runner.invoke(app, ["check", str(path), "--json"])
    assert json.loads(as_json.stdout)["model_problems"]  # valid JSON: no NaN
    # auto mode (no legs: the strata's own ranks): the same line, not 'not controllable'
    auto = text[: text.index("[[legs]]")] + "[decompose]\nmax_length = 1\n"
    result, path = run(tmp_path, auto)
    (line,) = _one_line_errors(result, path)
    assert "model.fields" in line and "not finite" in line


def test_check_says_when_eq2_fails_but_no_leg_needs_it(tmp_path):
    """One S2 leg on the one-arm model: its strata together miss a direction (eq. 2), yet the
    leg spans what it steers; the verdict says the task does not need eq. 2 (a newcomer read
    'not stratified controllable' with exit 0 as a contradiction)."""
    path = tmp_path / "one_leg.toml"
    path.write_text(
        'name = "one_leg"\n[model]\nkind = "preset"\nname = "one-arm"\n'
        '[task]\nstart = [0, "pi/4", 0, 0]\ngoal = [0, "pi/4", 0, 1.5]\n'
        '[[legs]]\nstratum = "S2"\n'
    )
    result = runner.invoke(app, ["check", str(path), "--samples", "10"])
    assert result.exit_code == 0, result.output
    verdict = next(line for line in result.output.splitlines() if line.startswith("verdict:"))
    assert "not stratified controllable" in verdict
    assert "which this task's legs do not need" in verdict


def test_plan_in_a_log_says_what_it_is_doing(tmp_path, monkeypatch):
    """`plan` printed nothing in a log for a minute of constrained starts (a terminal shows
    a spinner naming the phase): now plain lines on stderr, here at once; --quiet none."""
    from stratcli.cli import progress

    monkeypatch.setattr(progress, "LOG_FIRST", 0.0)
    monkeypatch.setattr(progress, "LOG_EVERY", 0.0)
    scenario = ROOT / "scenarios" / "sim4_task_d.toml"
    result = runner.invoke(cli.app, ["plan", str(scenario), "--out", str(tmp_path / "r")])
    assert result.exit_code == 0, result.output
    assert "energy search: minimum energy from " in result.stderr
    assert "planning the legs one by one (Newton) (0 s)" in result.stderr
    quiet = runner.invoke(cli.app, ["plan", str(scenario), "--out", str(tmp_path / "q"), "-q"])
    assert quiet.exit_code == 0 and "energy search" not in quiet.stderr


def test_compare_sequences_in_a_log_says_it_is_alive(tmp_path, newton, monkeypatch):
    """Output that is no terminal (a CI log) got no progress at all: now plain lines on
    stderr (here at once: the log's first line is otherwise after 10 s); --quiet none."""
    from stratcli.cli import progress

    monkeypatch.setattr(progress, "LOG_FIRST", 0.0)
    monkeypatch.setattr(progress, "LOG_EVERY", 0.0)
    args = ["compare-sequences", str(newton), "--max-length", "2", "--jobs", "1"]
    result = runner.invoke(cli.app, [*args, "--out", str(tmp_path / "r")])
    assert result.exit_code == 0, result.output
    lines = [x for x in result.stderr.splitlines() if x.startswith("planning sequences: ")]
    assert lines and lines[-1].startswith("planning sequences: 6 of 6 (")
    quiet = runner.invoke(cli.app, [*args, "--out", str(tmp_path / "q"), "--quiet"])
    assert quiet.exit_code == 0 and "planning sequences" not in quiet.stderr


def test_show_of_a_time_scaled_auto_record_says_its_comparison_is_as_planned(tmp_path):
    """`plan --time-scale 2` in auto mode says its choice is 'as planned, before time scaling
    by 2'; `show` printed the comparison's energies under the scaled total without it."""
    text = (ROOT / "scenarios" / "sim4_auto.toml").read_text()
    (tmp_path / "auto.toml").write_text(text)
    task = load_scenario(tmp_path / "auto.toml")
    mine = task.with_changes({"planner.objective": "newton", "decompose.max_length": 2})
    from stratcli.tomlwrite import dumps

    (tmp_path / "auto.toml").write_text(dumps(mine.scenario.model_dump(exclude_none=True)))
    out = tmp_path / "runs"
    planned = runner.invoke(
        cli.app,
        [
            "plan",
            str(tmp_path / "auto.toml"),
            "--time-scale",
            "2",
            "--jobs",
            "1",
            "--out",
            str(out),
            "-q",
        ],
    )
    assert planned.exit_code == 0, planned.output
    (run_dir,) = out.iterdir()
    shown = " ".join(runner.invoke(cli.app, ["show", str(run_dir)]).output.split())
    assert "(all of them: comparison.json, as planned, before time scaling by 2)" in shown


CHAINED5 = """
name = "chained5"
[model]
kind = "custom"
states = ["x1", "x2", "x3", "x4", "x5"]
inputs = ["u1", "u2"]
[model.fields]
u1 = [1, 0, "x2", "x3", "x4"]
u2 = [0, 1, 0, 0, 0]
[[model.strata]]
name = "all"
active = ["u1", "u2"]
[task]
start = [0, 0, 0, 0, 0]
goal = [0, 0, 0, 0, 0.1]
[[legs]]
stratum = "all"
"""


def test_a_system_that_needs_degree_4_brackets_is_undecided_not_declared_uncontrollable(tmp_path):
    """A chained form of 5 states is controllable with degree-4 brackets; the check, whose
    brackets stop at degree 3, said "not stratified controllable" as a fact. It says up to
    which degree, that such a system is not decided, and how to plan it (which works)."""
    path = tmp_path / "chained5.toml"
    path.write_text(CHAINED5)
    checked = runner.invoke(cli.app, ["check", str(path)])
    assert checked.exit_code == 3
    (verdict,) = [line for line in checked.output.splitlines() if line.startswith("verdict:")]
    assert (
        "not stratified controllable (eq. 2, brackets up to degree 3: a system that needs"
        in verdict
    )
    assert "plan --no-check tries it" in verdict
    args = ["plan", str(path), "--no-check", "--objective", "newton", "--out", str(tmp_path / "r")]
    planned = runner.invoke(cli.app, [*args, "--quiet"])
    assert planned.exit_code == 0, planned.output


def test_a_leg_refused_for_a_coordinate_the_next_leg_locks_says_so(tmp_path):
    """Leg 2 (x only) was refused for steering z with the advice 'goal "*"', which its goal
    already had: leg 3 locks z, so leg 2 must end it where it stays. The line says that."""
    path = tmp_path / "pinned.toml"
    path.write_text(
        """
name = "pinned"
[model]
kind = "custom"
states = ["x", "y", "z"]
inputs = ["u1", "u2"]
parameters = { k = 1 }
[model.fields]
u1 = [1, 0, "-k*y"]
u2 = [0, 1, "k*x"]
[[model.strata]]
name = "lift"
active = ["u1", "u2"]
[[model.strata]]
name = "flat"
active = ["u1", "u2"]
locked = ["z"]
parameters = { k = 0 }
[[model.strata]]
name = "xonly"
active = ["u1"]
locked = ["y"]
[task]
start = [0, 0, 0]
goal = [1, 1, 1]
[[legs]]
stratum = "lift"
goal = [0, 0, 1]
[[legs]]
stratum = "xonly"
goal = [1, 0, "*"]
[[legs]]
stratum = "flat"
"""
    )
    result = runner.invoke(cli.app, ["check", str(path)])
    assert result.exit_code == 3
    assert 'goal "*"; not z, whatever its goal says: leg 3 locks it, so this leg ends it' in (
        " ".join(result.output.split())
    )


ONLY2 = """[[model.strata]]
name = "only2"
active = ["u2"]
locked = ["x1", "x3", "x4", "x5"]
"""


def test_check_all_strata_shows_the_strata_no_leg_uses(tmp_path):
    """`check FILE` showed only the strata the scenario's legs use: a stratum of the model
    that could not be planned on stayed hidden. --all-strata shows every one (and its
    verdict), the default the legs' strata, the legs checked either way."""
    path = tmp_path / "three.toml"
    path.write_text(CHAINED5.replace("[task]", ONLY2 + "[task]", 1))
    rows = {}
    for extra in ([], ["--all-strata"]):
        doc = json.loads(runner.invoke(app, ["check", str(path), "--json", *extra]).stdout)
        rows[bool(extra)] = [s["stratum"] for s in doc["strata"]]
        assert [leg["leg"] for leg in doc["legs"]] == [1]
    assert rows == {False: ["all"], True: ["all", "only2"]}


def test_a_rank_short_at_a_singularity_of_the_fields_says_so(tmp_path):
    """A car starting at phi = pi/2 (tan(phi) = 1.6e16) was refused as "span only 1 of the 4
    coordinates", as if brackets were missing; one field dwarfs the others there."""
    path = tmp_path / "car.toml"
    path.write_text(
        """
name = "car"
[model]
kind = "custom"
states = ["x", "y", "theta", "phi"]
inputs = ["v", "w"]
[model.fields]
v = ["cos(theta)", "sin(theta)", "tan(phi)", 0]
w = [0, 0, 0, 1]
[[model.strata]]
name = "drive"
active = ["v", "w"]
[task]
start = [0, 0, 0, "pi/2"]
goal = [0, 0.5, 0, 0]
[[legs]]
stratum = "drive"
"""
    )
    result = runner.invoke(cli.app, ["check", str(path)])
    assert result.exit_code == 3
    assert "its fields reach 1.6e+16 there: a singularity of the model" in " ".join(
        result.output.split()
    )
    fine = path.read_text().replace('start = [0, 0, 0, "pi/2"]', "start = [0, 0, 0, 0.3]")
    path.write_text(fine)
    assert runner.invoke(cli.app, ["check", str(path)]).exit_code == 0


def test_quiet_prints_no_notes_and_the_next_command_prints_its_own(tmp_path):
    """--quiet says "Print nothing but errors", but `plan --jobs 1 --quiet` of a scenario with
    legs still printed its note that --jobs is for auto mode. A command after it in the same
    process (a notebook's or a test's runner) prints its notes as before."""
    quiet, _ = run(tmp_path, TASK_D, "--jobs", "1", "--quiet")
    assert quiet.exit_code == 0 and quiet.stdout == "" and quiet.stderr == ""
    loud, _ = run(tmp_path, TASK_D, "--jobs", "1")
    assert loud.exit_code == 0 and "note: --jobs is for auto mode" in loud.stderr


def test_check_says_a_stratum_that_spans_at_the_samples_does_not_at_q():
    """arm3_reorient's S1: the table says "no" (rank 3 of 5 at its start) while a note said
    "third order spans there" of the 100 samples, read as a contradiction; it says not at q."""
    result = runner.invoke(
        app, ["check", str(ROOT / "scenarios" / "spatial" / "arm3_reorient.toml")]
    )
    line = next(x for x in result.stdout.splitlines() if x.startswith("note: S1: degree 2"))
    assert line.endswith("third order spans there, but not at q (rank 3 of 5 with third order)")


def test_animation_of_a_urdf_robot_says_it_draws_none(tmp_path):
    """`--animation` on a URDF robot wrote no motion.gif and said nothing (its help: "Also
    write motion.gif"); it says where that motion is instead."""
    scenario = ROOT / "scenarios" / "spatial" / "arm3_reorient.toml"
    result = runner.invoke(app, ["plan", str(scenario), "--out", str(tmp_path), "--animation"])
    assert result.exit_code == 0
    assert "note: --animation draws motion.gif of planar robots only" in result.stderr
    assert not list(tmp_path.glob("*/motion.gif"))


@pytest.mark.parametrize("command", ["models", "check"])
def test_models_and_check_of_a_fifo_refuse_it_instead_of_waiting(tmp_path, command):
    """`mkfifo f.toml; stratplan models f.toml` waited for a writer for good (peeking whether
    it was a URDF opened it); `plan` said "not a regular file", as both do now."""
    import os

    fifo = tmp_path / "f.toml"
    os.mkfifo(fifo)
    result = runner.invoke(app, [command, str(fifo)])
    assert result.exit_code == 2 and "not a regular file" in result.stderr


def test_quiet_says_where_a_failed_plans_record_is(tmp_path):
    """With --quiet a failed plan's one line did not say where its record went (the footer
    that does is not printed); it does, and without --quiet the footer alone says it."""
    failing = TASK_D.replace(
        "[planner]", '[planner]\nobjective = "newton"\nmax_iterations = 1\nrestarts = 0'
    )
    quiet, _ = run(tmp_path, failing, "--quiet")
    (record,) = (tmp_path / "runs").iterdir()
    assert quiet.exit_code == 1 and quiet.stdout == ""
    assert quiet.stderr.strip().endswith(f"(record: {record})")
    loud, _ = run(tmp_path, failing)
    assert loud.exit_code == 1 and "(record: " not in loud.stderr
