"""Auto mode (plan_auto, compare_sequences) under a [constraints] table, and re-timing a plan
that carries a constraints report (`time_scaled`)."""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import numpy as np
import pytest
from reintegrate import verify
from test_planners_constrained import _dense, _self_clearance

import stratcli

ROOT = Path(__file__).resolve().parents[1]
LIMITS = {"joint_limits": [-2.5, 2.5], "self_collision": True, "clearance": 0.05}


def _auto(objective: str, **constraints):
    """Sim 4 in auto mode, sequences of up to 2 strata, under the given constraints."""
    task = stratcli.load_scenario(ROOT / "scenarios" / "sim4_auto.toml")
    changes = {"decompose": {"max_length": 2}, "planner": {"objective": objective}}
    return task.with_changes({**changes, "constraints": {**LIMITS, **constraints}})


@pytest.mark.slow
@pytest.mark.parametrize("objective", ["energy", "newton"])
def test_auto_mode_chooses_a_plan_within_the_limits(objective):
    free = stratcli.plan_auto(_auto(objective).with_changes({"constraints": None}), jobs=2)
    q_free = _dense(free.best.task, free.best.document)
    assert np.abs(q_free[:, :3]).max() > 2.5  # the unconstrained choice breaks the limits
    task = _auto(objective)
    outcome = stratcli.plan_auto(task, jobs=2)
    plan = outcome.best.result
    assert plan.ok, plan.message
    assert plan.constraints is not None and plan.constraints.ok
    assert outcome.best.document["constraints"]["legs"]
    verify(outcome.best.task, outcome.best.document)  # goals reached on re-integration
    q = _dense(outcome.best.task, outcome.best.document)
    assert np.abs(q[:, :3]).max() <= 2.5 + 1e-6
    robot = task.system.robot
    assert _self_clearance(robot, q, 0.05).min() >= 0.05 - 1e-6
    # within the limits costs energy: never below the free choice's (the same duration)
    assert plan.total_energy >= free.best.result.total_energy * (1 - 1e-9)
    # every candidate the comparison kept as reaching the goal is within the limits too
    for o in outcome.comparison.outcomes:
        if o.plan is not None and o.plan.ok:
            assert o.plan.constraints is not None and o.plan.constraints.ok


def test_a_rate_limit_in_auto_mode_slows_the_chosen_plan_and_says_so():
    task = _auto("energy", max_rate=0.5).with_changes(
        {"constraints": {"joint_limits": None, "self_collision": False, "clearance": 0.0}}
    )
    outcome = stratcli.plan_auto(task, jobs=1, time_scale=2.0)
    plan = outcome.best.result
    assert plan.ok, plan.message
    peak = max(np.abs(p.controls(np.linspace(0, p.duration, 4001))).max() for p in plan.legs)
    assert peak <= 0.5 * (1 + 1e-9)
    assert plan.constraints.duration_set_by.startswith("the rate limit of")
    assert any("the time scale 2 asked for is too fast" in n for n in plan.notes)
    # the notes for the user (compare-sequences prints them under its ranking) say how much
    # the best was slowed, at the speed it runs at
    slowed = [n for n in outcome.notes if n.startswith("slowed")]
    assert slowed and slowed == [n for n in plan.notes if n.startswith("slowed")]
    compared = stratcli.compare_sequences(task, jobs=1)
    assert [n for n in compared.notes if n.startswith("slowed")] == [
        n for n in compared.best.result.notes if n.startswith("slowed")
    ]
    # the ranking measures every candidate as it will run: slowed by its own factor
    best = compared.comparison.best
    assert compared.notes and best.duration > 10 * best.plan.duration
    assert compared.best.result.duration == pytest.approx(best.duration, rel=1e-9)
    assert best.peak_control == pytest.approx(0.5, rel=1e-6)


def test_a_duration_ranking_sees_each_candidates_slow_down():
    task = _auto("energy", max_rate=0.5).with_changes(
        {
            "decompose": {"criterion": "duration"},
            "constraints": {"self_collision": False, "clearance": 0.0},
        }
    )
    outcome = stratcli.compare_sequences(task, jobs=1)
    ok = [o for o in outcome.comparison.outcomes if o.ok]
    assert len({round(o.plan.duration, 9) for o in ok}) == 1  # all planned over 2 s
    shortest = min(o.duration for o in ok)
    assert outcome.comparison.best.duration == shortest  # as run: each slowed differently
    assert outcome.best.result.duration == pytest.approx(shortest, rel=1e-9)


def test_time_scaled_verifies_a_constrained_plan_again():
    plan = stratcli.plan(ROOT / "scenarios" / "sim4_task_d_rate_limited.toml")
    assert plan.ok
    slower = stratcli.time_scaled(plan, 0.5)
    assert slower.ok and slower.constraints.legs[0].rate > 0.2  # half the speed: room
    assert plan.constraints.duration_set_by and not slower.constraints.duration_set_by
    # its "slowed ...x to meet ..." note is history now: a note says what set the duration
    assert slower.notes == (*plan.notes, "then time-scaled by 0.5: its duration is this "
                            "call's, not a limit's")  # fmt: skip
    faster = stratcli.time_scaled(plan, 10)
    assert not faster.ok
    assert faster.status is stratcli.Status.CONSTRAINT_VIOLATED
    assert "violates the rate limit of" in faster.message
    assert re.search(r"rad/s\) by [0-9.e+-]+ rad/s at t = ", faster.message)  # with its unit
    # the first violation named, the others counted (a worse one on a later leg went unsaid)
    # (10x faster: every leg's rates 10x and accelerations 100x, over both limits)
    more = "leg 1's acceleration limit, leg 2's rate limit, leg 2's acceleration limit"
    assert re.search(rf"at t = [0-9.]+ s \(and 3 more limits: {more}\)", faster.message)
    assert "this plan time_scaled again by" in faster.message  # the factor for this plan
    # the advice is to run it slower, by how much (not the vias or harmonics of a plan that
    # was planned off its limits: joint limits and clearances do not change with the speed)
    assert "via configurations" not in faster.message
    found = re.search(r"time_scaled by 10, where at most ([0-9.e+-]+) meets every rate and "
                      r"acceleration limit \(this plan time_scaled again by at most "
                      r"([0-9.e+-]+)\)", faster.message)  # fmt: skip
    given, factor = float(found[1]), float(found[2])
    # exactly 1 and 0.1: the plan ran at its rate limit, sped up 10 times (a new user was
    # offered 0.499 for 2 times, the exact 0.5 rounded down from 0.49999999999999994); the
    # first factor is the plan given time_scaled's (a user re-times that one, and was
    # offered the second, which slowed it 10x more than needed)
    assert given == 1.0 and stratcli.time_scaled(plan, given).ok
    assert factor == 0.1 and stratcli.time_scaled(faster, factor).ok
    assert faster.to_dict()["constraints"]["violated"]
    # re-timed again while failed: the message is this re-timing's (it kept the first's)
    still = stratcli.time_scaled(faster, 0.5)  # 5x the plan: still too fast
    assert not still.ok and still.message.startswith(still.constraints.violated)
    assert still.message.endswith(
        "time_scaled by 0.5, where at most 0.1 meets every rate and acceleration limit (this "
        "plan time_scaled again by at most 0.2)"
    )
    # slowed back within the limit: ok, and no message of the violation left behind
    back = stratcli.time_scaled(faster, 0.1)
    assert back.ok and back.message == "" and back.to_dict()["status"] == "ok"
    assert back.constraints.legs[0].rate == pytest.approx(plan.constraints.legs[0].rate, abs=1e-6)


@pytest.mark.slow
def test_when_no_candidate_keeps_the_limits_the_failed_best_is_still_time_scaled():
    task = _auto("energy", joint_limits=[-1.1, 1.1])
    outcome = stratcli.plan_auto(task, jobs=2, time_scale=2.0)
    plan = outcome.best.result
    assert not outcome.ok and not plan.ok
    assert plan.time_scale == 2.0 and plan.constraints is not None and plan.constraints.violated
    from stratcli.api.auto import auto_choice

    sentence = auto_choice(outcome)
    assert "no sequence stayed within the limits" in sentence and "chose no" not in sentence


@pytest.mark.slow
def test_newton_auto_mode_counts_a_candidate_done_after_its_limits(monkeypatch):
    from stratcli import trie

    seen, during = [], []
    original = trie._plan_within_limits

    def spy(unit):  # the second pass, in this process (jobs=1): progress so far
        during.append(seen[-1][0])
        return original(unit)

    monkeypatch.setattr(trie, "_plan_within_limits", spy)
    task = _auto("newton")
    outcome = stratcli.compare_sequences(
        task, jobs=1, progress=lambda done, total: seen.append((done, total))
    )
    moved = [o.plan for o in outcome.comparison.outcomes if o.plan is not None and o.plan.ok]
    moved = [p for p in moved if any(n.startswith("constrained search from") for n in p.notes)]
    assert moved  # legs the second pass re-chained carry its search's iterations, not 0
    legs = [leg for p in moved for leg in p.legs]
    assert all(leg.strategy == "constrained" and leg.iterations > 0 for leg in legs)
    total = seen[-1][1]
    assert during and max(during) < total  # not shown finished while it is being moved inside
    assert seen[-1] == (total, total)
    assert all(a[0] <= b[0] for a, b in itertools.pairwise(seen))


@pytest.mark.slow  # two comparisons of 18 constrained candidates: ~20 s
def test_a_candidate_that_stalls_in_the_default_basis_is_planned_with_more_harmonics():
    """Sim 4 in auto mode within ±2.5 rad and self-collision: (S1, S3, S1) and (S1, S3, S2)
    stall on self-collision with the default 3 harmonics and are planned inside the limits
    with 5 (each such plan says so; its pieces are in 5 harmonics); the same choice. With the
    harmonics set by the scenario, they fail as before."""
    task = stratcli.load_scenario(ROOT / "scenarios" / "sim4_auto.toml").with_changes(
        {"constraints": LIMITS}
    )
    outcome = stratcli.compare_sequences(task, jobs=2)

    def more(o) -> bool:
        return o.plan is not None and any(n.startswith("planned with 5") for n in o.plan.notes)

    retried = [o for o in outcome.comparison.outcomes if more(o)]
    assert retried and all(o.ok and o.plan.constraints.ok for o in retried)
    assert all(leg.basis.harmonics == 5 for o in retried for leg in o.plan.legs)
    assert not any(r["status"] == "failed" for r in outcome.document["rows"])
    best = outcome.document["rows"][0]
    assert best["sequence"] == ["S1", "S3"] and best["status"] == "ok"
    kept = stratcli.compare_sequences(
        task.with_changes({"planner": {"basis": {"harmonics": 3}}}), jobs=2
    )
    failed = [r for r in kept.document["rows"] if r["status"] == "failed"]
    assert {tuple(r["sequence"]) for r in failed} == {tuple(o.candidate.sequence) for o in retried}
    assert all("stalled" in r["reason"] for r in failed)
    assert kept.document["rows"][0]["energy"] == best["energy"]


def test_a_candidate_whose_via_touches_an_obstacle_fails_before_planning():
    """A via on an obstacle was searched for 3.4 s (the stall advising more harmonics) and a
    candidate with the same via was bounded as if it could win; a scenario's own via there
    is refused before planning, and so is the candidate's now."""
    obstacle = {"shape": "circle", "centre": [1.63, 0.85], "radius": 0.08}
    task = _auto("newton", clearance=0.02, obstacles=[obstacle])
    outcome = stratcli.compare_sequences(task, jobs=1)
    touched = [o for o in outcome.comparison.outcomes if o.candidate.legs[0].stratum == "S1"]
    assert touched and all(o.status == "failed" and o.plan is None for o in touched)
    for o in touched:
        assert o.reason.startswith("via 1 (after S1): the robot touches an obstacle here: link 3")
