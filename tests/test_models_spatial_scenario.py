"""Scenarios with `[model] kind = "urdf"`: the path relative to the file, configurations by
joint name with `attitude` or `rpy`, one-line errors, and plans verified independently."""

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from stratcli.cli import app
from stratcli.errors import InputError
from stratcli.scenario import load_scenario, parse_scenario

ROOT = Path(__file__).resolve().parents[1]
SPATIAL = ROOT / "scenarios" / "spatial"

pin = pytest.importorskip("pinocchio")

from spatial_reintegrate import verify_spatial  # noqa: E402

from stratcli import so3  # noqa: E402
from stratcli.api import plan_run  # noqa: E402

TEXT = """
name = "t"
[model]
kind = "urdf"
path = "{path}"
[task]
start = {start}
goal = {goal}
[[legs]]
stratum = "S3"
"""


def _text(start="[0, 0, 0, 0, 0, 0]", goal='[0, 0, "*", 0.1, 0, 0]', path=None):
    return TEXT.format(path=path or (ROOT / "robots" / "arm3.urdf"), start=start, goal=goal)


def test_configuration_by_name_with_rpy_and_free_coordinates():
    start = '{ j1 = "10deg", j2 = 0, j3 = 0.5, rpy = [0.1, -0.2, 0.3] }'
    goal = '{ j1 = 0, j2 = 0, j3 = "*", attitude = [0.1, "*", 0] }'
    task = parse_scenario(_text(start, goal))
    assert task.system.states == ("j1", "j2", "j3", "rx", "ry", "rz")
    np.testing.assert_allclose(task.start[:3], [np.radians(10), 0, 0.5])
    np.testing.assert_allclose(so3.exp(task.start[3:]), so3.rpy_to_matrix([0.1, -0.2, 0.3]))
    assert np.isnan(task.goal[2]) and np.isnan(task.goal[4]) and task.goal[3] == 0.1


def test_an_omitted_attitude_is_the_identity():
    task = parse_scenario(_text("{ j1 = 0, j2 = 0, j3 = 0 }", '{ j1 = 0, j2 = 0, j3 = "*" }'))
    assert task.start[3:].tolist() == [0, 0, 0] and task.goal[3:].tolist() == [0, 0, 0]


def test_an_attitude_turning_by_more_than_pi_is_noted_with_the_rotation_reached(tmp_path):
    """A goal attitude [0, 0, 4] was planned to the same rotation as [0, 0, 4 - 2 pi], which
    result.json's `end` shows, silently: a script comparing `end` with `goal` saw 2 pi."""
    (tmp_path / "s.toml").write_text(_text(goal='[0, 0, "*", 0, 0, 4.0]'))
    outcome = plan_run(load_scenario(tmp_path / "s.toml"), check=False)
    short = 4.0 - 2 * np.pi
    note = (
        f"task.goal's attitude [0, 0, 4] turns by more than pi: it is the rotation "
        f"[0, 0, {short:.4g}], which the plan reaches (result.json's end shows that one)"
    )
    assert note in outcome.result.notes
    # decompose listed the goal's rz = 4 without a word: it says so too
    import stratcli

    auto = load_scenario(tmp_path / "s.toml").with_changes({"legs": None, "decompose": {}})
    listed = stratcli.decompose(auto)
    assert note in listed.notes and listed.document["notes"] == [note]
    end = outcome.document["attitude"]["end"]["rotation_vector"]
    assert outcome.result.ok and end[2] == pytest.approx(short, abs=1e-3)
    (tmp_path / "s.toml").write_text(_text(goal='[0, 0, "*", 0, 0, 3.0]'))  # within pi: none
    quiet = plan_run(load_scenario(tmp_path / "s.toml"), check=False).result
    assert not any("turns by more than pi" in n for n in quiet.notes)


def test_an_attitude_component_past_a_full_turn_is_noted_as_degrees_maybe(tmp_path):
    """`attitude = [0, 0, 45]` (45° meant) was noted only as the rotation [0, 0, 1.018]."""
    from stratcli.models.spatial_scenario import long_attitudes

    (tmp_path / "s.toml").write_text(_text(goal='[0, 0, "*", 0, 0, 45]'))
    (note,) = long_attitudes(load_scenario(tmp_path / "s.toml"))
    assert note.endswith('; if degrees were meant, write ["0deg", "0deg", "45deg"]')
    (tmp_path / "s.toml").write_text(_text(goal='[0, 0, "*", 0, 0, 4.0]'))  # within a turn
    (note,) = long_attitudes(load_scenario(tmp_path / "s.toml"))
    assert "degrees" not in note


@pytest.mark.parametrize("attitude", ['["*", "*", 4.0]', '[2.5, "*", 2.5]'])
def test_a_partly_free_attitude_longer_than_pi_is_refused(attitude):
    """Its fixed components can never be reached (log(R) is never longer than pi): it
    planned for 35 s and failed, advising more harmonics."""
    with pytest.raises(InputError) as caught:
        parse_scenario(_text(goal=f'{{ j1 = 0, j2 = 0, j3 = "*", attitude = {attitude} }}'))
    (problem,) = caught.value.problems
    assert problem.path == "task.goal"
    assert "cannot be reached: it is compared component by component" in problem.message
    parse_scenario(_text(goal='{ j1 = 0, j2 = 0, j3 = "*", attitude = ["*", "*", 3.0] }'))


def test_a_urdf_scenario_given_as_a_dict_changes_its_goal_by_joint_name():
    """A dict was recorded after its configurations by name became lists, so a change by
    name replaced the whole goal: `task.goal: missing joints j2, j3` (from a file: fine)."""
    import tomllib

    raw = tomllib.loads((SPATIAL / "arm3_auto.toml").read_text())
    raw["model"]["path"] = str(ROOT / "robots" / "arm3.urdf")
    task = load_scenario(raw)
    assert "[task.goal]" in task.text  # recorded as given: by name
    nested = task.with_changes({"task": {"goal": {"j1": 0.2}}})
    dotted = task.with_changes({"task.goal.j1": 0.2})
    assert nested.goal[0] == dotted.goal[0] == 0.2
    np.testing.assert_array_equal(nested.goal[1:], task.goal[1:])
    assert task.with_changes({"goal.rz": 0.1}).goal[5] == pytest.approx(0.1)
    whole = task.with_changes({"goal.attitude": [0, 0, 0.1]}).goal  # (was "unknown coordinate")
    np.testing.assert_allclose(whole[3:], [0, 0, 0.1])
    assert np.isnan(task.with_changes({"goal.rz": "*"}).goal[5])
    # a nested rpy replaces the file's attitude (the merge kept both: "give either attitude
    # or rpy, not both", of a key the user had not written), and an attitude an rpy
    turned = task.with_changes({"task": {"goal": {"rpy": [0, 0, "10deg"]}}})
    np.testing.assert_allclose(turned.goal[3:], [0, 0, np.radians(10)])
    np.testing.assert_array_equal(turned.goal[:3], task.goal[:3])
    back = turned.with_changes({"task": {"goal": {"attitude": [0, 0, 0.1]}}})
    np.testing.assert_allclose(back.goal[3:], [0, 0, 0.1])


def test_path_is_relative_to_the_scenario_file(tmp_path):
    (tmp_path / "robots").mkdir()
    (tmp_path / "robots" / "r.urdf").write_text((ROOT / "robots" / "arm3.urdf").read_text())
    (tmp_path / "s.toml").write_text(_text(path="robots/r.urdf"))
    task = load_scenario(tmp_path / "s.toml")
    assert Path(task.scenario.model.path) == (tmp_path / "robots" / "r.urdf").resolve()


def test_with_changes_finds_a_relative_urdf_path_after_a_change_of_directory(tmp_path, monkeypatch):
    """A relative path is relative to the file's directory (or, in text, to the working
    directory) as it was when the scenario was loaded: a notebook's os.chdir in between
    must not send `with_changes` looking for the URDF file elsewhere."""
    (tmp_path / "robots").mkdir()
    (tmp_path / "robots" / "r.urdf").write_text((ROOT / "robots" / "arm3.urdf").read_text())
    (tmp_path / "s.toml").write_text(_text(path="robots/r.urdf"))
    monkeypatch.chdir(tmp_path)
    loaded = [load_scenario("s.toml"), load_scenario(_text(path="robots/r.urdf"))]
    monkeypatch.chdir(ROOT)
    for task in loaded:
        changed = task.with_changes({"planner": {"tolerance": 1e-5}})
        assert Path(changed.scenario.model.path) == (tmp_path / "robots" / "r.urdf").resolve()


@pytest.mark.parametrize(
    "start, words",
    [
        ("{ j1 = 0, j2 = 0, jx = 0, j3 = 0 }", "task.start: unknown names jx"),
        ("{ j1 = 0, j2 = 0 }", "task.start: missing joints j3"),
        ("{ j1 = 0, j2 = 0, j3 = 0, rpy = [0, 0] }", "task.start.rpy: needs 3 angles"),
        ('{ j1 = 0, j2 = 0, j3 = 0, rpy = [0, "*", 0] }', "task.start.rpy: either all three"),
    ],
)
def test_bad_configurations_name_the_field(start, words):
    with pytest.raises(InputError) as err:
        parse_scenario(_text(start=start))
    assert words in str(err.value)


def test_a_misspelt_joint_is_one_line_that_names_the_joint_meant():
    """`j22` for j2 gave two lines: the unknown name, and j2 "missing" as its knock-on."""
    with pytest.raises(InputError) as err:
        parse_scenario(_text(start="{ j1 = 0, j22 = 0, j3 = 0 }"))
    (problem,) = err.value.problems
    assert problem.path == "task.start"
    assert problem.message.startswith("unknown names j22 (did you mean j2?) (allowed: j1, j2")


def test_unsupported_joint_and_missing_pinocchio_exit_2(tmp_path, monkeypatch):
    text = (
        (ROOT / "robots" / "arm3.urdf")
        .read_text()
        .replace('name="j2" type="revolute"', 'name="j2" type="prismatic"')
    )
    (tmp_path / "r.urdf").write_text(text)
    (tmp_path / "s.toml").write_text(_text(path="r.urdf"))
    runner = CliRunner()
    result = runner.invoke(app, ["plan", str(tmp_path / "s.toml")])
    assert result.exit_code == 2 and "joint 'j2' is prismatic" in result.output
    assert "Traceback" not in result.output

    from stratcli.models import spatial

    def missing():
        raise InputError("model.kind: URDF models need Pinocchio; " + spatial.INSTALL)

    monkeypatch.setattr(spatial, "load_pinocchio", missing)
    (tmp_path / "ok.toml").write_text(_text())
    result = runner.invoke(app, ["plan", str(tmp_path / "ok.toml")])
    assert result.exit_code == 2 and "pip install 'stratplan[spatial]'" in result.output


def _planned(name, objective="newton", **settings):
    task = load_scenario(SPATIAL / f"{name}.toml")
    task = task.with_changes({"planner": {"objective": objective, **settings}})
    return task, plan_run(task, check=False)


def test_reorientation_by_joint_cycles_verifies_independently():
    task, out = _planned("arm3_reorient")
    doc = out.document
    verify_spatial(doc, task.system.spatial)
    start, end = np.array(doc["start"]), np.array(doc["legs"][-1]["end"])
    np.testing.assert_allclose(end[:3], start[:3], atol=1e-6)  # the joints come back
    assert np.linalg.norm(end[3:]) > 0.3  # the base turned
    att = doc["attitude"]
    assert att["end"]["quaternion"][0] > 0 and len(att["end"]["rotation_vector"]) == 3
    assert att["legs"][0]["goal_error"] <= doc["tolerance"]


@pytest.mark.parametrize("mode", ["none", "l-C0", "l-C1", "lr-C0", "lr-C1"])
def test_every_continuity_mode_with_soft_start_and_full_stop(mode):
    task, out = _planned("arm3_reorient", continuity=mode, soft_start=True, full_stop=True)
    doc = out.document
    verify_spatial(doc, task.system.spatial)
    first, last = doc["legs"][0]["pieces"][0], doc["legs"][-1]["pieces"][-1]
    from reintegrate import controls

    u0 = controls(first, doc["inputs"], 0.0)
    du0 = controls(first, doc["inputs"], 0.0, derivative=True)
    uT = controls(last, doc["inputs"], last["duration"])
    duT = controls(last, doc["inputs"], last["duration"], derivative=True)
    assert max(np.abs(u0).max(), np.abs(du0).max(), np.abs(uT).max(), np.abs(duT).max()) < 1e-9


def test_a_tolerance_below_the_maps_own_accuracy_is_met_on_an_independent_integration():
    """At tolerance 1e-10 a plan reported its legs within 6e-14 of their goals, measured on
    the Magnus map, 3e-10 off the true attitude: the map now runs to a tenth of the
    tolerance, and the true ends (scipy, rtol 1e-12) are within it."""
    from spatial_reintegrate import reintegrate_spatial

    task, out = _planned("arm3_reorient", tolerance=1e-10)
    doc = out.document
    assert doc["status"] == "ok", doc["message"]
    for leg, again in zip(doc["legs"], reintegrate_spatial(doc, task.system.spatial), strict=True):
        goal = np.array([np.nan if g is None else g for g in leg["goal"]])[3:]
        phi = so3.log(again["R"])
        if np.all(np.isfinite(goal)):
            error = np.linalg.norm(so3.log(so3.exp(goal).T @ again["R"]))
        else:  # the given components of a partly free attitude
            error = np.linalg.norm((phi - goal)[np.isfinite(goal)])
        assert error <= 1e-10, error


def test_three_leg_task_on_the_seven_joint_arm_verifies_independently():
    task, out = _planned("arm7_three_legs")
    verify_spatial(out.document, task.system.spatial)
    assert out.document["attitude"]["legs"][0]["goal"] is None  # left free on leg 1


@pytest.mark.slow
def test_the_seven_joint_arm_within_its_urdf_limits_verifies_independently():
    """arm7_within_limits: arm7_three_legs with the URDF's joint limits (an empty
    [constraints] table), whose leg 2 left joint_4's ±2.09 rad; planned inside them
    (the energy objective, the constrained search) and re-integrated independently."""
    from test_urdf_limits import _joint_extremes

    task, out = _planned("arm7_within_limits", objective="energy")
    doc = out.document
    verify_spatial(doc, task.system.spatial)
    robot = task.system.spatial
    for j in range(robot.n_joints):
        low, high = _joint_extremes(doc, j)
        assert robot.lower[j] - 1e-6 <= low and high <= robot.upper[j] + 1e-6, j
    free = _planned("arm7_three_legs", objective="energy")[1].document
    assert _joint_extremes(free, 3)[0] < robot.lower[3]  # without the table it left them
    assert doc["total_energy"] >= free["total_energy"] * (1 - 1e-9)


@pytest.mark.slow
def test_energy_objective_lowers_the_energy_and_still_verifies():
    task, out = _planned("arm3_reorient", objective="energy")
    doc = out.document
    verify_spatial(doc, task.system.spatial)
    assert doc["total_energy"] <= doc["optimisation"]["newton_energy"]
    # (its record named the planar legs' method, an exact Hessian, which URDF legs have not)
    assert doc["optimisation"]["method"] == (
        "feasible SQP, the goals' curvature by symmetric-rank-one updates"
    )


def test_models_lists_joints_limits_and_strata():
    result = CliRunner().invoke(app, ["models", str(SPATIAL / "arm7_three_legs.toml")])
    assert result.exit_code == 0, result.output
    out = result.output
    assert "joint_1 [-2.97, 2.97]" in out and "rotation vector" in out
    assert "S12" in out and "magnus" in out  # pair locks from four joints on
    # the URDF's velocity limits as a line to copy (the README says to copy them to
    # max_rate; a new user found them nowhere), exactly as the URDF has them
    import re

    urdf = (ROOT / "robots" / "bus_arm7.urdf").read_text()
    speeds = [float(v) for v in re.findall(r'velocity="([^"]+)"', urdf)]
    line = " ".join(out.split())  # (the console wraps)
    assert f"max_rate = [{', '.join(f'{v:g}' for v in speeds)}] (rad/s)" in line


@pytest.mark.slow
def test_regress_covers_the_spatial_scenarios():
    """Against DIR/baseline.json by default (it was scenarios/baseline.json whatever DIR)."""
    result = CliRunner().invoke(app, ["regress", str(SPATIAL)])
    assert result.exit_code == 0, result.output
    assert "all 4 scenarios match" in result.output


def test_lie_legs_are_rejected_on_urdf_models():
    text = _text() + 'method = "lie"\n'
    with pytest.raises(InputError, match=r"legs\[0\]\.method: Lie-algebraic legs are not"):
        parse_scenario(text)


def test_the_evaluator_asked_is_the_one_that_runs():
    """`models` shows "magnus" on URDF models: it is accepted there and planned with; a
    "quadrature" request is refused rather than silently replaced, "magnus" elsewhere too."""
    asked = _text().replace("[[legs]]", '[planner]\nevaluator = "{}"\n[[legs]]')
    task = parse_scenario(asked.format("magnus"))
    out = plan_run(task, check=False)
    assert [leg["evaluator"] for leg in out.document["legs"]] == ["magnus"]
    with pytest.raises(InputError) as err:
        parse_scenario(asked.format("quadrature"))
    assert str(err.value) == (
        "<scenario>: planner.evaluator: a URDF model has no quadrature path: its attitude is "
        "integrated on SO(3) by the Magnus method; use 'auto' or 'magnus' (or 'ode', much slower)"
    )
    preset = (ROOT / "scenarios" / "sim4_task_d.toml").read_text()
    with pytest.raises(
        InputError, match=r"^<scenario>: planner\.evaluator: .magnus. is the evaluator of URDF"
    ):
        parse_scenario(preset.replace("[planner]", '[planner]\nevaluator = "magnus"'))


def test_auto_mode_ranks_spatial_sequences_and_the_best_verifies():
    from stratcli.api import plan_auto

    outcome = plan_auto(SPATIAL / "arm3_auto.toml", jobs=1)
    assert outcome.ok
    best = outcome.best
    verify_spatial(best.document, best.task.system.spatial)
    goal = np.array(best.document["goal"])
    end = np.array(best.document["end"])
    assert np.linalg.norm(so3.log(so3.exp(goal[3:]).T @ so3.exp(end[3:]))) <= 1e-6


def test_plan_command_prints_the_audit_per_leg(tmp_path):
    path = SPATIAL / "arm7_three_legs.toml"
    result = CliRunner().invoke(app, ["plan", str(path), "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "leg 3 on SO(3): attitude error" in result.output
    assert "leg 1 on SO(3): attitude error (free)" in result.output  # attitude = "*"
    (run,) = tmp_path.iterdir()
    assert {"run.mcap", "stroboscope.png", "result.json"} <= {p.name for p in run.iterdir()}


def test_a_partly_free_attitude_has_the_error_of_its_given_components():
    """A partly free goal attitude had no error in result.json (null) nor on the SO(3) line,
    where the leg table showed one: the planner compares its given components."""
    from stratcli.spatialdoc import group_error

    nan = np.nan
    assert group_error([nan, 0.2, nan], [0.3, 0.2 + 3e-9, -0.1]) == pytest.approx(3e-9)
    assert group_error([0.1, nan, 0.0], [0.1 + 3e-4, 1.0, 4e-4]) == pytest.approx(5e-4)
    assert group_error([nan, nan, nan], [0.3, 0.2, -0.1]) is None
    task, out = _planned("arm3_reorient")  # its leg 2: ["*", 0.174..., "*"]
    leg = out.document["attitude"]["legs"][1]
    assert leg["goal"] is None and 0 <= leg["goal_error"] <= task.settings.tolerance


def test_a_pickled_urdf_plan_keeps_its_robot_when_the_file_changes(tmp_path):
    """Unpickled in another process, a URDF plan was rebuilt from the file its [model] table
    names: after the URDF's base mass changed, `sample()` gave another motion, still
    SUCCESS (and a deleted file a traceback). It pickles with its URDF text now."""
    import pickle
    import subprocess
    import sys
    import tomllib

    from stratcli import plan

    urdf = tmp_path / "arm.urdf"
    urdf.write_text((ROOT / "robots" / "arm3.urdf").read_text())
    raw = tomllib.loads((ROOT / "scenarios" / "spatial" / "arm3_reorient.toml").read_text())
    raw["model"]["path"] = str(urdf)
    planned = plan(raw, check=False)
    (tmp_path / "plan.pkl").write_bytes(pickle.dumps(planned))
    text = urdf.read_text()
    assert '<mass value="10' in text
    urdf.write_text(text.replace('<mass value="10', '<mass value="3', 1))  # another robot
    code = (
        "import pickle, sys; p = pickle.load(open(sys.argv[1], 'rb')); "
        "print(repr(p.sample(50).q[-1].tolist()))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path / "plan.pkl")],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    again = np.array(eval(out.stdout))
    np.testing.assert_allclose(again, planned.sample(50).q[-1], rtol=0, atol=1e-12)


def test_a_urdf_plans_limits_say_which_are_the_tables_and_which_the_urdfs():
    """`joint_limits = { j2 = [...] }` printed "limits: joints within their own limits", and
    a start past the URDF's limit did not say the limit was the URDF's."""
    from stratcli.cli.render_limits import limits_asked

    legs = [{"joint_limit": 0.1}]
    table = {"spec": {"joint_limits": {"j2": [-0.02, 0.02]}}, "legs": legs}
    assert limits_asked(table, urdf=True) == (
        "limits: j2 within [-0.02, 0.02] rad (the table), the other joints within the URDF's"
    )
    assert limits_asked({"spec": {"self_collision": False}, "legs": legs}, urdf=True) == (
        "limits: joints within the URDF's limits"
    )
    rates = {"spec": {"self_collision": False, "max_rate": [1, 1.5, 1]}, "legs": legs}
    assert limits_asked(rates, urdf=True) == (  # ("rate within its per-joint limits": whose?)
        "limits: joints within the URDF's limits; rate at most 1, 1.5, 1 rad/s, input by "
        "input (the table's)"
    )
    import tomllib

    raw = tomllib.loads((ROOT / "scenarios" / "spatial" / "arm3_reorient.toml").read_text())
    raw["model"]["path"] = str(ROOT / "robots" / "arm3.urdf")
    raw["task"]["start"]["j3"] = 2.7  # the URDF limits j3 to [-2.5, 2.5]
    raw["constraints"] = {}
    outside = r"j3 = 2\.7 is outside its limits \[-2\.5, 2\.5\] \(the URDF's joint limits\)"
    with pytest.raises(InputError, match=outside):
        load_scenario(raw)
    raw["constraints"] = {"joint_limits": {"j3": [-2.0, 2.0]}}  # the table's: it says so
    with pytest.raises(InputError, match=r"j3 = 2\.7 is outside its limits \[-2, 2\] \(constr"):
        load_scenario(raw)
