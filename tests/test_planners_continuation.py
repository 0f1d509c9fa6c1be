"""Continuation for hard legs (issue 14, item 1): the two-arm S13 leg Newton cannot reach.

The task: two-arm preset, lr-C1, legs S13 → S34 → S14. The issue gives the start and the S13
via; the next two vias are ours (S34 keeps q3 and q4, S14 keeps q1 and q4; both move the
remaining joints and θ moderately).
"""

from __future__ import annotations

import numpy as np
import pytest
from reintegrate import verify

from stratcli.objectives import plan_sequence
from stratcli.planners.continuation import follow_line
from stratcli.planners.newton import NewtonPlanner
from stratcli.records.result import result_document
from stratcli.scenario import load_scenario
from stratcli.sequence import SequencePlan
from stratcli.stratified import LegStart, chain_legs, leg_problem

START = [0.3002291198512008, 0.9533131223269813, 0.6616456565884643, -0.6595027440225795,
         -0.11990022905326472]  # fmt: skip
VIA_S13 = [0.3002291198512008, -0.5625338799506006, 0.6616456565884643, 0.8258443997376518,
           -0.19248077859060764]  # fmt: skip
VIA_S34 = [-0.5, 0.4, VIA_S13[2], VIA_S13[3], -0.1]  # moves q1, q2, θ
GOAL_S14 = [-0.5, -0.3, 1.2, VIA_S13[3], 0.05]  # moves q2, q3, θ


def hard_task(objective: str):
    return load_scenario(
        {
            "name": "hard-two-arm-leg",
            "model": {"kind": "preset", "name": "two-arm"},
            "task": {"start": START, "goal": GOAL_S14},
            "planner": {"continuity": "lr-C1", "objective": objective},
            "legs": [
                {"stratum": "S13", "goal": VIA_S13},
                {"stratum": "S34", "goal": VIA_S34},
                {"stratum": "S14", "goal": GOAL_S14},
            ],
        }
    )


def test_newton_alone_fails_on_the_hard_leg():
    """The issue's failure, reproduced: plain damped Newton with its restarts stalls."""
    task = hard_task("newton")
    at = LegStart(np.asarray(START, dtype=float))
    planner = NewtonPlanner.from_settings(task.settings, task.legs[0], continuation=False)
    problem = leg_problem(task.system, task.settings, task.legs[0], at, task.legs[1], planner)
    out = planner.plan(problem)
    assert out.error == pytest.approx(0.0666, abs=1e-4)
    assert (out.iterations, out.attempts, out.strategy) == (141, 12, "newton")


@pytest.fixture(scope="module")
def newton_plan():
    task = hard_task("newton")
    return task, chain_legs(task.system, task.start, task.legs, task.settings)


def test_continuation_reaches_the_hard_leg_and_the_task_verifies(newton_plan):
    task, plan = newton_plan
    assert plan.ok, plan.message
    assert [leg.strategy for leg in plan.legs] == ["continuation", "newton", "newton"]
    doc = result_document(plan, "hard", "two-arm")
    assert [leg["strategy"] for leg in doc["legs"]] == ["continuation", "newton", "newton"]
    verify(task, doc)  # independent re-integration: every leg within tolerance


def test_strategy_round_trips_and_defaults_to_newton(newton_plan):
    task, plan = newton_plan
    doc = result_document(plan, "hard", "two-arm")
    again = SequencePlan.from_dict(doc, task.settings)
    assert [leg.strategy for leg in again.legs] == ["continuation", "newton", "newton"]
    for leg in doc["legs"]:
        del leg["strategy"]  # a record written before the field
    assert {leg.strategy for leg in SequencePlan.from_dict(doc, task.settings).legs} == {"newton"}


def test_energy_objective_starts_from_the_continuation_plan(newton_plan):
    task = hard_task("energy")
    _, newton = newton_plan  # = the energy objective's first pass (leg 1 by continuation)
    best = plan_sequence(task.system, task.start, task.legs, task.settings)
    assert best.ok, best.message
    assert best.optimisation.newton_energy == pytest.approx(newton.total_energy)
    assert best.total_energy <= newton.total_energy
    verify(task, result_document(best, "hard", "two-arm"))


def test_follow_line_is_bounded_when_the_goal_is_out_of_reach():
    """A goal no control reaches: the continuation stops within its budgets."""

    def evaluate_for(aim):
        def evaluate(z, jacobian):  # reachable set: the unit disc's x axis only
            end = np.array([np.tanh(z[0]), 0.0])
            J = np.array([[1.0 - np.tanh(z[0]) ** 2, 0.0], [0.0, 0.0]])
            return aim - end, J if jacobian else None, end

        return evaluate

    out = follow_line(
        evaluate_for,
        np.zeros(2),
        np.zeros(2),
        np.array([0.5, 1.0]),
        1e-3,
        rng=np.random.default_rng(0),
        max_steps=30,
        max_iterations=200,
    )
    assert not out.reached and out.steps <= 30 and out.iterations <= 200
    assert out.kicks >= 1


def test_a_continuation_that_fails_too_is_said_and_not_counted_as_an_attempt(monkeypatch):
    """The attempts reported are Newton's (restarts + 1); a continuation that followed them
    and failed as well is named in the leg's message, which the failure sentence quotes."""
    import stratcli.planners.newton as newton

    monkeypatch.setattr(newton, "CONTINUATION_BUDGET", 0.01)  # too few steps to get there
    task = hard_task("newton")
    at = LegStart(np.asarray(START, dtype=float))
    planner = NewtonPlanner.from_settings(task.settings, task.legs[0], continuation=True)
    problem = leg_problem(task.system, task.settings, task.legs[0], at, task.legs[1], planner)
    out = planner.plan(problem)
    assert out.error > problem.tolerance and out.strategy == "newton"
    assert out.attempts == task.settings.restarts + 1
    # the leg's own message reads alone (a notebook prints it without the plan's sentence)
    assert out.message.startswith("the last ") and " iterations were a continuation" in out.message
    plan = chain_legs(task.system, task.start, task.legs, task.settings)
    assert not plan.ok
    assert f"in {task.settings.restarts + 1} attempts (" in plan.message
    assert "a continuation along the line to the goal, which did not reach it" in plan.message


def test_two_stalled_attempts_hand_the_leg_to_a_short_continuation(monkeypatch):
    """Sim 4 task A's S2 leg: Newton's first two attempts stall; a short continuation
    (`EARLY_STEPS` steps, `EARLY_BUDGET` attempts' iterations) reaches the goal before any
    blind restart, and in fewer iterations than the restarts took to find one (the sixth
    attempt did)."""
    import stratcli.planners.newton as newton

    task = load_scenario("scenarios/sim4_task_a.toml")
    plan = chain_legs(task.system, task.start, task.legs, task.settings)
    assert [leg.strategy for leg in plan.legs] == ["newton", "continuation"]
    verify(task, result_document(plan, "a", "one-arm"))  # independent re-integration
    first = plan.legs[0]
    at = LegStart(first.end, first.end_controls(), first.duration, 1)  # as chain_legs

    def plan_leg():
        planner = NewtonPlanner.from_settings(task.settings, task.legs[1])
        problem = leg_problem(task.system, task.settings, task.legs[1], at, None, planner)
        return problem, planner.plan(problem)

    problem, early = plan_leg()
    early_after = newton.EARLY_CONTINUATION
    assert (early.attempts, early.strategy) == (early_after, "continuation")
    assert early.error <= problem.tolerance
    monkeypatch.setattr(newton, "EARLY_CONTINUATION", task.settings.restarts + 2)  # never
    _, late = plan_leg()
    assert late.strategy == "newton" and late.attempts > early_after + 1
    assert late.error <= problem.tolerance
    assert early.iterations < late.iterations
