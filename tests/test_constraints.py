"""The [constraints] table: validation, rate limits met by time scaling, margins verified on
an independent re-integration, and plans that violate a limit failed with their record."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest
from reintegrate import controls, verify
from typer.testing import CliRunner

from stratcli import load_scenario, plan
from stratcli.api import plan_run
from stratcli.cli import app
from stratcli.errors import InputError
from stratcli.models.geometry import world_geometry

ROOT = Path(__file__).resolve().parents[1]
TASK_D = ROOT / "scenarios" / "sim4_task_d.toml"
runner = CliRunner()


def _task_d(**constraints) -> dict:
    raw = tomllib.loads(TASK_D.read_text())
    raw["planner"]["objective"] = "newton"  # fast; constraints do not depend on it
    raw["constraints"] = constraints
    return raw


def _problems(raw: dict) -> list[str]:
    with pytest.raises(InputError) as info:
        load_scenario(raw)
    return [f"{p.path}: {p.message}" for p in info.value.problems]


@pytest.mark.parametrize(
    ("constraints", "field"),
    [
        ({"joint_limits": [2.0, -2.0]}, "constraints.joint_limits: lower 2"),
        ({"joint_limits": [[-1, 1], [-1, 1]]}, "constraints.joint_limits"),
        ({"joint_limits": {"q9": [-1, 1]}}, "constraints.joint_limits.q9"),
        ({"max_rate": -1.0}, "constraints.max_rate"),
        ({"max_rate": [1.0, 2.0]}, "constraints.max_rate"),
        ({"self_collision": "yes"}, "constraints.self_collision"),
        ({"clearance": float("nan")}, "constraints.clearance"),
        ({"obstacles": [{"shape": "circle", "centre": [0, 1]}]}, "constraints.obstacles"),
        ({"speed": 1.0}, "constraints.speed"),
        ({"joint_limits": []}, "constraints.joint_limits: empty"),  # was a ValueError
        (  # an overflow in the clearances, and a numerical failure, before
            {"obstacles": [{"shape": "circle", "centre": [1e160, 1.3], "radius": 0.1}]},
            "constraints.obstacles[0].centre[0]: must be at most 1e+06",
        ),
        (
            {"obstacles": [{"shape": "box", "centre": [2, 0], "size": [1, 1], "rotation": 1e300}]},
            "constraints.obstacles[0].rotation",
        ),
        ({"clearance": 0.05}, "constraints.clearance: applies to self_collision = true and"),
        ({"link_radius": 0.1}, "constraints.link_radius: applies to self_collision = true and"),
    ],
)
def test_bad_constraints_name_their_field(constraints, field):
    problems = _problems(_task_d(**constraints))
    assert any(p.startswith(field) for p in problems), problems


def test_the_default_sizes_as_resolved_json_writes_them_load():
    # resolved.json fills every default in: a rate-limited plan's table holds link_radius 0.05
    # and clearance 0 beside self_collision = false, and must plan again as it is
    spec = {"max_rate": 1.0, "self_collision": False, "clearance": 0.0, "link_radius": 0.05}
    assert load_scenario(_task_d(**spec)).constraints.link_radius == 0.05


@pytest.mark.parametrize(
    ("limits", "line"),
    [  # one pair for every joint is said once, not once per joint
        ([2.0, -2.0], "constraints.joint_limits: lower 2 must be below upper -2"),
        ([[-3, 3], [2, 1], [-3, 3]], "constraints.joint_limits[1]: lower 2 must be below upper 1"),
        (
            {"q1": [-3, 3], "q2": [2, 1]},
            "constraints.joint_limits.q2: lower 2 must be below upper 1",
        ),
    ],
)
def test_a_reversed_joint_limit_is_one_line_named_as_written(limits, line):
    problems = [p for p in _problems(_task_d(joint_limits=limits)) if "must be below" in p]
    assert problems == [line]


def test_a_start_outside_the_joint_limits_is_bad_input():
    # Sim 4 D starts at q2 = pi/4 and its via has q1 = -pi/3
    problems = _problems(_task_d(joint_limits={"q2": [-0.5, 0.5], "q1": [-0.5, 0.5]}))
    assert any(p.startswith("task.start: q2 = 0.7854 is outside") for p in problems), problems
    assert any(p.startswith("legs[0].goal: q1 = -1.047") for p in problems), problems


def test_a_start_in_collision_names_the_bodies_and_the_obstacle():
    obstacles = [
        {"shape": "box", "centre": [3.0, 3.0], "size": [0.2, 0.2]},
        {"shape": "circle", "centre": [1.0, 0.0], "radius": 0.3},
    ]
    (problem,) = _problems(_task_d(obstacles=obstacles))
    assert problem.startswith("task.start: the robot touches an obstacle here: link 2 and ")
    assert "obstacles[1] (a circle) are overlapping by 0.3" in problem  # not "0.3 into"
    assert problem.endswith("(clearance 0, link radius 0.05); move the obstacle or change this "
                            "configuration")  # fmt: skip
    raw = _task_d(self_collision=True, clearance=0.05)
    raw["task"]["start"] = [0.0, 2.9, 2.9, 0.0]  # the arm folded back onto itself
    (problem,) = _problems(raw)
    assert problem.startswith("task.start: the robot collides with itself here: links 1 and 3")
    assert problem.endswith("; change this configuration")  # they overlap: no clearance helps
    raw["task"]["start"] = [0.0, 0.7854, 0.0, 0.0]
    raw["constraints"]["obstacles"] = [{"shape": "circle", "centre": [0.5, 0.08], "radius": 0.1}]
    (problem,) = [p for p in _problems(raw) if p.startswith("task.start")]  # nearer than the
    # clearance but apart: lowering it helps
    assert problem.startswith(
        "task.start: the robot comes within the clearance of an obstacle here: link 1 and "
        "obstacles[0] (a circle) are 0.0388 apart"
    )
    assert problem.endswith("; move the obstacle or change this configuration or lower "
                            "constraints.clearance")  # fmt: skip


def test_the_cli_reports_bad_constraints_with_exit_2(tmp_path):
    text = TASK_D.read_text() + '\n[constraints]\nmax_rate = "fast"\n'
    path = tmp_path / "bad.toml"
    path.write_text(text)
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path / "runs")])
    assert result.exit_code == 2, result.output
    assert "constraints.max_rate" in result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "runs").exists() or not any((tmp_path / "runs").iterdir())


@pytest.mark.parametrize(("key", "value"), [("max_rate", 1e-9), ("max_acceleration", 1e-15)])
def test_a_limit_no_slowing_down_can_meet_is_one_line_exit_2(tmp_path, key, value):
    text = TASK_D.read_text().replace("[planner]", "[planner]\nsoft_start = true\nfull_stop = true")
    text += f"\n[constraints]\n{key} = {value}\n"
    path = tmp_path / "tiny.toml"
    path.write_text(text)
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path / "runs")])
    assert result.exit_code == 2, result.output
    (line,) = result.output.strip().splitlines()
    assert line.startswith(f"error: {path}: constraints.{key}: meeting the "), line
    assert "x slower, more than the" in line


@pytest.mark.parametrize(
    ("planner", "missing"),
    [
        ({}, "set planner.soft_start = true and planner.full_stop = true;"),
        ({"soft_start": True}, "set planner.full_stop = true;"),
        (
            {"soft_start": True, "full_stop": True, "continuity": "l-C1"},
            'set planner.continuity = "lr-C1" (or "lr-C0");',
        ),
    ],
)
def test_an_acceleration_limit_needs_controls_that_never_jump(planner, missing):
    raw = _task_d(max_acceleration=1.0)
    raw["planner"].update(planner)
    (problem,) = _problems(raw)
    assert problem.startswith("constraints.max_acceleration: holds only if the controls never")
    assert missing in problem
    raw["planner"].update(soft_start=True, full_stop=True, continuity="lr-C0")
    assert load_scenario(raw).constraints.max_acceleration is not None


def test_the_terminal_shows_each_legs_smallest_margins(tmp_path):
    text = TASK_D.read_text() + "\n[constraints]\njoint_limits = [-3.0, 3.0]\nmax_rate = 0.8\n"
    path = tmp_path / "limited.toml"
    path.write_text(text)
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path), "--no-animation"])
    assert result.exit_code == 0, result.output
    (run,) = [p for p in tmp_path.iterdir() if p.is_dir()]
    legs = json.loads((run / "result.json").read_text())["constraints"]["legs"]
    (line,) = [x for x in result.output.splitlines() if x.startswith("smallest margins")]
    for i, m in enumerate(legs):
        assert f"leg {i + 1}: joints {m['joint_limit']:.3g} rad, rate {m['rate']:.3g} rad/s" in line
    assert "clearances beyond" not in line  # no clearance measured: none named
    assert "limits: joints within [-3, 3] rad; rate at most 0.8 rad/s" in result.output


def test_an_empty_constraints_table_says_it_sets_no_limit(tmp_path):
    """It printed a blank line where the limits go, and margins of 'none limited'."""
    path = tmp_path / "empty.toml"
    path.write_text(TASK_D.read_text() + "\n[constraints]\n")
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path), "--no-animation"])
    assert result.exit_code == 0, result.output
    assert "limits: none (the [constraints] table sets none)" in result.output.splitlines()
    assert "smallest margins" not in result.output and "\n\n" not in result.output


def test_the_margins_line_says_clearances_are_beyond_the_clearance_asked(tmp_path):
    """A self-clearance margin of 0.02 means 0.02 beyond the clearance, not bodies 0.02
    apart: the line says so, with the clearance the table asked for."""
    text = TASK_D.read_text() + "\n[constraints]\nself_collision = true\nclearance = 0.01\n"
    path = tmp_path / "clear.toml"
    path.write_text(text)
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path), "--no-animation"])
    assert result.exit_code in (0, 1), result.output
    (line,) = [x for x in result.output.splitlines() if x.startswith("smallest margins")]
    assert line.startswith(
        "smallest margins to the limits (2000 re-integrated samples a leg; clearances beyond "
        "the 0.01 asked): leg 1: self-clearance "
    )
    assert "limits: clearance 0.01 from itself (links as capsules of radius 0.05)" in result.output


def test_rate_limits_by_name_limit_the_inputs_named_and_no_other(tmp_path):
    """`max_rate = { q2 = 0.5 }` was refused ("must be a number or a valid list"): a motor
    list names its joints. By a joint's or an input's name; the others have no limit, the
    plan is slowed until the named one holds, and records and `show` say which."""
    from stratcli import write_record

    raw = _task_d(max_rate={"q2": 0.5, "u3": 2.0})
    task = load_scenario(raw)
    assert task.constraints.max_rate.tolist() == [np.inf, 0.5, 2.0]
    outcome = plan_run(task, check=False)
    assert outcome.result.ok, outcome.result.message
    doc = outcome.document
    u = np.concatenate(
        [
            [
                controls(leg["pieces"][0], doc["inputs"], s)
                for s in np.linspace(0, leg["duration"], 4001)
            ]
            for leg in doc["legs"]
        ]
    )
    assert np.abs(u[:, 1]).max() <= 0.5 * (1 + 1e-6) and np.abs(u[:, 2]).max() <= 2.0 * (1 + 1e-6)
    assert np.abs(u[:, 1]).max() == pytest.approx(0.5, rel=1e-4)  # slowed to it, no more
    assert outcome.result.constraints.duration_set_by == "the rate limit of u2 (0.5 rad/s)"
    assert all(np.isfinite(m.rate) for m in outcome.result.constraints.legs)
    run = write_record(tmp_path, outcome)
    shown = runner.invoke(app, ["show", str(run)]).output
    assert "rate at most q2 0.5, u3 2 rad/s (the table's; others unlimited)" in shown
    assert _problems(_task_d(max_rate={"q22": 1.0})) == [
        "constraints.max_rate.q22: not an input or joint (did you mean 'q2'? q1, q2, q3, u1, "
        "u2, u3)"
    ]
    assert _problems(_task_d(max_rate={})) == [
        "constraints.max_rate: empty: name at least one input or joint"
    ]
    # one input named twice (a joint and the input that drives it): the last won, silently
    assert _problems(_task_d(max_rate={"q2": 0.5, "u2": 1.0})) == [
        "constraints.max_rate: q2 and u2 name the same input (u2): give one limit"
    ]
    # a bad value in the table is one line, the table's own (not also "expected a number")
    assert _problems(_task_d(max_rate={"q2": [1, 2]})) == [
        "constraints.max_rate.q2: expected a number or an expression such as 'pi/3' (got [1, 2])"
    ]


def test_rate_and_acceleration_limits_are_met_exactly_by_time_scaling():
    rest = {"soft_start": True, "full_stop": True}  # an acceleration limit needs both
    free_raw = _task_d()
    free_raw["planner"].update(rest)
    free = plan(free_raw)
    raw = _task_d(max_rate=0.8, max_acceleration=[3.0, 3.0, 3.0])
    raw["planner"].update(rest)
    task = load_scenario(raw)
    outcome = plan_run(task, check=False)
    limited = outcome.result
    assert limited.ok, limited.message
    report = limited.constraints
    assert report.duration_set_by.startswith("the ")
    assert limited.duration > free.duration
    # energy × duration is invariant under time scaling
    assert limited.total_energy * limited.duration == pytest.approx(
        free.total_energy * free.duration, rel=1e-9
    )
    # independently: the controls rebuilt from result.json, on a denser grid than the margins
    doc = outcome.document
    for leg in doc["legs"]:
        t = np.linspace(0.0, leg["duration"], 20001)
        (piece,) = leg["pieces"]
        u = np.array([controls(piece, doc["inputs"], s) for s in t])
        du = np.array([controls(piece, doc["inputs"], s, derivative=True) for s in t])
        assert np.abs(u).max() <= 0.8 * (1 + 1e-6)
        assert np.abs(du).max() <= 3.0 * (1 + 1e-6)
    # from rest and to rest: no jump hides an unbounded acceleration at either end
    first, last = doc["legs"][0]["pieces"][0], doc["legs"][-1]["pieces"][-1]
    assert np.abs(controls(first, doc["inputs"], 0.0)).max() <= 1e-9
    assert np.abs(controls(last, doc["inputs"], last["duration"])).max() <= 1e-9
    # one of the two limits is met with equality (up to the peak's estimate)
    peaks = [min(m.rate, m.acceleration) for m in report.legs]
    assert min(peaks) == pytest.approx(0.0, abs=1e-5)
    verify(task, doc)  # the slowed plan still reaches every goal on re-integration


def _collides(task, result) -> bool:
    """Independently (points along the links): a link within 2 radii + clearance of link 3,
    or inside the base."""
    trajectory = result.sample(400)
    geo = world_geometry(task.system.robot, trajectory.q)
    a, b = geo["proximal"], geo["distal"]
    s = np.linspace(0, 1, 200)[:, None, None]
    link0 = a[None, :, 0] + s * (b - a)[None, :, 0]  # (200, N, 2)
    link2 = a[None, :, 2] + s * (b - a)[None, :, 2]
    base = geo["base_corners"]
    near = np.linalg.norm(link0[:, None] - link2[None], axis=-1).min(axis=(0, 1)) < 0.15
    inside = _points_in_boxes(link2, base).any(axis=0) | _points_in_boxes(
        a[None, :, 1] + s * (b - a)[None, :, 1], base
    ).any(axis=0)
    return bool((near | inside).any())


@pytest.mark.slow
def test_a_shipped_plan_that_self_collides_is_collision_free_with_the_constraint_on(tmp_path):
    free_task = load_scenario(_task_d())
    assert _collides(free_task, plan(free_task))  # Sim 4 D folds a link through the base
    raw = _task_d(self_collision=True, clearance=0.05)
    path = tmp_path / "clear.toml"
    from stratcli.tomlwrite import dumps

    path.write_text(dumps(raw))
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path), "-q", "--no-animation"])
    assert result.exit_code == 0, result.output
    (run,) = [p for p in tmp_path.iterdir() if p.is_dir()]
    doc = json.loads((run / "result.json").read_text())
    assert doc["status"] == "ok"
    assert min(m["self_clearance"] for m in doc["constraints"]["legs"]) >= 0
    from stratcli import load_run

    task = load_scenario(raw)
    assert not _collides(task, load_run(run))  # the recorded plan, re-integrated
    verify(task, doc)


def _points_in_boxes(points, boxes):
    """points (S, N, 2) inside boxes (N, 4, 2)."""
    edges = np.roll(boxes, -1, axis=1) - boxes  # (N, 4, 2)
    rel = points[:, :, None, :] - boxes[None]  # (S, N, 4, 2)
    side = edges[None, ..., 0] * rel[..., 1] - edges[None, ..., 1] * rel[..., 0]
    return np.all(side >= 0, axis=-1) | np.all(side <= 0, axis=-1)


def test_margins_are_the_smallest_distance_to_the_joint_limits():
    task = load_scenario(_task_d(joint_limits=[-3.0, 3.0], max_rate=50.0))
    result = plan_run(task, check=False).result
    trajectory = result.sample(2000)
    for leg, margins in zip(result.legs, result.constraints.legs, strict=True):
        q = trajectory.q[trajectory.leg == leg.index][:, :3]
        want = np.minimum(q + 3.0, 3.0 - q).min()
        assert margins.joint_limit == pytest.approx(want, abs=1e-12)
        assert margins.self_clearance is None and margins.obstacle_clearance is None


def test_the_constraint_report_round_trips_through_result_json(tmp_path):
    from stratcli import load_run, write_record

    task = load_scenario(_task_d(joint_limits=[-3.0, 3.0], max_rate=2.0))
    outcome = plan_run(task, check=False)
    run = write_record(tmp_path, outcome)
    loaded = load_run(run)
    assert loaded.to_dict()["constraints"] == outcome.document["constraints"]
    assert loaded.constraints == outcome.result.constraints


def test_urdf_models_take_their_joint_limits_from_the_urdf_unless_overridden():
    pytest.importorskip("pinocchio")
    raw = tomllib.loads((ROOT / "scenarios" / "spatial" / "arm7_three_legs.toml").read_text())
    raw["model"]["path"] = str(ROOT / "robots" / "bus_arm7.urdf")
    raw["constraints"] = {"max_rate": 1.0}
    task = load_scenario(raw)
    robot = task.system.spatial
    joints = len(robot.joint_names)
    np.testing.assert_array_equal(task.constraints.lower[:joints], robot.lower)
    np.testing.assert_array_equal(task.constraints.upper[:joints], robot.upper)
    assert np.all(np.isinf(task.constraints.lower[joints:]))  # the attitude is not limited
    raw["constraints"] = {"joint_limits": {"joint_2": [-1.0, 1.0]}}
    c = load_scenario(raw).constraints
    assert (c.lower[1], c.upper[1]) == (-1.0, 1.0)
    assert c.upper[0] == robot.upper[0]
    raw["constraints"] = {"self_collision": True}
    assert _problems(raw) == [
        "constraints.self_collision: self_collision needs a planar robot (a preset or a planar "
        "manipulator); for custom and URDF models only joint, rate and acceleration limits are "
        "supported"
    ]
    raw["constraints"] = {"obstacles": [{"shape": "circle", "centre": [1, 0], "radius": 0.1}]}
    (line,) = _problems(raw)  # the key written, not the table (a new user read `constraints`)
    assert line.startswith("constraints.obstacles: obstacles need a planar robot")


def test_the_schemas_and_the_models_problems_of_constraints_come_in_one_run():
    """A [constraints] table with a value the schema refuses (max_acceleration = 0) showed
    its other problems (a coordinate the model does not have, a count of rates) only on the
    next run; the refused key causes no second line (self_collision's clearance)."""
    bad = {"max_acceleration": 0, "joint_limits": {"q9": [0, 1]}, "max_rate": [1, 2, 3, 4, 5]}
    problems = _problems(_task_d(**bad))
    assert len(problems) == 3, problems
    assert problems[0].startswith("constraints.max_acceleration: must be more than 0")
    assert problems[1].startswith("constraints.joint_limits.q9: not a coordinate")
    assert problems[2].startswith("constraints.max_rate: give one number or 3")
    (only,) = _problems(_task_d(self_collision="yes", clearance=0.05))
    assert only.startswith("constraints.self_collision: must be a valid boolean")


@pytest.mark.parametrize(
    ("limits", "warned"),
    [
        ("[-150, 150]", 'q1, q2, q3 within [-150, 150] rad, 47.7 turns; if degrees were meant, '
         'write ["-150deg", "150deg"]'),
        ('{ q2 = [-2.5, 2.5], theta = [-200, 200] }', "theta within [-200, 200] rad"),
        ('["-150deg", "150deg"]', None),
        ("[-6, 6]", None),  # within a full turn: radians, surely
    ],
)  # fmt: skip
def test_joint_limits_past_a_full_turn_warn_of_degrees_and_plan_as_written(
    tmp_path, limits, warned
):
    path = tmp_path / "deg.toml"
    path.write_text(f"{TASK_D.read_text()}\n[constraints]\njoint_limits = {limits}\n")
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path / "runs"), "--quiet"])
    assert result.exit_code == 0, result.output
    warnings = [x for x in result.output.splitlines() if x.startswith("warning: ")]
    if warned is None:
        assert not warnings, warnings
        return
    (line,) = warnings
    assert line.startswith(f"warning: constraints.joint_limits: {warned}"), line
    (run,) = (tmp_path / "runs").iterdir()  # planned within the limits as written: radians
    spec = json.loads((run / "result.json").read_text())["constraints"]["spec"]
    assert spec["joint_limits"] == tomllib.loads(f"x = {limits}")["x"]


def test_a_goal_angle_past_a_full_turn_warns_of_degrees(tmp_path):
    """`goal = [.., 45, ..]` for a joint (45 rad, 7 turns) was checked with no word of degrees."""
    written = 'goal = ["-pi/3", "pi/3", "pi/4", "-pi/12"]'
    assert written in TASK_D.read_text()
    path = tmp_path / "deg.toml"
    path.write_text(TASK_D.read_text().replace(written, 'goal = ["-pi/3", "pi/3", 45, "-pi/12"]'))
    warnings = runner.invoke(app, ["check", str(path)]).output.splitlines()
    assert (
        'warning: task.goal: q3 45 rad, past a full turn; if degrees were meant, write "45deg"'
        in warnings
    )
    fine = runner.invoke(app, ["check", str(TASK_D)]).output
    assert "past a full turn" not in fine


def test_urdf_limits_and_rpy_angles_past_a_full_turn_are_named_as_degrees(tmp_path):
    """A URDF's `lower="-140" upper="140"` (degrees) were enforced as radians without a word,
    and `rpy = [4, 0, 8]` planned a turn of the base nobody meant."""
    pytest.importorskip("pinocchio")
    from stratcli.api import limit_warnings

    urdf = (ROOT / "robots" / "arm3.urdf").read_text()
    first = urdf.index('lower="')
    end = urdf.index("/>", first)
    robot = tmp_path / "deg.urdf"
    robot.write_text(urdf[:first] + 'lower="-140" upper="140" effort="1" velocity="1"' + urdf[end:])
    raw = tomllib.loads((ROOT / "scenarios" / "spatial" / "arm3_reorient.toml").read_text())
    raw["model"]["path"] = str(robot)
    raw["constraints"] = {}
    warned = [w for w in limit_warnings(load_scenario(raw)) if w.startswith("model.path")]
    assert warned == [
        "model.path: the URDF limits j1 to [-140, 140] rad, 44.6 turns; a URDF's angles are "
        "radians: if degrees were meant, convert them in the URDF (or set "
        "constraints.joint_limits)"
    ]
    raw["constraints"] = {"joint_limits": {"j1": [-2, 2]}}  # overridden: the table's
    assert not [w for w in limit_warnings(load_scenario(raw)) if w.startswith("model.path")]
    raw["constraints"] = {"joint_limits": {"j1": [-200, 2]}}  # past the URDF's own: said
    assert (
        "constraints.joint_limits: wider than the URDF's own, which they override: j1 [-200, 2] "
        "(the URDF's [-140, 140])"
    ) in limit_warnings(load_scenario(raw))
    raw["model"]["path"] = str(ROOT / "robots" / "arm3.urdf")
    raw["task"]["goal"] = {"j1": 0, "j2": 0, "j3": 0, "rpy": [4, 0, 8]}
    assert _problems(raw) == [
        'task.goal.rpy[2]: 8 rad is past a full turn; if degrees were meant, write "8deg" '
        "(roll, pitch and yaw are within -2pi ... 2pi)"
    ]
    raw["task"]["goal"]["rpy"] = [0, 0, "400deg"]  # degrees already: no advice to write them
    assert _problems(raw) == [
        "task.goal.rpy[2]: 6.98132 rad (400deg) is past a full turn; give it within a turn "
        "(roll, pitch and yaw are within -2pi ... 2pi)"
    ]


def _depth(p: np.ndarray, q: np.ndarray) -> float:
    """Independently: the shortest translation separating convex point sets p and q, as the
    smallest overlap of their projections over 7200 directions (brute force)."""
    angles = np.linspace(0.0, np.pi, 7200, endpoint=False)
    n = np.stack((np.cos(angles), np.sin(angles)))
    pp, qq = p @ n, q @ n
    overlap = np.minimum(pp.max(0) - qq.min(0), qq.max(0) - pp.min(0))
    return float(max(overlap.min(), 0.0))


def test_a_margin_inside_an_obstacle_is_the_depth_of_the_overlap_not_the_radius():
    """A link through a box: the margin says how deep (a deeper plan is worse), where the
    cores' distance alone stops at 0 and every overlap read as the link radius."""
    from stratcli.body_clearances import clearances

    q = np.array([[-1.0, 1.0, 0.5, 0.3]])
    geo = world_geometry(load_scenario(_task_d()).system.robot, q)
    a, b = geo["proximal"][0, 1], geo["distal"][0, 1]  # link 2
    centre = (0.6 * a + 0.4 * b).tolist()
    box = {"shape": "box", "centre": centre, "size": [0.3, 0.3], "rotation": 0.2}
    task = load_scenario(_task_d(obstacles=[box], clearance=0.01))  # the start is clear
    _, world = clearances(task.system.robot, q, task.constraints)
    corners = task.constraints.boxes[0]
    depth = _depth(np.stack((a, b)), corners)
    assert world[0] == pytest.approx(-depth - 0.05 - 0.01, abs=1e-4)
    assert world[0] < -0.05 - 0.01 - 0.1  # far deeper than "touching"
    folded = np.array([[0.0, 2.9, 2.9, 0.0]])  # and the arm folded onto itself and the base
    task = load_scenario(_task_d(self_collision=True))
    own, _ = clearances(task.system.robot, folded, task.constraints)
    geo = world_geometry(task.system.robot, folded)
    seg = [np.stack((geo["proximal"][0, i], geo["distal"][0, i])) for i in range(3)]
    base = geo["base_corners"][0]
    expected = min(
        -_depth(seg[0], seg[2]) - 0.1 if _depth(seg[0], seg[2]) > 0 else np.inf,
        -_depth(seg[1], base) - 0.05 if _depth(seg[1], base) > 0 else np.inf,
        -_depth(seg[2], base) - 0.05 if _depth(seg[2], base) > 0 else np.inf,
    )
    assert own[0] == pytest.approx(expected, abs=1e-4)


def test_a_length_with_its_unit_is_one_line_saying_to_write_the_number_alone(tmp_path):
    path = tmp_path / "cm.toml"
    path.write_text(
        f'{TASK_D.read_text()}\n[constraints]\nself_collision = true\nclearance = "5cm"\n'
    )
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path / "runs")])
    assert result.exit_code == 2, result.output
    (line,) = result.output.strip().splitlines()
    assert line == (
        f"error: {path}: constraints.clearance: a unit (cm) is not read on a length: write the "
        "number alone, in the model's length unit (m) (got '5cm')"
    )


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("clearance", '"3deg"'),
        ("clearance", '"0.05 rad"'),
        ("link_radius", '"0.05m"'),
        ("obstacles", '[{ shape = "circle", centre = ["-0.3 rad", 1.3], radius = 0.15 }]'),
        ("obstacles", '[{ shape = "circle", centre = [-0.3, 1.3], radius = "10deg" }]'),
        ("obstacles", '[{ shape = "box", centre = [1.9, -0.1], size = [0.3, "30°"] }]'),
    ],
)
def test_a_length_refuses_an_angle_unit_where_an_angle_reads_it(field, value):
    """An angle's unit on a length was read: a "3deg" clearance became 0.0524, a centre of
    "90deg" 1.5708. Angles and rates still read theirs."""
    raw = tomllib.loads(TASK_D.read_text())
    raw["constraints"] = tomllib.loads(f"{field} = {value}\nself_collision = true")
    with pytest.raises(InputError, match=r"is not read on a length") as info:
        load_scenario(raw)
    assert info.value.problems[0].path.startswith(f"constraints.{field}")
    raw["constraints"] = {
        "max_rate": "60deg",
        "joint_limits": ["-2.5 rad", "2.5rad"],
        "obstacles": [{"shape": "box", "centre": [1.9, -0.1], "size": [0.3, 0.6],
                       "rotation": "30deg"}],
    }  # fmt: skip
    c = load_scenario(raw).constraints
    assert c.max_rate[0] == pytest.approx(np.pi / 3) and c.upper[0] == 2.5


def test_an_arms_mount_is_a_length_too():
    """A mount of "0.3 rad" was read as 0.3 m once rad became an angle's unit."""
    raw = tomllib.loads((ROOT / "scenarios" / "rods_three_link.toml").read_text())
    raw["model"]["arms"][0]["mount"] = ["0.3 rad", 0.0]
    with pytest.raises(
        InputError, match=r"model\.arms\[0\]\.mount\[0\]: a unit \(rad\) is not read"
    ):
        load_scenario(raw)


def test_compare_sequences_and_auto_mode_warn_of_joint_limits_past_a_full_turn(tmp_path):
    text = (ROOT / "scenarios" / "sim4_auto.toml").read_text()
    text = text.replace("[planner]\n", '[planner]\nobjective = "newton"\n')
    path = tmp_path / "auto.toml"
    path.write_text(text.replace("max_length = 3", "max_length = 2")
                    + "\n[constraints]\njoint_limits = [-150, 150]\n")  # fmt: skip
    warned = "warning: constraints.joint_limits: q1, q2, q3 within [-150, 150] rad"
    for command in ("compare-sequences", "plan"):
        out = tmp_path / command
        result = runner.invoke(app, [command, str(path), "--out", str(out), "--quiet"])
        assert result.exit_code in (0, 1), result.output
        assert [x for x in result.output.splitlines() if x.startswith("warning:")] == [
            x for x in result.output.splitlines() if x.startswith(warned)
        ]
        assert warned in result.output, command


@pytest.mark.parametrize(
    ("constraints", "line"),
    [  # a value of several forms: only the form it is of speaks (the number's parser spoke too)
        ({"max_rate": [1, 0, 1]}, "constraints.max_rate[1]: must be more than 0 (got 0)"),
        (
            {"joint_limits": [[-1, 1], [-1], [-1, 1]]},  # pairs, one short: not "at most 2"
            "constraints.joint_limits[1]: must have at least 2 entries, not 1 (got [-1])",
        ),
        ({"max_rate": {"u1": 0}}, "constraints.max_rate.u1: must be more than 0 (got 0)"),
    ],
)
def test_a_value_of_several_forms_is_told_by_the_form_it_is_of(constraints, line):
    assert _problems(_task_d(**constraints)) == [line]


def test_a_speed_up_just_past_the_limit_is_shown_with_the_digits_that_tell_it_apart():
    """`time_scaled(plan, 1.000001)` of a plan at its rate limit said "time_scaled by 1,
    where at most 1 meets every ... limit": the speed-up and its bound read the same."""
    from stratcli.limit_timing import _retimed

    said = _retimed("too fast for u1's rate limit", 1 / 1.000001, 1.000001, "less meets it")
    assert said.startswith("re-timed too fast for u1's rate limit: time_scaled by 1.000001, where")
    assert "time_scaled by 2, where at most 1 meets it" in _retimed("x", 0.5, 2.0, "less meets it")


def test_stratcli_plan_warns_of_a_limit_that_looks_mistaken_with_its_own_category(tmp_path):
    """Limits past a full turn (degrees?) came as an IllConditionedWarning, the check's
    category for a hard leg: a script filtering one filtered both."""
    import warnings

    import stratcli

    raw = _task_d(joint_limits=[-150, 150])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        stratcli.plan(raw, check=False)
    kinds = {(w.category.__name__, str(w.message)[:27]) for w in caught}
    assert ("LimitWarning", "constraints.joint_limits: q") in kinds
    assert not any(w.category is stratcli.IllConditionedWarning for w in caught)
    assert all(w.filename == __file__ for w in caught)  # the caller's line, not the package


class _Stop(Exception):
    """Raised by a progress callback: the warnings come before any planning."""


def _stop(*_):
    raise _Stop


@pytest.mark.parametrize("use_case", ["plan_auto", "compare_sequences"])
def test_auto_mode_and_comparisons_warn_of_a_limit_that_looks_mistaken(use_case):
    """`plan` of a scenario with legs warned of limits past a full turn; auto mode (`plan`
    without legs runs `plan_auto`) and `compare_sequences` did not (the command line printed
    them itself): a notebook's auto-mode plan with degrees written as radians went unwarned.
    A `warn` callback gets them instead of Python's warnings."""
    import warnings

    import stratcli

    raw = _task_d(joint_limits=[-150, 150])
    if use_case == "plan_auto":
        del raw["legs"]
        raw["decompose"] = {"max_length": 2}
    call = getattr(stratcli, use_case)
    kw = {"check": False} if use_case == "plan_auto" else {}
    with warnings.catch_warnings(record=True) as caught, pytest.raises(_Stop):
        warnings.simplefilter("always")
        call(raw, jobs=1, progress=_stop, **kw)
    limits = [w for w in caught if w.category is stratcli.LimitWarning]
    assert [str(w.message)[:27] for w in limits] == ["constraints.joint_limits: q"]
    assert all(w.filename == __file__ for w in limits)  # the caller's line
    said: list[str] = []
    with warnings.catch_warnings(record=True) as caught, pytest.raises(_Stop):
        warnings.simplefilter("always")
        call(raw, jobs=1, progress=_stop, warn=said.append, **kw)
    assert len(said) == 1 and said[0].startswith("constraints.joint_limits: q")
    assert not [w for w in caught if w.category is stratcli.LimitWarning]
