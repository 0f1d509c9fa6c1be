"""The legwise start of the energy search (`planners.legwise`): legs alone, then joined."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from conftest import IPOPT_BEST, energy_plan
from reintegrate import verify

from stratcli.planners import energy, legwise, stacked
from stratcli.records.result import result_document
from stratcli.scenario import load_scenario
from stratcli.stratified import chain_legs

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"


def _problem(name: str):
    """The stacked energy problem of a shipped scenario, with its Newton plan's coefficients."""
    task = load_scenario(SCENARIOS / f"{name}.toml")
    newton = chain_legs(task.system, task.start, task.legs, task.settings)
    nominal = [np.asarray(task.start, dtype=float)]
    for leg, planned in zip(task.legs[:-1], newton.legs[:-1], strict=True):
        nominal.append(np.where(np.isnan(leg.goal), planned.end, leg.goal))
    targets = [np.array(leg.targets, dtype=int) for leg in newton.legs]
    problem = stacked.StackedProblem(task.system, nominal, task.legs, task.settings, targets)
    lam = np.concatenate([leg.coefficients.ravel() for leg in newton.legs])
    return task, problem, lam


def test_every_continuity_row_ties_legs_or_belongs_to_exactly_one_leg():
    _, problem, _ = _problem("sim1_l_c1")
    cons, offsets = problem.constraints, problem.offsets
    tied = legwise.tied_rows(cons, offsets)
    assert tied.any() and not tied.all()  # switches tie legs; a leg's own rows exist too
    own = [legwise.leg_constraints(cons, offsets, i) for i in range(len(offsets) - 1)]
    assert sum(c.C.shape[0] for c in own) + int(tied.sum()) == cons.C.shape[0]
    for i, c in enumerate(own):  # a leg's rows are the stacked rows restricted to its block
        assert c.C.shape[1] == offsets[i + 1] - offsets[i]


def test_a_moved_right_hand_side_keeps_the_coordinates_and_meets_the_new_rows():
    _, problem, lam = _problem("sim1_l_c1")
    cons = problem.constraints
    rng = np.random.default_rng(3)
    rhs = cons.c + rng.normal(size=cons.c.size)
    moved = problem.with_rhs(rhs)
    z = problem.project(lam)
    np.testing.assert_allclose(moved.null, problem.null)
    np.testing.assert_allclose(cons.C @ moved.coefficients(z), rhs, atol=1e-9)
    # the energy as the quadratic in z equals λᵀMλ of the moved coefficients
    again = moved.coefficients(z)
    assert moved.energy(z) == pytest.approx(float(again @ moved.M @ again), rel=1e-9)


def test_joined_legs_meet_the_switch_conditions_and_the_goals():
    """Each leg's own minimum, stacked, misses the switch rows; the continuation carries it
    onto them, and onto the goals."""
    task, problem, lam = _problem("sim4_task_d")
    parts = legwise.leg_minima(problem, task.system, task.settings, lam)
    assert parts is not None
    stacked = np.concatenate(parts)
    cons = problem.constraints
    assert np.abs(cons.C @ stacked - cons.c).max() > 1e-6  # relaxed: the switches differ
    z = legwise.join(problem, parts, task.settings.tolerance)
    assert z is not None
    joined = problem.coefficients(z)
    assert np.abs(cons.C @ joined - cons.c).max() <= 1e-9
    assert np.abs(problem.constraint(z)).max() <= 1e-6


def test_a_pulled_start_is_each_legs_start_as_it_is_and_a_newton_plan_is_pulled(monkeypatch):
    """The stacked pulled start's parts already meet each leg's own rows and goals: they
    start the legs as they are (no second pull, leg by leg); a plain Newton plan's parts are
    pulled toward least energy first, one pull per leg."""
    task, problem, lam = _problem("sim4_task_d")
    pulled = energy.pulled_start(problem, problem.project(lam))
    assert pulled is not None
    calls = []
    real = energy.pulled_start
    monkeypatch.setattr(energy, "pulled_start", lambda p, z: calls.append(z) or real(p, z))
    start = problem.coefficients(pulled)
    parts = legwise.leg_minima(problem, task.system, task.settings, start, True)
    assert parts is not None and calls == []
    again = legwise.leg_minima(problem, task.system, task.settings, lam)
    assert again is not None and len(calls) == len(task.legs)
    # each leg's own minimum from there is no higher than its part of the pulled start
    blocks = [problem.M[a:b, a:b] for a, b in itertools.pairwise(problem.offsets)]
    for own, part, M in zip(parts, problem.split(start), blocks, strict=True):
        assert float(own @ M @ own) <= float(part @ M @ part) * (1 + 1e-9)


@pytest.mark.parametrize("name", ["sim1_l_c1", "sim4_task_a"])
def test_the_legwise_start_reaches_a_lower_minimum_than_the_plain_starts(name):
    """On Sim 1 (l-C1) and Sim 4 A the plain starts end in one basin; the legwise start,
    raced on its own after the default search's starts (its loop starts too), finds a lower
    minimum at or below the best IPOPT found on the same Fourier problem (the loop start's:
    the plan keeps the one found first), and the plan re-integrates independently onto
    every via with continuous controls at the switches."""
    task = load_scenario(SCENARIOS / f"{name}.toml")
    plain = energy_plan(task, "starts")
    default = energy_plan(task, "loops")
    task = task.with_changes({"planner": {"search": "legwise"}})
    wide = energy_plan(task, "legwise")
    assert wide.ok and plain.ok
    opt = wide.optimisation
    own = opt.starts[-1]
    assert own.kind == "legwise" and own.projected_gradient <= 1e-8  # a true minimum
    assert own.energy < 0.95 * plain.total_energy  # another, lower basin
    assert own.energy <= IPOPT_BEST[name]
    # the other starts are the default search's, raced as without the legwise one
    assert [s.energy for s in opt.starts[:-1]] == [s.energy for s in default.optimisation.starts]
    assert wide.total_energy <= min(own.energy, default.total_energy) * (1 + 1e-9)
    verify(task, result_document(wide, task.scenario.name, task.model_name))


def test_the_search_is_a_planner_setting_and_a_bad_value_names_the_field():
    from stratcli.errors import InputError
    from stratcli.scenario import parse_scenario

    text = (SCENARIOS / "sim4_task_d.toml").read_text()
    chosen = parse_scenario(text.replace("[planner]", '[planner]\nsearch = "legwise"'))
    assert chosen.settings.search == "legwise"
    assert load_scenario(SCENARIOS / "sim4_task_d.toml").settings.search == "loops"
    with pytest.raises(InputError, match=r"planner\.search"):
        parse_scenario(text.replace("[planner]", '[planner]\nsearch = "everywhere"'))


def test_legs_that_nothing_ties_are_searched_alone_and_not_joined():
    """Without continuity conditions the legs' own minima are the stacked problem's: the
    legwise start is their stack, and the plan is no higher than the plain starts'."""
    task = load_scenario(SCENARIOS / "sim4_task_d.toml")
    task = task.with_changes({"planner": {"continuity": "none"}})
    plain = energy_plan(task, "starts")
    wide = energy_plan(task, "legwise")
    assert [s.kind for s in wide.optimisation.starts][-1] == "legwise"
    assert wide.ok and wide.total_energy <= plain.total_energy * (1 + 1e-9)
    verify(task, result_document(wide, task.scenario.name, task.model_name))
