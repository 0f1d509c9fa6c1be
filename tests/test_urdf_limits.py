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
    r"t = (?P<t>[\d.]+) s\); add a \[constraints\] table \(even an empty one\) to have them "
    r"verified \(the plan then fails\)$"
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


def test_a_violated_urdf_limit_is_named_as_the_urdfs_with_advice_that_can_help(tmp_path):
    plan = stratcli.plan(_scenario(tmp_path, constraints="[constraints]\n"))
    assert not plan.ok and plan.status is stratcli.Status.CONSTRAINT_VIOLATED
    assert plan.message.startswith("leg 1 (S3) violates the URDF's joint limits of j2 [-1, 1] by")
    assert "wider limits in [constraints].joint_limits" in plan.message
    assert "another stratum sequence" in plan.message
    assert "more harmonics" not in plan.message.replace("more harmonics do not help", "")
    assert "a limit of [constraints]" not in plan.message
    assert plan.notes[-1].startswith("the limits were verified, not searched for")


def test_after_plain_newton_the_advice_names_the_energy_objective(tmp_path):
    """The scenario's objective is "newton": the energy objective may help there, so the
    advice names it (after an energy plan it does not)."""
    table = "[constraints]\njoint_limits = { j2 = [-1, 1] }\n"
    for plan in (
        stratcli.plan(_scenario(tmp_path, constraints="[constraints]\n")),  # the URDF's
        stratcli.plan(_scenario(tmp_path, upper_j2=2.0, constraints=table)),  # the table's
    ):
        assert plan.status is stratcli.Status.CONSTRAINT_VIOLATED
        assert 'try objective = "energy" (the default' in plan.message
        assert "more harmonics do not help" in plan.message
        assert "the other objective" not in plan.message
    energy = _scenario(tmp_path).with_name("energy.toml")  # j2 within ±1: 1.04 at least energy
    energy.write_text(
        SCENARIO.replace('objective = "newton"', 'objective = "energy"').format(
            j2=0, constraints="[constraints]\n"
        )
    )
    plan = stratcli.plan(energy)
    assert plan.status is stratcli.Status.CONSTRAINT_VIOLATED
    assert 'objective = "energy"' not in plan.message
    assert "more harmonics or the other objective do not help" in plan.message


def test_a_violated_limit_of_the_table_on_a_urdf_model_does_not_advise_harmonics(tmp_path):
    table = "[constraints]\njoint_limits = { j2 = [-1, 1] }\n"
    plan = stratcli.plan(_scenario(tmp_path, upper_j2=2.0, constraints=table))
    assert plan.message.startswith("leg 1 (S3) violates the joint limits of j2 by")
    assert "URDF's" not in plan.message
    assert "more harmonics" not in plan.message.replace("more harmonics do not help", "")
    assert "the constrained search does not run on URDF models" in plan.message


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
