"""Weak strata diagnosed before planning (issue 14): the reachability estimate of each leg,
the check's warnings, and what `check` and `plan` print."""

from __future__ import annotations

import pytest
from conftest import SCENARIOS, weak_stratum_scenario
from typer.testing import CliRunner

from stratcli.api.check import check_document
from stratcli.api.inspection import check_controllability
from stratcli.api.planning import plan_run
from stratcli.cli import app
from stratcli.reachability import WARN_ENERGY, better_strata, reach
from stratcli.scenario import load_scenario

runner = CliRunner()

WEAK = weak_stratum_scenario(joints="0, 0")  # the 4-link arm, joints back at 0


def test_the_weak_leg_needs_third_order_brackets_and_theta_is_hard():
    task = load_scenario(WEAK)
    leg = task.legs[0]
    r = reach(task.system, "S12", task.start, leg.goal, leg.duration)
    assert r.degree == 3 and r.sigma == pytest.approx(3.3e-3, rel=0.05)
    assert task.system.states[r.hard] == "theta" and r.leverage > 50 and r.weak
    better = better_strata(task.system, task.start, leg.goal, leg.duration, r)
    assert better[0].stratum == "S34" and not better[0].weak  # the heavy proximal links
    assert {b.stratum for b in better} >= {"S1", "S2", "S3", "S4", "S14", "S24"}
    assert "S13" not in {b.stratum for b in better}  # flagged too (two light links)


def test_the_check_warns_about_the_weak_leg_naming_theta_and_a_better_stratum():
    task = load_scenario(WEAK)
    doc = check_document(task.system, ["S12"], task.start, samples=5, legs=task.legs)
    assert doc["controllable"] and not doc["problems"]  # a warning, not a failure
    (warning,) = doc["warnings"]
    assert warning.startswith("leg 1 on S12 may be ill-conditioned: at its start theta is hard")
    assert "third-order brackets" in warning and "try stratum S34" in warning
    assert "auto mode" in warning
    assert doc["legs"][0]["reach"]["hard_coordinate"] == "theta"
    assert doc["legs"][0]["reach"]["weak"] is True


def test_a_small_turn_with_free_joints_is_not_warned():
    task = load_scenario(weak_stratum_scenario())
    doc = check_document(task.system, ["S12"], task.start, samples=5, legs=task.legs)
    assert doc["warnings"] == [] and doc["legs"][0]["reach"]["degree"] == 1


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_no_shipped_scenario_is_warned_about(path):
    doc = check_controllability(path, samples=5).document
    assert doc["warnings"] == []
    for leg in doc["legs"] or []:
        assert leg["reach"]["predicted_energy"] < WARN_ENERGY / 3
        assert leg["reach"]["degree"] <= 2


def test_plan_warns_before_any_iteration():
    said: list[str] = []
    outcome = plan_run(load_scenario(WEAK), progress=said.append, warn=said.append)
    warned = [i for i, s in enumerate(said) if "may be ill-conditioned" in s]
    newton = said.index("planning the legs one by one (Newton)")
    assert len(warned) == 1 and warned[0] < newton
    assert outcome.result.legs[0].stratum == "S12"  # planned as asked all the same


def test_the_python_api_warns_with_a_python_warning_at_the_callers_line():
    """`stratcli.plan` has no terminal: the check's warning is an IllConditionedWarning,
    attributed to the line that called `plan` (a notebook shows it there)."""
    import stratcli

    with pytest.warns(stratcli.IllConditionedWarning, match="theta is hard to move") as seen:
        plan = stratcli.plan(WEAK)  # the caller's line
    assert plan.legs[0].stratum == "S12"
    assert len(seen) == 1 and seen[0].filename == __file__


def test_check_prints_one_warning_line_and_exits_0(tmp_path):
    path = tmp_path / "weak.toml"
    path.write_text(WEAK)
    result = runner.invoke(app, ["check", str(path), "--samples", "5"])
    assert result.exit_code == 0, result.output
    lines = [x for x in result.stderr.splitlines() if x.startswith("warning:")]
    assert len(lines) == 1 and "theta is hard to move" in lines[0] and "S34" in lines[0]


def test_plan_of_a_runaway_leg_fails_fast_saying_why(tmp_path):
    path = tmp_path / "runaway.toml"
    path.write_text(weak_stratum_scenario(theta="90deg"))
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path / "runs"), "-q"])
    assert result.exit_code == 1
    assert "planning failed: leg 1 on S12 was abandoned: the search diverged (q3 reached" in (
        result.stderr
    )
    assert "try another stratum" in result.stderr


ARM3_LEG = """
name = "arm3_s1_turns_z"
[model]
kind = "urdf"
path = "{root}/robots/arm3.urdf"
[task]
start = {{ j1 = 0, j2 = "20deg", j3 = "-30deg", attitude = [0, 0, 0] }}
goal = {{ j1 = 0, j2 = "-10deg", j3 = "20deg", attitude = [0, {ry}, {rz}] }}
[planner]
objective = "newton"
tolerance = 1e-6
leg_duration = 2.0
[[legs]]
stratum = "S1"
"""


def _arm3_s1(rz: str, ry: str = "0"):
    from conftest import ROOT

    return load_scenario(ARM3_LEG.format(root=ROOT, rz=rz, ry=ry))


def test_out_of_reach_names_the_direction_a_urdf_stratum_cannot_move():
    """S1 of the golden arm locks j1 at 0: j2 and j3 swing in the base's xz plane, so every
    field and bracket turns the base about y only; a goal turning it about z is out of reach,
    one turning it about y is not (and the other strata span z there)."""
    from stratcli.reachability import out_of_reach

    task = _arm3_s1('"5deg"')
    why = out_of_reach(task.system, "S1", task.start, task.goal, 1e-6)
    assert why is not None and why.startswith("S1 cannot move rz from the leg's start")
    assert "span 3 of the 5 coordinates" in why
    reachable = _arm3_s1("0", ry='"5deg"')
    assert out_of_reach(task.system, "S1", task.start, reachable.goal, 1e-6) is None
    for other in ("S2", "S3"):
        assert out_of_reach(task.system, other, task.start, task.goal, 1e-6) is None


def test_out_of_reach_leaves_planar_models_to_their_continuation():
    task = load_scenario(WEAK)
    assert out_of_reach_of(task) is None


def out_of_reach_of(task):
    from stratcli.reachability import out_of_reach

    leg = task.legs[0]
    return out_of_reach(task.system, leg.stratum, task.start, leg.goal, 1e-6)


def test_a_urdf_leg_out_of_reach_fails_without_continuation_naming_stratum_and_direction():
    """It took ~30 s of continuation to fail (auto mode on arm3_auto without its strata
    list); now Newton's own attempts, then the reason."""
    from stratcli.objectives import plan_sequence

    task = _arm3_s1('"5deg"')
    plan = plan_sequence(task.system, task.start, list(task.legs), task.settings)
    (leg,) = plan.legs
    assert not plan.ok and leg.strategy != "continuation"
    budget = (task.settings.restarts + 1) * task.settings.max_iterations
    assert leg.iterations <= budget  # Newton's own attempts only: no continuation after them
    assert "S1 cannot move rz from the leg's start" in leg.message
    assert "no continuation tried" in leg.message
    # what it advises: no tuning of the search ("try more harmonics" contradicted the reason)
    advice = plan.message.rpartition("(no continuation tried)); ")[2]
    assert advice.startswith("give the leg a via its stratum can reach, or other strata")
    assert "harmonics" not in advice and "max_iterations" not in advice


def test_a_coordinate_free_at_the_via_before_is_no_distance_to_steer():
    """Sim 3 with theta free at both vias: the check read leg 3's start theta as 0 and warned
    of an ill-conditioned leg at ~1.2e4 (planned at 0.78): where it starts is not known."""
    import tomllib

    from conftest import ROOT

    raw = tomllib.loads((ROOT / "scenarios" / "sim3_hybrid.toml").read_text())
    for leg in raw["legs"][:-1]:
        leg["goal"][-1] = "*"
    task = load_scenario(raw)
    doc = check_document(task.system, [leg.stratum for leg in task.legs], task.start,
                         samples=5, legs=task.legs)  # fmt: skip
    assert not doc["warnings"], doc["warnings"]
    assert doc["legs"][2]["reach"]["weak"] is False  # still estimated: q2 and q3 are known
