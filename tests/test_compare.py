"""Comparing candidate sequences: shared prefixes, ranking, failed sequences kept."""

from __future__ import annotations

import math

import numpy as np
from conftest import (
    newton_objective,
)

from stratcli.compare import compare
from stratcli.decomposition import (
    decompose,
    moved_coordinates,
)
from stratcli.objectives import plan_sequence
from stratcli.scenario import parse_scenario
from stratcli.trie import build_trie

PI = math.pi


UNICYCLE = """
name = "unicycle_turns"
[model]
kind = "custom"
states = ["x", "y", "theta"]
inputs = ["v", "w"]
[model.fields]
v = ["cos(theta)", "sin(theta)", 0]
w = [0, 0, 1]
[[model.strata]]
name = "drive"
active = ["v"]
locked = ["theta"]
[[model.strata]]
name = "turn"
active = ["w"]
locked = ["x", "y"]
[task]
start = [0, 0, 0]
goal = [1, 0, "pi/2"]
[planner]
continuity = "lr-C1"
[decompose]
max_length = 2
"""


def test_custom_model_and_a_failed_sequence_stays_in_the_table():
    task = parse_scenario(UNICYCLE)
    system = task.system
    assert moved_coordinates(system, "drive") == (0, 1)
    assert moved_coordinates(system, "turn") == (2,)
    dec = decompose(system, task.start, task.goal, max_length=2)
    assert dec.sequences == (("drive", "turn"), ("turn", "drive"))
    turn_first = dec.candidates[1]
    np.testing.assert_allclose(turn_first.vias[0], (0, 0, PI / 2))
    result = compare(system, task.start, dec.candidates, newton_objective(task.settings))
    best, other = (result.outcomes[k] for k in result.ranking)
    assert best.candidate.sequence == ("drive", "turn") and best.ok
    # heading π/2 first, the car can no longer reach x = 1: failed, with its reason
    assert not other.ok and other.rank == 2
    assert "leg 2 on drive" in other.reason and "did not reach its goal" in other.message


def test_shared_prefixes_give_exactly_the_plans_of_plan_sequence(sim4):
    dec = decompose(
        sim4.system, sim4.start, sim4.goal, max_length=3, strategies=("conservative", "postponed")
    )
    result = compare(sim4.system, sim4.start, dec.candidates, sim4.settings)
    nodes, _ = build_trie(sim4.system, sim4.settings, [list(c.legs) for c in dec.candidates])
    assert result.legs_requested == sum(len(c.legs) for c in dec.candidates) == 96
    assert result.legs_planned == len(nodes) < result.legs_requested  # shared, not repeated
    for o in result.outcomes:
        again = plan_sequence(sim4.system, sim4.start, list(o.candidate.legs), sim4.settings)
        assert o.status == ("ok" if again.ok else "failed")
        assert o.energy == again.total_energy  # exactly: same seeds, same numbers
        assert o.plan.message == again.message
        for a, b in zip(o.plan.legs, again.legs, strict=True):
            np.testing.assert_array_equal(a.coefficients, b.coefficients)
            np.testing.assert_array_equal(a.end, b.end)
        for a, b in zip(o.plan.switches, again.switches, strict=True):
            np.testing.assert_array_equal(a.jump_derivative, b.jump_derivative)
    ranked = [result.outcomes[k] for k in result.ranking if result.outcomes[k].ok]
    energies = [o.energy_equal_time for o in ranked]  # compared at one total duration
    assert energies == sorted(energies)
    assert result.reference_duration == min(
        sum(leg.duration for leg in c.legs) for c in dec.candidates
    )
    assert "lowest total energy" in result.choice()
    by_peak = compare(
        sim4.system, sim4.start, dec.candidates[:6], sim4.settings, criterion="peak-control"
    )
    peaks = [by_peak.outcomes[k].peak_control for k in by_peak.ranking]
    assert peaks == sorted(peaks)


def test_energies_are_compared_at_equal_total_duration(sim4):
    """Time-scaling a path by s multiplies its energy by s and divides its duration by s, so
    energy x duration belongs to the path: a longer sequence cannot win by being slower."""
    from dataclasses import replace

    import pytest

    from stratcli.compare import Outcome, rank
    from stratcli.time_scaling import time_scaled

    cand = decompose(sim4.system, sim4.start, sim4.goal, max_length=2).candidates[0]
    plan = plan_sequence(sim4.system, sim4.start, list(cand.legs), sim4.settings)
    assert plan.ok
    for s in (0.5, 2.0, 3.0):
        scaled = time_scaled(plan, s)
        assert scaled.total_energy * scaled.duration == pytest.approx(
            plan.total_energy * plan.duration, rel=1e-12
        )
    short = Outcome(0, cand, None, "ok", "", "", energy=100.0, duration=2.0)
    long = Outcome(1, cand, None, "ok", "", "", energy=80.0, duration=3.0)  # 120 in 2 s
    at = [replace(o, reference_duration=2.0) for o in (short, long)]
    assert at[1].energy_equal_time == pytest.approx(120.0)
    assert rank(at, "energy") == [0, 1]
    assert rank([short, long], "energy") == [1, 0]  # raw energies would favour the slow one


def test_a_failed_candidates_reason_is_its_message_up_to_the_advice_not_inside_a_parenthesis():
    """The reason was the message up to its first ";", which cut a stalled search's
    "(with 3 harmonics; it stalled with 5 and 8 too)" open."""
    from stratcli.compare import first_clause

    stall = (
        "the constrained search stalled on leg 1: the joint limits of q3 still violated by "
        "0.484 rad at its nodes (with 3 harmonics; it stalled with 5 and 8 too)"
    )
    assert first_clause(f"{stall}; kept instead: the plan found without the limits; try") == stall
    assert first_clause("leg 2 did not reach its goal; try more harmonics") == (
        "leg 2 did not reach its goal"
    )
    assert first_clause("no advice") == "no advice"


def test_a_comparison_on_a_dask_cluster_says_so_not_local_processes():
    """`compare-sequences --dask` said "... in 0.32 s on 2 processes"."""
    from stratcli.compare import _where

    class Client:  # as distributed's, by its module
        pass

    Client.__module__ = "distributed.client"
    assert _where(None) == "" and _where(Client()) == "a Dask cluster"
    assert _where(object()) == "the executor given"


def test_a_tie_with_the_next_sequence_says_what_broke_it_or_that_rounding_did():
    """A symmetric two-arm task chose (S2, S1) at 81.83 with (S4, S3) next at 81.83 and no
    word of how; the values differed by 7e-13."""
    from types import SimpleNamespace

    from stratcli.comparison_values import _tie

    def outcome(value, energy, legs):
        return SimpleNamespace(
            value=lambda criterion: value, energy=energy, candidate=SimpleNamespace(legs=legs)
        )

    best = outcome(81.83, 81.83, (1, 2))
    assert _tie(best, outcome(81.83 + 7e-13, 81.83, (1, 2)), "energy") == " (a tie but for 7e-13)"
    assert _tie(best, outcome(81.9, 81.9, (1, 2)), "energy") == ""  # no tie
    # an exact tie: the keys `rank` breaks it by, in turn
    assert _tie(best, outcome(81.83, 82.0, (1, 2)), "duration") == (
        " (a tie, broken by total energy)"
    )
    assert _tie(best, outcome(81.83, 81.83, (1, 2, 3)), "energy") == (
        " (a tie, broken by fewer legs)"
    )
    assert _tie(best, outcome(81.83, 81.83, (1, 2)), "energy") == (
        " (a tie, broken by the order of the candidates)"
    )


def test_candidates_failed_only_by_a_limit_rank_by_how_far_they_stalled_outside():
    """Six candidates reached every goal and broke a limit: the last legs' errors (1.1e-14,
    1.6e-14, ...) decided their order, and the message said 'no sequence reached the goal;
    the one that got furthest' of the one 0.421 rad outside, where another was 0.202."""
    from types import SimpleNamespace

    from stratcli.compare import Comparison, Outcome, rank

    def failed(k, by, error, n=2):
        legs = [SimpleNamespace(converged=True, error=error)] * n
        plan = SimpleNamespace(legs=legs, constraints=SimpleNamespace(violation={"by": 9.0}))
        cand = SimpleNamespace(legs=[None] * n, label=f"(S{k})", strategy="conservative")
        message = f"the constrained search stalled on leg 1: q2 still violated by {by} rad"
        return Outcome(k, cand, plan, "failed", message, message)

    outcomes = [failed(0, 0.421, 1e-14), failed(1, 0.202, 4e-14), failed(2, 0.3, 2e-14)]
    order = rank(outcomes, "energy")
    assert order == [1, 2, 0]
    # whatever their lengths: a 3-leg sequence 0.824 outside ranked above a 2-leg one 0.502
    assert rank([failed(0, 0.824, 1e-14, n=3), failed(1, 0.502, 1e-14)], "energy") == [1, 0]
    comparison = Comparison(outcomes, order, "energy", 1, 6, 6, 0.0, False)
    assert comparison.choice().startswith(
        "no sequence stayed within the limits; the nearest was (S1)"
    )


def test_candidates_that_did_not_reach_the_goal_rank_by_how_many_legs_they_planned():
    """Among failed candidates that did not reach every goal: more legs planned first, then
    the smaller error of the leg that failed, then enumeration order; rejected ones last."""
    from types import SimpleNamespace

    from stratcli.compare import Outcome, rank

    def failed(k, reached, error, n=3):
        legs = [SimpleNamespace(converged=i < reached, error=0.0) for i in range(reached)]
        if reached < n:  # the leg it stopped on
            legs.append(SimpleNamespace(converged=False, error=error))
        plan = SimpleNamespace(legs=legs, constraints=None)
        cand = SimpleNamespace(legs=[None] * n, label=f"(S{k})", strategy="conservative")
        return Outcome(k, cand, plan, "failed", "did not reach", "did not reach")

    rejected = Outcome(4, SimpleNamespace(legs=[None]), None, "failed", "refused", "refused")
    outcomes = [failed(0, 1, 0.1), failed(1, 2, 0.5), rejected, failed(3, 2, 0.2)]
    assert rank(outcomes, "energy") == [3, 1, 0, 4]


def test_a_failed_candidates_partial_duration_does_not_make_the_durations_unequal():
    """A failed candidate keeps the duration of the legs it planned (1 s of 2): the exhaustive
    table then said "ranked by energy at an equal total duration of 2 s", with an "energy in
    2 s" column, where the screened one said "total energy" for the same plans. A bounded
    (unsearched) candidate of three legs does make them unequal: its bound is at 2 s, as the
    table's header and column said while the sentence under it said "total energy"."""
    from types import SimpleNamespace

    from stratcli.comparison_values import Comparison, Outcome

    def legs(n):
        return SimpleNamespace(sequence=("S1",) * n, label=f"({n} legs)", strategy="conservative")

    ok = Outcome(0, legs(2), None, "ok", "", "", energy=1.0, duration=2.0)
    failed = Outcome(1, legs(3), None, "failed", "x", "x", energy=0.5, duration=1.0)
    compared = Comparison([ok, failed], [0, 1], "energy", 1, 2, 2, 0.0, False, 2.0)
    assert compared.equal_durations
    slower = Outcome(2, legs(3), None, "ok", "", "", energy=1.0, duration=3.0)
    assert not Comparison([ok, slower], [0, 1], "energy", 1, 2, 2, 0.0, False, 2.0).equal_durations
    bounded = Outcome(3, legs(3), None, "bounded", "", "", screened=True)
    longer = Comparison([ok, bounded], [0, 1], "energy", 1, 2, 2, 0.0, False, 2.0)
    assert not longer.equal_durations and "at an equal total duration of 2 s" in longer.choice()


def test_a_comparison_starts_no_more_than_four_workers_a_core(monkeypatch):
    """(`--jobs 100` forked 100 processes for 18 sequences on 2 cores; its footer said so.)"""
    from conftest import ROOT as root

    from stratcli import api, trie

    monkeypatch.setattr(trie, "default_jobs", lambda: 1)
    outcome = api.compare_sequences(root / "scenarios" / "sim4_auto.toml", jobs=1000)
    assert outcome.comparison.jobs == trie.most_workers() == 4
