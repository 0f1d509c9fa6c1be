"""Sequences of legs: tolerances, determinism, time scaling, planners × continuity modes."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import (
    ROOT,
    plan_document,
    weak_stratum_scenario,
)
from reintegrate import PRINTED, reintegrate, verify

import stratcli
from stratcli.continuity import mode_order
from stratcli.models.presets import preset
from stratcli.planners import PLANNERS, LegPlanner, NewtonPlanner, damped_gauss_newton
from stratcli.planners.base import COORDINATE_RUNAWAY, SearchDiverged
from stratcli.records.result import result_document
from stratcli.scenario import load_scenario
from stratcli.sequence import SequencePlan
from stratcli.settings import PlannerSettings
from stratcli.status import Status
from stratcli.stratified import LegSpec, chain_legs
from stratcli.time_scaling import time_scaled


@pytest.mark.parametrize("name", ["sim4_task_d", "sim4_task_b", "sim2"])
def test_tight_tolerance_1e9(scenarios_dir, name):
    task, doc = plan_document(scenarios_dir / f"{name}.toml", tolerance=1e-9)
    assert all(leg["error"] <= 1e-9 for leg in doc["legs"])
    verify(task, doc)


def test_planning_is_deterministic(scenarios_dir):
    _, a = plan_document(scenarios_dir / "sim4_task_a.toml")
    _, b = plan_document(scenarios_dir / "sim4_task_a.toml")
    assert a["total_energy"] == b["total_energy"]
    assert a["legs"][1]["pieces"] == b["legs"][1]["pieces"]


def test_time_scaling_keeps_the_path(task_d):
    _, _, optimal = task_d
    s = 2.5
    fast = time_scaled(optimal, s)
    assert fast.duration == pytest.approx(optimal.duration / s)
    assert fast.total_energy == pytest.approx(optimal.total_energy * s, rel=1e-12)
    doc = result_document(fast, "d", "one-arm")
    assert doc["time_scale"] == s
    replay = reintegrate(doc, lambda stratum, q, u: PRINTED["one-arm"](q, u))
    for leg, again in zip(optimal.legs, replay, strict=True):
        np.testing.assert_allclose(again["end"], leg.end, atol=1e-8)  # same end points
        assert again["energy"] == pytest.approx(leg.energy * s, rel=1e-8)


def test_time_scaling_scales_the_jumps_at_the_switches_as_the_controls():
    """Run s times faster, u is s u(s t) and u' is s² u'(s t): a switch's jumps are those of
    the scaled legs' own controls (checked where they are not zero, continuity "none": a
    plan whose jumps are all zero says nothing of their factor)."""
    task = stratcli.load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")
    task = task.with_changes({"planner": {"continuity": "none", "objective": "newton"}})
    plan = stratcli.plan(task, check=False)
    assert plan.ok and plan.switches
    s = 2.5
    fast = time_scaled(plan, s)
    zero = np.array([0.0])
    for switch, before, after in zip(fast.switches, fast.legs, fast.legs[1:], strict=False):
        u, du = before.end_controls()
        jump, slope = after.controls(zero)[0] - u, after.controls(zero, True)[0] - du
        assert np.abs(slope).max() > 1.0  # not zero: its factor shows
        np.testing.assert_allclose(switch.jump, jump, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(switch.jump_derivative, slope, rtol=1e-12, atol=1e-9)


def test_a_time_scaled_plans_record_re_plans_to_it(tmp_path):
    """A record written from `time_scaled(plan, 2)` said time_scale 2 in result.json but 1
    in its scenario.toml and resolved.json: re-planning it gave the plan before (84.04 over
    2 s, not 168.08 over 1 s)."""
    import json

    plan = stratcli.plan(ROOT / "scenarios" / "sim4_task_d.toml", check=False)
    fast = time_scaled(plan, 2.0)
    assert fast.settings.time_scale == 2.0
    run = stratcli.write_record(tmp_path, fast)
    again = stratcli.plan(run / "scenario.toml", check=False)
    assert again.total_energy == pytest.approx(fast.total_energy, rel=1e-12)
    assert again.duration == pytest.approx(fast.duration, rel=1e-12)
    assert json.loads((run / "resolved.json").read_text())["planner"]["time_scale"] == 2.0
    assert stratcli.load_run(run) == fast
    back = time_scaled(fast, 0.5)  # and back: the scales multiply
    assert back.settings.time_scale == 1.0 and back.total_energy == pytest.approx(plan.total_energy)


def test_every_planner_and_continuity_mode_reaches_its_goals(small_plan):
    """Newton legs and a Lie leg among Newton legs, under every continuity mode: every goal
    is reached on independent re-integration, legs chain, switches keep what the mode
    promises (`verify`)."""
    assert small_plan.plan.ok, small_plan.plan.message
    doc = small_plan.doc
    assert doc["continuity"] == small_plan.continuity
    assert [leg["method"] for leg in doc["legs"]] == [leg.method for leg in small_plan.legs]
    verify(small_plan.task, doc)


def test_switch_jumps_follow_the_continuity_mode(small_plan):
    """C0 modes make the promised inputs continuous at every switch, C1 modes their
    derivatives too; the Lie leg's steps join each other like the switches do."""
    doc = small_plan.doc
    order = mode_order(small_plan.continuity)
    for sw in doc["switches"]:
        nxt = doc["legs"][sw["after_leg"] + 1]["active_inputs"]
        promised = doc["inputs"] if small_plan.continuity.startswith("lr") else nxt
        jump = max(abs(sw["jump"][u]) for u in promised)
        slope = max(abs(sw["jump_derivative"][u]) for u in promised)
        assert jump <= 1e-9 or order < 0, (sw, jump)
        assert slope <= 1e-9 or order < 1, (sw, slope)
    if small_plan.planner == "lie" and order >= 0:
        from test_planners_lie import _pieces_join

        (lie_leg,) = [leg for leg in doc["legs"] if leg["method"] == "lie"]
        assert len(lie_leg["pieces"]) >= 2
        assert _pieces_join(doc, lie_leg, order) <= 1e-9


# ---------------------------------------------------------------------------------------------
# Status, not tracebacks: a planner that breaks down numerically fails its leg
# ---------------------------------------------------------------------------------------------


@pytest.fixture
def breaking_planner():
    """A third planner, one class that registers itself: it raises what numerical code
    raises. Unregistered after the test."""

    class Breaking(LegPlanner):
        method = "breaking-test"

        def plan(self, problem):
            raise np.linalg.LinAlgError("Singular matrix")

        def missing_coefficients(self, problem):
            return 1, 0

    yield Breaking
    PLANNERS.pop(Breaking.method)


def test_a_numerical_breakdown_is_a_failed_leg_with_its_status(breaking_planner):
    system = preset("one-arm")
    start = np.zeros(4)
    legs = [
        LegSpec("S3", np.array([0.1, 0.2, 0.0, np.nan])),
        LegSpec("S1", np.array([0.0, 0.3, 0.2, np.nan]), method="breaking-test"),
    ]
    plan = chain_legs(system, start, legs, PlannerSettings(objective="newton"))
    assert [leg.status for leg in plan.legs] == [Status.SUCCESS, Status.NUMERICAL_FAILURE]
    assert not plan.ok and plan.status is Status.NUMERICAL_FAILURE
    assert plan.message.startswith("leg 2 on S1 was stopped by a numerical failure")
    assert "LinAlgError: Singular matrix" in plan.message
    doc = plan.to_dict()  # a record can still be written: nothing non-finite in the JSON
    assert doc["status"] == "failed" and doc["legs"][1]["status"] == "numerical_failure"
    assert doc["legs"][1]["error"] is None and doc["legs"][1]["pieces"] == []
    assert SequencePlan.from_dict(doc).to_dict() == doc


class _Patient(LegPlanner):
    """A planner of a user's own (README "Your own leg planner"): Newton with other settings,
    counting its legs. Only `method`, `plan` and `missing_coefficients` are required."""

    method = "patient-test"
    legs = 0

    def __init__(self, **overrides):
        self.inner = NewtonPlanner(**({"max_iterations": 300, "restarts": 20} | overrides))

    def plan(self, problem):
        type(self).legs += 1
        return self.inner.plan(problem)

    def missing_coefficients(self, problem):
        return self.inner.missing_coefficients(problem)


# defining it registered it, at collection: other modules' tests would see it (a scenario's
# unknown method then listed 'patient-test' among the choices); registered by the fixture only
PLANNERS.pop(_Patient.method)


@pytest.fixture
def patient_planner():
    _Patient.legs = 0
    PLANNERS[_Patient.method] = _Patient
    yield _Patient
    PLANNERS.pop(_Patient.method)


@pytest.mark.parametrize("objective", ["newton", "energy"])
def test_a_planner_of_ones_own_plans_the_legs_that_name_it(
    scenarios_dir, patient_planner, objective
):
    task = load_scenario(scenarios_dir / "sim4_task_d.toml")
    legs = [{"stratum": leg.stratum, "method": "patient-test"} for leg in task.legs]
    for entry, leg in zip(legs[:-1], task.legs, strict=False):
        entry["goal"] = [None if g != g else float(g) for g in leg.goal]
    mine = task.with_changes({"legs": legs, "planner": {"objective": objective}})
    plan = stratcli.plan(mine)
    assert plan.ok and [leg.method for leg in plan.legs] == ["patient-test"] * len(legs)
    assert patient_planner.legs == len(legs)  # it planned them, once each
    verify(mine, plan.to_dict())  # re-integrated independently: every leg at its goal
    # its outcomes left strategy at its default, "newton": recorded as what planned them,
    # and the record valid by stratplan's own schema (a strategy of its own was refused)
    assert [leg["strategy"] for leg in plan.to_dict()["legs"]] == ["patient-test"] * len(legs)
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(plan.to_dict(), stratcli.record_schema("result"))
    notes = " ".join(plan.notes)
    if objective == "energy":  # not a Lie leg: the note names the method
        assert "does not apply: every leg uses method 'patient-test'" in notes
        assert "Lie" not in notes
    else:
        assert not notes


def test_a_planner_of_ones_own_cannot_take_a_builtin_name_or_a_bad_one():
    """A user's class with method = "newton" replaced the built-in for the whole process
    (task D: 256.12 instead of 84.04), silently; so did a NewtonPlanner subclass that named
    no method (it inherited "newton"); 3 and "Bad Name" were registered."""
    for name in ("newton", "lie"):
        with pytest.raises(ValueError, match=rf"^Mine.method: '{name}' is stratplan's own"):
            type("Mine", (LegPlanner,), {"method": name})
    for bad in (3, "Bad Name", "", "1st"):
        with pytest.raises(TypeError, match=r"^Mine.method: must be a lowercase name"):
            type("Mine", (LegPlanner,), {"method": bad})
    type("Quiet", (NewtonPlanner,), {})  # no method of its own: registers nothing
    assert PLANNERS["newton"] is NewtonPlanner and PLANNERS["lie"].__name__ == "LiePlanner"


def _own(plan, name="contract-test"):
    """A user's planner (registered for one test) whose `plan` is `plan`."""

    def missing(self, problem):
        return NewtonPlanner().missing_coefficients(problem)

    return type(
        "Own", (LegPlanner,), {"method": name, "plan": plan, "missing_coefficients": missing}
    )


@pytest.fixture
def own_planner():
    made = []

    def make(plan):
        made.append(_own(plan))
        return made[-1]

    yield make
    PLANNERS.pop("contract-test", None)


def _task_d_with(method):
    task = load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")
    legs = [
        {"stratum": "S3", "goal": ["-pi/3", "pi/3", 0, "-pi/12"]},
        {"stratum": "S1", "method": method},
    ]
    return task.with_changes({"legs": legs, "planner": {"objective": "newton"}})


def test_a_planner_that_claims_its_goal_is_checked_by_the_end_point_map(own_planner):
    """A planner returning zero controls with the goal as its end was "ok", error 0.00,
    while its path ended 0.785 rad from the goal."""
    from stratcli.planners import LegOutcome
    from stratcli.results import Piece

    def lying(self, problem):
        zero = np.zeros((len(problem.stratum.active), problem.basis.size))
        piece = Piece(0.0, problem.duration, zero)
        return LegOutcome((piece,), problem.goal, 0.0, 1, 1, Status.SUCCESS, 0, "quadrature")

    own_planner(lying)
    plan = stratcli.plan(_task_d_with("contract-test"))
    leg = plan.legs[1]
    assert not plan.ok and leg.status is Status.NOT_CONVERGED
    assert leg.error == pytest.approx(np.pi / 4, rel=1e-6)  # q3: 0 -> pi/4 not moved
    assert (
        "leg planner 'contract-test' (Own.plan) reported its goal reached, but its " in leg.message
    )
    np.testing.assert_allclose(leg.end, leg.start, atol=1e-12)  # where its controls end


def test_a_planners_wrong_outcome_or_own_bug_is_named_not_a_numerical_failure(own_planner):
    own_planner(lambda self, problem: None)
    with pytest.raises(
        TypeError,
        match=r"^leg planner 'contract-test' \(Own.plan\) returned NoneType, not a LegOutcome "
        r"\(planning leg 2 on S1\)$",
    ):
        stratcli.plan(_task_d_with("contract-test"))
    PLANNERS.pop("contract-test")

    def buggy(self, problem):
        raise RuntimeError("my bug")

    own_planner(buggy)
    with pytest.raises(RuntimeError) as caught:  # its own, not a "numerical failure"
        stratcli.plan(_task_d_with("contract-test"))
    assert str(caught.value) == "my bug"
    assert caught.value.__notes__ == [
        "raised by leg planner 'contract-test' (Own.plan) planning leg 2 on S1"
    ]


def _escaping(z, jacobian):
    """e = exp(-z): every step lowers the error and pushes the end point z farther out."""
    e = np.exp(-z)
    return e, (e[None, :] if jacobian else None), (z.copy(), z.copy())


def test_a_runaway_search_raises_with_the_coordinate():
    with pytest.raises(SearchDiverged) as caught:
        damped_gauss_newton(_escaping, np.zeros(1), tolerance=0.0, max_iterations=10_000, mu=1e-6)
    assert caught.value.coordinate == 0 and "farther out" in caught.value.detail
    assert "after" in caught.value.detail  # the iterations it took, bounded by the limit


def test_refused_full_steps_cost_no_jacobian_and_the_iterates_are_the_same():
    """With `lazy`, on a residual whose Gauss-Newton step overshoots (cube roots: the full
    step lands at -2x) the search asks no Jacobian with the next full step after one was
    refused, so fewer Jacobians are thrown away than full steps refused; the path is the one
    a search given every Jacobian takes, to the bit."""

    def make(always):
        log = []  # (asked for the Jacobian, accepted, first trial after an acceptance)
        state = {"err": np.inf, "new": True}

        def cube_roots(z, jacobian):
            x = z - np.array([1.0, -0.5])
            e = -np.array([np.cbrt(x[0]), x[1]])  # -residual; J = -de/dz as the search expects
            err = float(np.linalg.norm(e))
            accepted = err < state["err"]
            if err != state["err"]:  # (not the accepted point asked again for its Jacobian)
                log.append((jacobian, accepted, state["new"]))
                state["new"] = accepted
                state["err"] = min(err, state["err"])
            with np.errstate(divide="ignore"):  # (at the root itself: not used there)
                J = np.diag([1.0 / (3.0 * np.cbrt(x[0]) ** 2), 1.0])
            return e, (J if jacobian or always else None), (z.copy(), z.copy())

        return cube_roots, log

    lazy, log = make(False)
    eager, _ = make(True)
    kwargs = dict(tolerance=1e-6, max_iterations=200, mu=1e-10, diverged=lambda _: None, lazy=True)
    a = damped_gauss_newton(lazy, np.array([4.0, 3.0]), **kwargs)
    b = damped_gauss_newton(eager, np.array([4.0, 3.0]), **kwargs)
    assert a.error <= 1e-6 and np.array_equal(a.z, b.z) and a.iterations == b.iterations
    refused_full = sum(1 for _, accepted, first in log[1:] if first and not accepted)
    thrown_away = sum(1 for asked, accepted, _ in log[1:] if asked and not accepted)
    assert refused_full >= 3  # the residual makes the search refuse full steps
    assert thrown_away < refused_full


def test_a_runaway_check_of_the_caller_stops_the_loop_with_its_reason():
    def far(payload):
        return "too far" if payload[1][0] > 5.0 else None

    out = damped_gauss_newton(
        _escaping, np.zeros(1), tolerance=0.0, max_iterations=10_000, mu=1e-6, diverged=far
    )
    assert out.diverged == "too far" and out.iterations < 20 and out.z[0] <= 10.0


def test_the_weak_stratum_runaway_is_abandoned_as_diverged():
    """Issue 14: the 4-link arm turning its base 90° on S12 with q3, q4 free winds q3 by
    more than 100 rad (it took 13.7 s and ended at q3 = -106 before): now abandoned."""
    task = load_scenario(weak_stratum_scenario(theta="90deg"))
    plan = chain_legs(task.system, task.start, task.legs, task.settings)
    leg = plan.legs[0]
    assert leg.status is Status.DIVERGED and plan.status is Status.DIVERGED
    assert plan.message.startswith("leg 1 on S12 was abandoned: the search diverged (q3 reached")
    assert f"(limit {COORDINATE_RUNAWAY:g})" in plan.message
    assert "try another stratum" in plan.message and "auto mode" in plan.message
    assert plan.to_dict()["legs"][0]["status"] == "diverged"
    # no plan: no energy (it was the zero controls' 0.0), and the iterations it ran
    assert np.isnan(leg.energy) and plan.to_dict()["legs"][0]["energy"] is None
    assert f"after {leg.iterations} iterations" in plan.message and leg.iterations > 0


def test_the_weak_stratum_with_a_small_turn_still_plans():
    """The same arm turning 10° winds q3 about 7 rad: not a runaway."""
    task = load_scenario(weak_stratum_scenario())
    plan = chain_legs(task.system, task.start, task.legs, task.settings)
    assert plan.ok and abs(plan.legs[0].end[2]) < COORDINATE_RUNAWAY
