"""The Newton leg planner's iteration budget (the energy objective's extra starts)."""

from __future__ import annotations

import numpy as np
from conftest import ROOT

from stratcli.scenario import load_scenario
from stratcli.stratified import chain_legs

# A seeded start of Sim 4 task B whose first leg needs 46 Newton iterations over 2 attempts
# without a budget (the energy objective's fifth extra start).
SEEDED = {"restarts": 2, "seed": 5 * 7919, "spread": 0.02 + 0.3 * 5}


def _task_b():
    return load_scenario(ROOT / "scenarios" / "sim4_task_b.toml")


def test_a_budget_bounds_the_iterations_of_every_leg_over_its_attempts():
    task = _task_b()
    free = chain_legs(task.system, task.start, task.legs, task.settings, **SEEDED)
    assert free.legs[0].iterations > 36  # the case the budget is for
    capped = chain_legs(task.system, task.start, task.legs, task.settings, budget=36, **SEEDED)
    assert all(leg.iterations <= 36 for leg in capped.legs)
    assert not capped.ok  # this seed is dropped, not planned differently


def test_a_budget_the_leg_does_not_reach_changes_nothing():
    task = _task_b()
    free = chain_legs(task.system, task.start, task.legs, task.settings, **SEEDED)
    roomy = chain_legs(task.system, task.start, task.legs, task.settings, budget=1000, **SEEDED)
    assert free.ok and roomy.ok
    for a, b in zip(free.legs, roomy.legs, strict=True):
        assert a.iterations == b.iterations and a.attempts == b.attempts
        assert np.array_equal(a.coefficients, b.coefficients)
