"""Planning use cases: every shipped scenario, unsteerable legs, decompositions."""

from __future__ import annotations

import pytest
from conftest import (
    ROOT,
    SCENARIOS,
)
from reintegrate import verify

from stratcli import api
from stratcli.errors import InputError, NotControllableError
from stratcli.scenario import load_scenario, parse_scenario

TURN_ONLY = """
name = "turn-only"
[model]
kind = "custom"
states = ["x", "y", "theta"]
inputs = ["v", "w"]
[model.fields]
v = ["cos(theta)", "sin(theta)", 0]
w = [0, 0, 1]
[[model.strata]]
name = "turn"
active = ["w"]
[task]
start = [0, 0, 0]
goal = [1, 0, 0]
[[legs]]
stratum = "turn"
"""


def test_a_leg_its_stratum_cannot_steer_raises_before_planning():
    task = parse_scenario(TURN_ONLY)
    with pytest.raises(NotControllableError) as caught:
        api.plan_run(task)
    assert any("leg 1 on turn" in p for p in caught.value.problems)
    report = api.check_controllability(task, samples=3)
    assert not report.controllable and report.problems == caught.value.problems


def test_decompose_lists_the_candidates_without_planning():
    task = load_scenario(ROOT / "scenarios" / "sim4_auto.toml")
    outcome = api.decompose(task, max_length=2, strategy="both")
    assert outcome.document["strategies"] == ["conservative", "postponed"]
    assert len(outcome.document["sequences"]) == len(outcome.decomposition.candidates)
    with pytest.raises(InputError, match=r"^strategy: must be conservative, postponed or both"):
        api.decompose(task, strategy="eager")


def test_plan_in_auto_mode_says_which_sequence_it_chose(sim4):
    """`stratcli.plan` of a scenario without legs returns the chosen plan only: its first
    note says what was compared and what was chosen, as the command line prints."""
    plan = api.plan(sim4.with_changes({"decompose": {"max_length": 2}}))
    first = plan.notes[0]
    assert first.startswith("auto mode: ") and "candidate sequences (max length 2" in first
    chosen = "(" + ", ".join(leg.stratum for leg in plan.legs) + ")"
    assert f"chose {chosen}" in first


def test_auto_mode_runs_the_chosen_plan_at_the_time_scale_asked(sim4):
    """`time_scale` (the argument, else planner.time_scale) applies in auto mode as with legs:
    it was silently dropped there. Driftless: s times faster, s times the energy."""
    short = sim4.with_changes({"decompose": {"max_length": 2}})
    plain = api.plan(short)
    fast = api.plan(short, time_scale=2.0)
    scaled = api.plan(short.with_changes({"planner": {"time_scale": 4.0}}))
    assert fast.duration == pytest.approx(plain.duration / 2, rel=1e-12)
    assert fast.total_energy == pytest.approx(2 * plain.total_energy, rel=1e-9)
    assert scaled.duration == pytest.approx(plain.duration / 4, rel=1e-12)
    assert fast.notes[0].endswith("(as planned, before time scaling by 2)")  # its energies
    assert "before time scaling" not in plain.notes[0]


@pytest.mark.parametrize("stem", [p.stem for p in SCENARIOS])
def test_shipped_scenario_plans_and_reintegrates(shipped_plans, stem):
    """Every shipped scenario, planned once per session as `stratplan regress` plans it."""
    task, outcome = shipped_plans[stem]
    verify(task, outcome.document)
