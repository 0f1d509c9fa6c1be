"""Leg durations as decision variables: the budget is met exactly, the energy does not rise
above equal durations, and the plan re-integrates to every goal with continuous controls."""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from reintegrate import controls, rhs_for, verify
from scipy.integrate import solve_ivp
from typer.testing import CliRunner

from stratcli import load_scenario, record_schema, time_scaled
from stratcli.api import plan_run
from stratcli.cli import app
from stratcli.durations import shares
from stratcli.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()


def _task_d(**planner) -> dict:
    raw = tomllib.loads((ROOT / "scenarios" / "sim4_task_d.toml").read_text())
    raw["planner"].update(planner)
    return raw


def test_shares_meet_the_budget_and_stay_positive():
    rng = np.random.default_rng(3)
    for k in range(1, 6):
        d = shares(rng.normal(scale=5.0, size=k - 1), 2.5)
        assert d.sum() == pytest.approx(2.5, abs=1e-12)
        assert np.all(d > 0)
    np.testing.assert_allclose(shares(np.zeros(2), 3.0), [1.0, 1.0, 1.0])


def test_optimised_durations_beat_equal_ones_and_verify_independently():
    task = load_scenario(_task_d(durations="optimise", total_duration=2.0))
    outcome = plan_run(task, check=False)
    plan = outcome.result
    assert plan.ok, plan.message
    assert sum(leg.duration for leg in plan.legs) == pytest.approx(2.0, abs=1e-9)
    equal = plan_run(load_scenario(_task_d()), check=False).result  # 1 s + 1 s
    assert plan.total_energy <= equal.total_energy * (1 + 1e-9)
    assert any(note.startswith("durations optimised within the 2 s budget") for note in plan.notes)
    verify(task, outcome.document)  # goals, chaining, energies, continuity at the switch
    # no budget given: the legs' own sum, which is no limit (a rate limit may slow past it)
    unbounded = plan_run(load_scenario(_task_d(durations="optimise")), check=False).result
    assert unbounded.total_energy == pytest.approx(plan.total_energy, rel=1e-12)
    assert any(
        n.startswith("durations optimised within the legs' 2 s in all (no planner.total_duration")
        for n in unbounded.notes
    )


def _dense(task, doc, samples: int = 2000) -> np.ndarray:
    """Configurations at `samples` times a piece, integrated independently (solve_ivp)."""
    rhs, inputs = rhs_for(task, doc), doc["inputs"]
    q, out = np.array(doc["start"], dtype=float), []
    for leg in doc["legs"]:
        for piece in leg["pieces"]:
            sol = solve_ivp(
                lambda s, y, p=piece, st=leg["stratum"]: rhs(st, y, controls(p, inputs, s)),
                (0.0, piece["duration"]), q, method="DOP853", rtol=1e-11, atol=1e-12,
                t_eval=np.linspace(0.0, piece["duration"], samples),
            )  # fmt: skip
            assert sol.success
            out.append(sol.y.T)
            q = sol.y[:, -1]
    return np.concatenate(out)


def _within(limit: float):
    """Task D, durations optimised in a 2 s budget, joints within ±`limit`: the raw
    scenario, the task and its outcome, checked planned, within the budget and inside the
    limits on an independent integration."""
    raw = _task_d(durations="optimise", total_duration=2.0)
    raw["constraints"] = {"joint_limits": [-limit, limit]}
    task = load_scenario(raw)
    outcome = plan_run(task, check=False)
    plan = outcome.result
    assert plan.ok, plan.message
    assert sum(leg.duration for leg in plan.legs) == pytest.approx(2.0, abs=1e-9)
    assert np.abs(_dense(task, outcome.document)[:, :3]).max() <= limit + 1e-6
    return raw, task, outcome


def test_optimised_durations_are_searched_within_the_limits():
    """The free optimum takes q2 past 3 rad; the durations are chosen without the limits,
    then the plan is searched within them at those durations and at equal ones: inside on
    an independent integration, no dearer than the fixed durations' constrained plan."""
    raw, task, outcome = _within(2.5)
    plan = outcome.result
    verify(task, outcome.document)  # goals, chaining, energies, continuity at the switch
    (note,) = [n for n in plan.notes if n.startswith("durations optimised")]
    assert "then searched within them at those durations and at equal ones" in note
    fixed = dict(raw, planner={k: v for k, v in raw["planner"].items() if "duration" not in k})
    equal = plan_run(load_scenario(fixed), check=False).result  # 1 s + 1 s, searched inside
    assert equal.ok and plan.total_energy <= equal.total_energy * (1 + 1e-9)
    assert f"{equal.total_energy:.6g} at equal durations)" in note  # the same search, given
    raw["constraints"] = {"max_rate": 5.0}  # a rate limit alone asks the search for nothing
    plan = plan_run(load_scenario(raw), check=False).result
    assert not any("searched within them" in n for n in plan.notes)


def test_optimised_durations_where_the_search_stalls_advise_without_the_other_objective():
    # the other objective is refused with optimised durations: not advised
    raw = _task_d(durations="optimise", total_duration=2.0)
    raw["constraints"] = {"joint_limits": [-2.0, 2.0]}  # stalls at any durations with 3
    raw["planner"]["basis"] = {"harmonics": 3}  # set: kept, no retry with more
    plan = plan_run(load_scenario(raw), check=False).result
    assert not plan.ok
    assert plan.message.startswith("the constrained search stalled on leg 1")
    assert "try more harmonics" in plan.message
    assert "the other objective" not in plan.message


def test_optimised_durations_where_the_search_stalls_in_the_default_basis_get_more_harmonics():
    """The same table with the default basis: planned again with 5 harmonics at the
    durations chosen, inside the limits on an independent integration, both notes kept."""
    _, _, outcome = _within(2.0)
    plan = outcome.result
    pieces = [p for leg in outcome.document["legs"] for p in leg["pieces"]]
    assert {p["basis"]["harmonics"] for p in pieces} == {5}
    assert any(n.startswith("durations optimised within the 2 s budget") for n in plan.notes)
    assert any(n.startswith("planned with 5 harmonics") for n in plan.notes)


@pytest.mark.parametrize(
    ("planner", "field"),
    [
        ({"durations": "optimise", "objective": "newton"}, "planner.durations"),
        ({"total_duration": 3.0}, "planner.total_duration"),
        ({"durations": "optimise", "total_duration": -1.0}, "planner.total_duration"),
        ({"durations": "free"}, "planner.durations"),
        # two legs of at least 1e-3 s each: planned, the equal split was a traceback
        ({"durations": "optimise", "total_duration": 0.001}, "planner.total_duration: 2 legs"),
    ],
)
def test_bad_duration_settings_name_their_field(planner, field):
    with pytest.raises(InputError) as info:
        load_scenario(_task_d(**planner))
    lines = [f"{p.path}: {p.message}" for p in info.value.problems]
    assert any(line.startswith(field) for line in lines), lines


def _rate_limited(**planner) -> dict:
    raw = tomllib.loads((ROOT / "scenarios" / "sim4_task_d_rate_limited.toml").read_text())
    raw["planner"].update(durations="optimise", **planner)
    return raw


def test_a_budget_the_rate_limits_cannot_meet_fails_and_its_advice_meets_it(tmp_path):
    # 0.5 rad/s slows the 2 s plan some 18x: a fixed time slot is broken, not "ok"
    path = tmp_path / "budget.toml"
    text = (ROOT / "scenarios" / "sim4_task_d_rate_limited.toml").read_text()
    budget = '[planner]\ndurations = "optimise"\ntotal_duration = 2.0'
    path.write_text(text.replace("[planner]", budget))
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path / "runs"), "--quiet"])
    assert result.exit_code == 1, result.output
    assert "Traceback" not in result.output
    (run,) = (tmp_path / "runs").iterdir()
    doc = json.loads((run / "result.json").read_text())
    jsonschema.validate(doc, record_schema("result"))
    assert doc["status"] == "failed" and doc["duration"] > 2.0
    violation = doc["constraints"]["violation"]
    assert violation["limit"] == "total_duration"
    assert violation["leg"] is None  # the budget is the plan's (it named the last leg)
    assert violation["by"] == pytest.approx(doc["duration"] - 2.0)
    advice = re.search(
        r"planner.total_duration to at least ([\d.]+) s and planner.basis.period alike, "
        r"to ([\d.]+) s",
        doc["message"],
    )
    assert advice, doc["message"]
    budget, period = float(advice[1]), float(advice[2])
    assert budget >= doc["duration"]
    # the advice is true: that budget and period plan within the limit, in the budget
    raw = _rate_limited(total_duration=budget)
    raw["planner"]["basis"] = {"harmonics": 3, "period": period}
    outcome = plan_run(load_scenario(raw), check=False)
    assert outcome.result.ok, outcome.result.message
    assert outcome.result.duration == pytest.approx(budget, rel=1e-9)
    assert not outcome.result.constraints.duration_set_by  # not slowed: within the limit
    for leg in outcome.document["legs"]:  # independently, from result.json's controls
        (piece,) = leg["pieces"]
        t = np.linspace(0.0, piece["duration"], 4001)
        u = np.array([controls(piece, outcome.document["inputs"], s) for s in t])
        assert np.abs(u).max() <= 0.5 * (1 + 1e-6)
    # re-timed from Python past the budget, the plan fails too (it came back ok, the budget
    # unchecked), and the advice's factor brings it back within both
    slower = time_scaled(outcome.result, 0.5)
    assert not slower.ok and slower.constraints.violation["limit"] == "total_duration"
    assert slower.message == (
        f"the plan runs {2 * budget:.4g} s, more than planner.total_duration = {budget:g} s; "
        "re-timed too slow for its budget: time_scaled by 0.5, where at least 1 fits it (this "
        "plan time_scaled again by at least 2)"
    )
    again = time_scaled(slower, 2.0)
    assert again.ok and again.message == "" and again.duration == pytest.approx(budget)
    assert time_scaled(outcome.result, 1.0).ok  # the plan given: a speed-up of 1 fits
    # the budget is kept to rounding, not to a slack: a millionth past it breaks it
    past = time_scaled(outcome.result, 1.0 / (1.0 + 1e-6))
    assert not past.ok and past.constraints.violation["limit"] == "total_duration"
    assert time_scaled(outcome.result, 1.0 / (1.0 + 1e-12)).ok


def test_a_failed_plan_of_optimised_durations_advises_the_budget_not_a_longer_leg():
    """The legs' durations come from total_duration there: 'a longer leg' named nothing the
    scenario sets."""
    import dataclasses

    from stratcli.durations import _budget_advice
    from stratcli.objectives import plan_sequence

    task = load_scenario(ROOT / "scenarios" / "sim4_task_c.toml")
    settings = dataclasses.replace(task.settings, max_iterations=1, restarts=0, objective="newton")
    failed = plan_sequence(task.system, task.start, task.legs, settings)
    assert not failed.ok and "a longer leg" in failed.message
    advised = _budget_advice(failed).message
    assert "a longer leg" not in advised and "a larger planner.total_duration" in advised


def test_a_failed_plan_slowed_past_its_budget_counts_the_budget_among_its_broken_limits():
    """A plan failed by a joint limit and slowed by a rate limit past planner.total_duration
    named the joint limit alone: the 27.3 s against a 6 s budget appeared nowhere, so a user
    who fixed the geometry met the budget only on the next run."""
    from stratcli.constraints import ConstraintsSpec, resolve
    from stratcli.limit_timing import enforce

    task = load_scenario(_task_d(durations="optimise", total_duration=2.0))
    free = plan_run(task, check=False).result  # no [constraints]: as planned
    spec = ConstraintsSpec.model_validate({"joint_limits": [-0.5, 0.5], "max_rate": 0.2})
    failed = enforce(free, resolve(spec, task.system))
    assert not failed.ok and failed.duration > 2.0
    report = failed.constraints
    assert report.violation["limit"] == "joint_limit"  # the first broken, as before
    assert f"planner.total_duration ({failed.duration:.4g} s > 2 s)" in report.violated
    assert f"planner.total_duration ({failed.duration:.4g} s > 2 s)" in failed.message
