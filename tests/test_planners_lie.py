"""The Lie-algebraic leg planner: Lie legs among Newton legs, local and cheap."""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from reintegrate import controls, verify
from scipy.integrate import cumulative_trapezoid

from stratcli.continuity import mode_order
from stratcli.models.presets import preset
from stratcli.objectives import plan_sequence
from stratcli.records.result import result_document
from stratcli.scenario import load_scenario
from stratcli.status import Status
from stratcli.stratified import LegSpec, PlannerSettings

PI = np.pi


def _pieces_join(doc, leg, order):
    """Values (and derivatives) of consecutive pieces of a leg agree at their joints."""

    inputs = doc["inputs"]
    worst = 0.0
    for a, b in zip(leg["pieces"], leg["pieces"][1:], strict=False):
        for d in range(order + 1):
            end = controls(a, inputs, a["duration"], bool(d))
            start = controls(b, inputs, 0.0, bool(d))
            worst = max(worst, float(np.abs(end - start).max()))
    return worst


@pytest.mark.parametrize(("degree", "rest"), [(3, True), (2, False)])
def test_hybrid_newton_lie_newton_keeps_continuity_and_reaches_every_goal(degree, rest):
    """A Lie leg between two Newton legs: its steps are pieces, each piece joins the next
    with C1, the first continues the Newton leg before it, the next Newton leg continues the
    last piece; every goal is reached, checked by re-integrating result.json independently."""
    system = preset("one-arm")
    q0 = np.array([0.0, PI / 4, 0.0, 0.0])
    via1 = np.array([0.0, PI / 3, 0.3, -0.05])
    via2 = via1 + np.array([0.0, 0.1, -0.05, 0.04])
    goal = np.array([-0.2, PI / 3 + 0.1, 0.25, np.nan])
    settings = PlannerSettings(objective="newton")
    lie = replace(settings.lie, degree=degree, rest=rest)
    legs = [
        LegSpec("S1", via1),
        LegSpec("S1", via2, method="lie", lie=lie),
        LegSpec("S3", goal),
    ]
    plan = plan_sequence(system, q0, legs, settings)
    assert plan.ok, plan.message
    doc = result_document(plan, "hybrid", "one-arm")
    lie_leg = doc["legs"][1]
    assert lie_leg["method"] == "lie" and len(lie_leg["pieces"]) >= 2
    assert lie_leg["duration"] == pytest.approx(0.51 * len(lie_leg["pieces"]))
    assert [p["t0"] for p in lie_leg["pieces"]] == pytest.approx(
        [0.51 * k for k in range(len(lie_leg["pieces"]))]
    )
    assert _pieces_join(doc, lie_leg, 1) <= 1e-9
    # u1 is unused on the Lie leg's S1 and u2 on the next leg's S3 (lr-C1): both end at zero
    for sw in doc["switches"]:
        assert max(abs(v) for v in sw["jump"].values()) <= 1e-9
        assert max(abs(v) for v in sw["jump_derivative"].values()) <= 1e-9

    verify(SimpleNamespace(legs=legs, text=""), doc)  # what verify() needs from a task
    if rest:  # time scaling scales every piece of the Lie leg: same path, energy x s
        from stratcli.time_scaling import time_scaled

        fast = time_scaled(plan, 2.0)
        assert fast.total_energy == pytest.approx(2.0 * plan.total_energy, rel=1e-9)
        verify(SimpleNamespace(legs=legs, text=""), result_document(fast, "hybrid", "one-arm"))
    # the trajectory sampler integrates the Lie leg piece by piece to the same end point
    from stratcli.records.trajectory import sample

    traj = sample(plan, samples_per_leg=100)
    np.testing.assert_allclose(traj.q[traj.leg_slice(1)][-1], plan.legs[1].end, atol=1e-8)
    assert mode_order(doc["continuity"]) == 1


def test_sim3_lie_leg_is_local_and_cheap(scenarios_dir):
    task = load_scenario(scenarios_dir / "sim3_hybrid.toml")
    assert [leg.method for leg in task.legs] == ["newton", "newton", "lie"]
    assert task.settings.lie.degree == 3
    # the Lie leg alone, from the configuration and the controls the Newton legs leave
    start = np.array([-PI / 3, -PI / 3, PI / 6, PI / 12])
    previous = (np.array([0.0, 0.0, -1.25]), np.array([0.0, 0.0, 19.6]))
    from stratcli.stratified import LegStart, plan_next_leg, planner_for

    lie_leg = task.legs[2]
    at = LegStart(start, previous, 2.0, 2)
    planner = planner_for(lie_leg, task.settings)
    leg = plan_next_leg(task.system, task.settings, lie_leg, at, None, planner)
    assert leg.converged and leg.error <= 1e-3
    assert leg.energy < 20.0  # small loops (the Newton legs cost ~10² here)
    # local: small periodic motions of the joints (the Newton legs sweep them by ~3 rad)
    t = np.linspace(0.0, leg.duration, 4001)
    u = leg.controls(t)
    joints = cumulative_trapezoid(u[:, 1:], t, axis=0, initial=0.0)
    assert np.ptp(joints, axis=0).max() < 0.5
    u0 = leg.controls(np.array([0.0]))[0]
    du0 = leg.controls(np.array([0.0]), True)[0]
    np.testing.assert_allclose(u0, previous[0], atol=1e-9)
    np.testing.assert_allclose(du0, previous[1], atol=1e-9)


CRAB = """
name = "crab"
[model]
kind = "planar-manipulator"
base = { mass = 20.0, a = 1.2, b = 0.8 }
[[model.arms]]
mount = [0.6, 0.2]
links = [{ mass = 3.0, length = 0.9 }, { mass = 1.5, length = 0.7 }]
[[model.arms]]
mount = [-0.6, -0.2]
zero_angle = "pi"
sense = -1
links = [{ mass = 2.0, length = 0.8 }, { mass = 1.0, length = 0.6, com = 0.25, inertia = 0.04 }]
[planner]
objective = "newton"
[task]
start = [0, "pi/4", 0, "pi/4", 0]
goal = ["-pi/4", "pi/3", "pi/6", "pi/6", 0]
[[legs]]
stratum = "S12"
method = "lie"
goal = [0, "pi/4", "pi/6", "*", "-pi/24"]
[[legs]]
stratum = "S3"
"""  # (leg 2 moves q4: were it locked there, q4 at the via would take the goal's value)


def test_a_failed_lie_leg_names_the_free_coordinate_that_drifted():
    """A trial's two-arm Lie leg with q4 free ("*") drifted it to 3.95 rad and failed (given a
    value, it planned in 11 steps): the message says so first."""
    import stratcli

    plan = stratcli.plan(CRAB, check=False)
    assert not plan.ok
    assert "free coordinates drifted (q4 0.785 -> " in plan.message
    assert "give them values in the leg's goal, or try a smaller lie.gamma" in plan.message
    given = stratcli.plan(CRAB.replace('"pi/6", "*", "-pi/24"', '"pi/6", "pi/6", "-pi/24"'))
    assert given.ok and "drifted" not in given.message


def test_a_hybrid_plans_note_says_what_its_newton_legs_iterations_count(scenarios_dir):
    """Sim 3 under the energy objective: its Newton legs come from the energy plan and need
    no polish, so the table shows 0 iterations, which a new user read as unexplained."""
    from stratcli.api import plan_run

    plan = plan_run(load_scenario(scenarios_dir / "sim3_hybrid.toml"), check=False).result
    (note,) = [n for n in plan.notes if "applied to the Newton legs only" in n]
    assert note.endswith("(a Newton leg's iterations are its polish from there: 0 where it "
                         "reached its goal as it was)")  # fmt: skip
    assert [leg.iterations for leg in plan.legs if leg.method == "newton"] == [0, 0]


def test_a_lie_leg_failing_either_way_keeps_the_energy_objectives_newton_legs(scenarios_dir):
    """Sim 3 with lie.max_steps = 6: its Lie leg fails from the minimum-energy Newton legs,
    and the plan was swapped for the paper's leg-by-leg one (legs 927.89 and 299.31 where they
    had been 95.56 and 125.63), whose Lie leg failed too, the note blaming the method; and the
    advice said lie.degree = 3 to a scenario that had set it."""
    from stratcli.api import plan_run

    task = load_scenario(scenarios_dir / "sim3_hybrid.toml")
    short = task.with_changes({"planner.lie.max_steps": 6})
    plan = plan_run(short, check=False).result
    full = plan_run(task, check=False).result
    assert not plan.ok and plan.legs[2].status.key == "lie_not_converged"
    assert any("applied to the Newton legs only" in n for n in plan.notes)
    for leg, energy_plan_leg in zip(plan.legs[:2], full.legs[:2], strict=True):
        assert leg.energy == pytest.approx(energy_plan_leg.energy, rel=1e-9)
    assert "lie.degree = 3" not in plan.message and "more lie.max_steps" in plan.message


def test_a_lie_step_of_a_whole_basis_period_is_refused_on_loading():
    """Sim 3 with lie.step_duration = 2.17, the basis period: its steps' controls end as they
    start, so the first cannot continue leg 2's and end at rest; planning failed with
    "boundary conditions are inconsistent" and the advice to move a via, and the summary
    showed a control jump of 0.66 at a switch to a leg with no controls."""
    from conftest import ROOT

    from stratcli.errors import InputError
    from stratcli.scenario import load_scenario

    text = (ROOT / "scenarios" / "sim3_hybrid.toml").read_text()
    with pytest.raises(InputError) as info:
        load_scenario(text.replace("step_duration = 0.51", "step_duration = 2.17", 1))
    (problem,) = info.value.problems
    assert problem.path == "planner.lie.step_duration"
    assert problem.message.startswith("leg 3's Lie steps last 2.17 s, 1 basis period of 2.17 s")
    load_scenario(text.replace("step_duration = 0.51", "step_duration = 2.0", 1))
    with pytest.raises(InputError):  # nearly a period: as inconsistent for the planner
        load_scenario(text.replace("step_duration = 0.51", "step_duration = 2.171", 1))


def test_a_switch_to_a_leg_without_controls_has_no_jump_to_measure():
    """A leg that failed before its first step has no controls: its switch was measured
    against zero controls (a jump of 0.66 in the summary line); it is not a number."""
    from stratcli.stratified import assemble

    plan = plan_sequence(
        preset("one-arm"),
        np.array([0.0, np.pi / 4, 0.0, 0.0]),
        [
            LegSpec("S3", np.array([-np.pi / 3, np.pi / 3, 0.0, 0.0])),
            LegSpec("S1", np.array([-np.pi / 3, np.pi / 3, np.pi / 4, -np.pi / 12])),
        ],
        PlannerSettings(objective="newton"),
    )
    legs = [plan.legs[0], replace(plan.legs[1], pieces=())]
    specs = [LegSpec(leg.stratum, leg.goal) for leg in plan.legs]
    again = assemble(plan.system, plan.settings, plan.start, specs, legs)
    (switch,) = again.switches
    assert np.all(np.isnan(switch.jump)) and np.all(np.isnan(switch.jump_derivative))
    assert np.all(np.isfinite(plan.switches[0].jump))  # a leg with controls: measured


def test_a_plan_whose_leg_has_no_controls_writes_its_record(tmp_path):
    """Its switch's jump is null in result.json, and run.mcap took abs() of it: a TypeError
    traceback and no record for a Lie leg that failed before its first step."""
    import dataclasses

    from conftest import ROOT

    import stratcli
    from stratcli.api import plan_run
    from stratcli.stratified import assemble

    task = load_scenario(ROOT / "scenarios" / "sim4_task_d.toml").with_changes(
        {"planner": {"objective": "newton"}}
    )
    outcome = plan_run(task, check=False)
    plan = outcome.result
    legs = [plan.legs[0], replace(plan.legs[1], pieces=(), status=Status.NUMERICAL_FAILURE)]
    failed = assemble(plan.system, plan.settings, plan.start, list(task.legs), legs)
    failed = replace(failed, scenario=plan.scenario, scenario_text=plan.scenario_text)
    broken = dataclasses.replace(outcome, result=failed, document=failed.to_dict())
    run = stratcli.write_record(tmp_path, broken)
    doc = stratcli.load_run(run).to_dict()
    assert doc["status"] == "failed" and all(v is None for v in doc["switches"][0]["jump"].values())
    assert (run / "run.mcap").stat().st_size > 0


def test_a_lie_leg_that_swings_a_joint_far_says_so_and_sim3s_does_not():
    """A Lie leg asked to move q3 by 0.1 rad swung q2 through 9 rad (3237 where Newton legs
    cost tens), with no word; Sim 3's own Lie leg stays close and is not noted."""
    from conftest import ROOT

    text = (ROOT / "scenarios" / "sim3_hybrid.toml").read_text()
    quiet = plan_sequence(*_planned_args(load_scenario(text)))
    assert not any("swings" in n for n in quiet.notes)
    far = load_scenario(LIE_MID)
    plan = plan_sequence(*_planned_args(far))
    (note,) = [n for n in plan.notes if "(Lie-algebraic) swings" in n]
    assert note.startswith("leg 2 (Lie-algebraic) swings q2 through")
    assert 'a Newton leg (method = "newton") may cost far less' in note


def _planned_args(task):
    return task.system, task.start, list(task.legs), task.settings


LIE_MID = """
name = "lie_mid"
[model]
kind = "preset"
name = "one-arm"
[task]
start = [0, "pi/4", 0, 0]
goal = ["-pi/3", "pi/3", "pi/4", "-pi/12"]
[planner]
continuity = "lr-C1"
soft_start = true
full_stop = true
lie = { degree = 3 }
[[legs]]
stratum = "S3"
goal = ["-pi/3", "pi/3", 0, "-pi/12"]
[[legs]]
stratum = "S1"
goal = ["-pi/3", "pi/3", 0.1, -0.2]
method = "lie"
[[legs]]
stratum = "S1"
"""


def test_each_lie_step_is_the_cheapest_combination_not_the_first_found(scenarios_dir):
    """Newton's method on the step's optimality conditions (exact Hessians) lowers every
    step of Sim 3's Lie leg well below the first solution found (at most 0.6 of its energy;
    0.08-0.55 as planned): its Hessian's sign flipped, 7 of 8 steps kept the first one."""
    from stratcli.planners import lie

    lowered = []
    cheapest = lie._StepSolver.cheapest

    def recorded(self, z, max_iter=30):
        out = cheapest(self, z, max_iter)
        lowered.append(self.energy(out) / self.energy(z))
        return out

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(lie._StepSolver, "cheapest", recorded)
        plan = plan_sequence(*_planned_args(load_scenario(scenarios_dir / "sim3_hybrid.toml")))
    assert plan.ok and len(lowered) >= 4
    assert max(lowered) <= 0.6, lowered
