"""A URDF's joint limits: noted where a scenario has no [constraints] table (the plan's status
unchanged), and named as the URDF's, with advice that can help there, where one fails it."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

ROOT = Path(__file__).resolve().parents[1]

pin = pytest.importorskip("pinocchio")

import stratcli  # noqa: E402
from stratcli.cli import app  # noqa: E402
from stratcli.urdf_limits import joint_paths  # noqa: E402

SCENARIO = """name = "limits"
[model]
kind = "urdf"
path = "arm.urdf"
[task]
start = {{ j1 = 0, j2 = {j2}, j3 = 0, attitude = [0, 0, 0] }}
goal = {{ j1 = 0, j2 = 0, j3 = "*", attitude = [0.1, 0, 0] }}
[planner]
objective = "newton"
[[legs]]
stratum = "S3"
{constraints}"""


def _scenario(tmp_path, upper_j2=1.0, j2=0, constraints=""):
    """arm3 with j2 limited to ±upper_j2; its plan swings j2 to 1.3 rad (from j2 = 0)."""
    urdf = (ROOT / "robots" / "arm3.urdf").read_text()
    urdf = urdf.replace('lower="-2.0" upper="2.0"', f'lower="-{upper_j2}" upper="{upper_j2}"')
    (tmp_path / "arm.urdf").write_text(urdf)
    path = tmp_path / "s.toml"
    path.write_text(SCENARIO.format(j2=j2, constraints=constraints))
    return path


NOTE = re.compile(
    r"^leg 1 leaves the URDF's limits of j2 \[-1, 1\] \(reaches (?P<value>[-\d.]+) at "
    r"t = (?P<t>[\d.]+) s\); add a \[constraints\] table \(even an empty one\) to have the "
    r"plan kept within them$"
)


def test_a_plan_leaving_the_urdf_limits_gets_a_note_not_a_failure(tmp_path):
    plan = stratcli.plan(_scenario(tmp_path))
    assert plan.ok and plan.constraints is None  # the status is unchanged
    (note,) = plan.notes
    found = NOTE.match(note)
    assert found, note
    trajectory = plan.sample(2000)  # independently re-integrated: where j2 is farthest out
    k = int(np.argmax(trajectory.q[:, 1]))
    assert trajectory.q[k, 1] > 1.0
    assert float(found["value"]) == pytest.approx(trajectory.q[k, 1], abs=5e-3)
    assert float(found["t"]) == pytest.approx(trajectory.t[k], abs=2e-3)
    assert plan.to_dict()["notes"] == [note]  # result.json too


def test_a_plan_inside_the_urdf_limits_gets_no_note(tmp_path):
    assert stratcli.plan(_scenario(tmp_path, upper_j2=2.0)).notes == ()


def test_the_joints_in_closed_form_are_the_re_integrated_ones(tmp_path):
    plan = stratcli.plan(_scenario(tmp_path, upper_j2=2.0))
    trajectory = plan.sample(2000)
    t, q = joint_paths(plan.legs[0], 3)
    np.testing.assert_allclose(t, trajectory.t, atol=1e-12)
    np.testing.assert_allclose(q, trajectory.q[:, :3], atol=1e-8)


def test_a_start_outside_the_urdf_limits_is_noted_not_refused(tmp_path):
    plan = stratcli.plan(_scenario(tmp_path, j2=1.2), check=False)
    assert plan.notes[0] == (
        "task.start has j2 = 1.2, outside the URDF's limits [-1, 1]; with a [constraints] "
        "table, even an empty one, that is an error"
    )
    assert (
        "leg 1 leaves the URDF's limits of j2 [-1, 1] (reaches 1.2 at t = 0.000 s)"
        in (plan.notes[1])
    )


def test_a_value_just_past_a_limit_is_shown_with_the_digits_that_show_it(tmp_path):
    """Not "reaches 2" beside limits [-2, 2]: as many digits as it takes to differ."""
    plan = stratcli.plan(_scenario(tmp_path, j2=1.0004), check=False)
    assert plan.notes[0].startswith("task.start has j2 = 1.0004, outside the URDF's limits [-1, 1]")
    free = stratcli.plan(_scenario(tmp_path, upper_j2=2.0))
    farthest = joint_paths(free.legs[0], 3)[1][:, 1].max()  # 1.3...
    upper = np.floor(farthest * 1000) / 1000  # the leg leaves it by less than 1e-3
    plan = stratcli.plan(_scenario(tmp_path, upper_j2=upper))
    reached = NOTE.pattern.replace(r"\[-1, 1\]", rf"\[{-upper:.3g}, {upper:.3g}\]")
    found = re.match(reached, plan.notes[-1])
    assert found, plan.notes[-1]
    assert float(found["value"]) > upper and found["value"] != f"{upper:.3g}"
    assert float(found["value"]) == pytest.approx(farthest, abs=5e-4)


def test_the_cli_prints_the_note_and_exits_0(tmp_path):
    result = CliRunner().invoke(
        app, ["plan", str(_scenario(tmp_path)), "--out", str(tmp_path / "runs")]
    )
    assert result.exit_code == 0, result.output
    assert "note: leg 1 leaves the URDF's limits of j2 [-1, 1] (reaches 1.3" in result.output


def _joint_extremes(doc: dict, j: int) -> tuple[float, float]:
    """Lowest and highest value of joint j along the plan, from result.json's controls alone
    (the joints of a URDF robot are the integrals of their rates: trapezoids on 20001 points
    a piece), independent of stratplan's own sampling and verification."""
    from reintegrate import controls

    q, low, high = float(doc["start"][j]), np.inf, -np.inf
    for leg in doc["legs"]:
        for piece in leg["pieces"]:
            t = np.linspace(0.0, piece["duration"], 20001)
            u = np.array([controls(piece, doc["inputs"], x)[j] for x in t])
            path = q + np.concatenate([[0.0], np.cumsum(0.5 * (u[1:] + u[:-1]) * np.diff(t))])
            low, high, q = min(low, path.min()), max(high, path.max()), float(path[-1])
    return low, high


@pytest.mark.parametrize("objective", ["newton", "energy"])
def test_a_urdf_plan_is_searched_within_the_urdfs_limits(tmp_path, objective):
    """With a [constraints] table the URDF's joint limits are searched for, not only verified
    (they failed the plan): its joints are closed-form, the attitude a goal on SO(3). The
    unconstrained plan swings j2 to 1.3 rad; the plan found keeps it inside ±1, re-integrated
    independently (scipy on the group) and the joints from the controls alone."""
    from spatial_reintegrate import verify_spatial

    path = _scenario(tmp_path, constraints="[constraints]\n")
    path.write_text(path.read_text().replace('"newton"', f'"{objective}"'))
    plan = stratcli.plan(path)
    assert plan.ok, plan.message
    doc = plan.to_dict()
    verify_spatial(doc, plan.system.spatial)
    low, high = _joint_extremes(doc, 1)
    assert -1.0 - 1e-6 <= low and high <= 1.0 + 1e-6 and high > 0.9  # pressed against it
    assert not any("not searched for" in note for note in plan.notes)
    assert any(note.startswith("constrained search from") for note in plan.notes)
    assert plan.constraints.legs[0].joint_limit >= 0
    # result.json says which limits it kept: the URDF's, which the empty table does not list
    assert doc["constraints"]["spec"]["joint_limits"] is None
    urdf = {"lower": -1.0, "upper": 1.0, "from": "urdf"}
    assert doc["constraints"]["joint_limits"]["j2"] == urdf
    assert doc["constraints"]["joint_limits"]["j1"]["from"] == "urdf"  # arm3's ±2
    assert set(doc["constraints"]["joint_limits"]) == {"j1", "j2", "j3"}  # no attitude's


def test_a_table_overriding_the_urdfs_limit_is_recorded_as_the_tables(tmp_path):
    path = _scenario(tmp_path, constraints="[constraints]\njoint_limits = { j2 = [-0.5, 1.5] }\n")
    with pytest.warns(
        stratcli.LimitWarning, match=r"wider than the URDF's own.*j2 \[-0\.5, 1\.5\]"
    ):
        plan = stratcli.plan(path, check=False)
    limits = plan.to_dict()["constraints"]["joint_limits"]
    assert limits["j2"] == {"lower": -0.5, "upper": 1.5, "from": "table"}
    assert limits["j1"]["from"] == "urdf"
    again = stratcli.load_run(stratcli.write_record(tmp_path / "runs", plan))
    assert again.constraints.joint_limits == plan.constraints.joint_limits


def test_a_limit_on_the_attitude_is_refused_naming_the_joints(tmp_path):
    """A limit on rx (an attitude component) made the constrained search give up with a note
    blaming ODE-path legs, and the plan failed the URDF's joint limits it kept before."""
    path = _scenario(tmp_path, constraints="[constraints]\njoint_limits = { rx = [-1, 1] }\n")
    result = CliRunner().invoke(app, ["check", str(path)])
    assert result.exit_code == 2, result.output
    assert "constraints.joint_limits.rx: a component of the base's attitude" in result.output
    assert "(j1, j2, j3)" in result.output and "Traceback" not in result.output


def test_a_urdf_limit_the_search_cannot_keep_is_named_as_the_urdfs(tmp_path):
    """j2 within ±0.02 rad cannot turn the base 0.1 rad: the search stalls, and the message
    names the limit as the URDF's with what can help, wider limits in the table among it."""
    plan = stratcli.plan(_scenario(tmp_path, upper_j2=0.02, constraints="[constraints]\n"))
    assert not plan.ok and plan.status is stratcli.Status.CONSTRAINT_VIOLATED
    assert plan.message.startswith("the constrained search stalled on leg 1: the joint limits")
    assert (
        "; kept instead: the plan found without the limits, in which leg 1 (S3) violates the "
        "URDF's joint limits of j2 [-0.02, 0.02] by"
    ) in plan.message
    assert "at its nodes (with 3 harmonics; it stalled with 5 and 8 too)" in plan.message
    assert plan.message.endswith(  # retried with 5 and 8 harmonics: more than those
        "try via configurations that keep the joint away from the limit, another stratum "
        "sequence, more than 8 harmonics (planner.basis.harmonics), the other objective, or "
        "wider limits in [constraints].joint_limits"
    )
    table = "[constraints]\njoint_limits = { j2 = [-0.02, 0.02] }\n"  # the table's own
    plan = stratcli.plan(_scenario(tmp_path, upper_j2=2.0, constraints=table))
    assert "violates the joint limits of j2 by" in plan.message and "URDF's" not in plan.message
    assert plan.message.endswith(
        stratcli.Status.CONSTRAINT_VIOLATED.value.replace(
            "more harmonics", "more than 8 harmonics (planner.basis.harmonics)"
        )
    )


def test_compare_sequences_notes_the_best_plans_urdf_limits(tmp_path):
    """The shipped arm3_auto: its best plan takes j1 to -4.25 rad (the URDF says ±3.14)."""
    scenario = ROOT / "scenarios" / "spatial" / "arm3_auto.toml"
    outcome = stratcli.compare_sequences(scenario, jobs=1)
    assert outcome.ok  # as before: not failed by default
    (note,) = outcome.notes
    assert note.startswith("leg 1 leaves the URDF's limits of j1 [-3.14, 3.14] (reaches -4.25")
    assert note in outcome.best.result.notes
    result = CliRunner().invoke(
        app, ["compare-sequences", str(scenario), "--out", str(tmp_path), "--jobs", "1"]
    )
    assert result.exit_code == 0 and f"note: {note}" in result.output


def test_check_warns_of_a_start_outside_the_urdf_limits_and_exits_0(tmp_path):
    scenario = str(_scenario(tmp_path, j2=1.2))
    result = CliRunner().invoke(app, ["check", scenario, "--samples", "5"])
    assert result.exit_code == 0, result.output
    assert "warning: task.start has j2 = 1.2, outside the URDF's limits [-1, 1]" in result.output
    inside = CliRunner().invoke(app, ["check", str(_scenario(tmp_path)), "--samples", "5"])
    assert inside.exit_code == 0 and "URDF" not in inside.output


def test_the_notes_times_are_those_of_the_plan_as_run_with_a_time_scale(tmp_path):
    path = _scenario(tmp_path)
    t1 = float(NOTE.match(stratcli.plan(path).notes[0])["t"])
    t2 = float(NOTE.match(stratcli.plan(path, time_scale=2.0).notes[0])["t"])
    assert t2 == pytest.approx(t1 / 2, abs=1e-3)
    auto = stratcli.plan_auto(ROOT / "scenarios" / "spatial" / "arm3_auto.toml", time_scale=2.0)
    (note,) = auto.notes
    assert "(reaches -4.25 at t = 0.454 s)" in note and auto.best.result.notes == (note,)


def test_time_scaled_times_the_legs_note_again(tmp_path):
    """`time_scaled` kept the note's times of the old speed: it is made again for the new
    timing (the same path: the same value, at half the time), in its place, once."""
    import dataclasses

    path = _scenario(tmp_path)
    planned = stratcli.plan(path)
    (legs,) = planned.notes
    plan = dataclasses.replace(planned, notes=("another note", legs, "a last one"))
    faster = stratcli.time_scaled(plan, 2.0)
    assert faster.notes[0] == "another note" and faster.notes[2] == "a last one"
    before, after = NOTE.match(legs), NOTE.match(faster.notes[1])
    assert after, faster.notes[1]
    assert float(after["t"]) == pytest.approx(float(before["t"]) / 2, abs=1e-3)
    assert after["value"] == before["value"]
    assert faster.notes[1] == stratcli.plan(path, time_scale=2.0).notes[0]  # as if planned so
    assert stratcli.time_scaled(faster, 0.5).notes == plan.notes
