"""Auto mode's screen (`compare(..., screen=K)`, `stratcli.screen`): bounds below the exhaustive
search's minima, and the same choice."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pytest

from stratcli import api
from stratcli.compare import SCREEN_TOP, compare
from stratcli.decomposition import decompose
from stratcli.records.comparison import comparison_csv
from stratcli.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def sim4():
    """Sim 4's auto scenario with its own (the default, energy) objective."""
    task = load_scenario(ROOT / "scenarios" / "sim4_auto.toml")
    assert task.settings.objective == "energy"
    return task


def random_task(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A random one-arm task, as benchmarks/bench_screen.py draws it."""
    rng = np.random.default_rng(seed)
    start = rng.uniform(-np.pi / 2, np.pi / 2, 4)
    change = np.concatenate([rng.uniform(-2.5, 2.5, 3), rng.uniform(-0.6, 0.6, 1)])
    return start, start + change


def screened_and_exhaustive(task, start, goal):
    dec = decompose(task.system, start, goal, max_length=3, strategies=("conservative",))
    return [
        compare(task.system, start, dec.candidates, task.settings, jobs=2, screen=screen)
        for screen in (SCREEN_TOP, None)
    ]


def test_screen_chooses_as_the_exhaustive_search_on_sim4(sim4):
    screened, exhaustive = screened_and_exhaustive(sim4, sim4.start, sim4.goal)
    for result in (screened, exhaustive):
        best = result.best
        assert best.candidate.sequence == ("S1", "S3") and best.candidate.strategy == (
            "conservative"
        )
        assert best.energy == pytest.approx(64.80, abs=0.01)
        assert not best.screened
    assert screened.best.energy == exhaustive.best.energy  # the same search, the same numbers
    assert any(o.screened for o in screened.outcomes)
    assert not any(o.screened for o in exhaustive.outcomes)
    best = screened.best.energy_equal_time
    for o, full in zip(screened.outcomes, exhaustive.outcomes, strict=True):
        # every bound is below the sequence's minimum (the exhaustive search's)
        assert o.energy_bound_equal_time <= full.energy_equal_time * (1 + 1e-9)
        # ... the sum of its legs' bounds, each at least the leg's floor; every floor below
        # the energy of that leg in the sequence's minimum (planned alone it costs no more)
        assert len(o.leg_bounds) == len(full.plan.legs)
        assert sum(bound for _, bound in o.leg_bounds) == pytest.approx(o.energy_bound)
        for (floor, bound), leg in zip(o.leg_bounds, full.plan.legs, strict=True):
            assert 0.0 <= floor <= bound and floor <= leg.energy * (1 + 1e-9)
        if o.screened:  # bounded: not planned, and its bound cannot beat the best
            assert o.status == "bounded" and o.plan is None
            assert o.energy_bound_equal_time >= best
        else:  # searched: the same search as the exhaustive one's
            assert o.ok and o.energy == full.energy
    ranked = [screened.outcomes[k] for k in screened.ranking]
    statuses = [o.status for o in ranked]  # searched, then bounded, then failed
    assert statuses == sorted(statuses, key=["ok", "bounded", "failed"].index)


@pytest.mark.parametrize("seed", [1, 4, 14, 16])
def test_screen_chooses_as_the_exhaustive_search_on_random_tasks(sim4, seed):
    start, goal = random_task(seed)
    screened, exhaustive = screened_and_exhaustive(sim4, start, goal)
    assert screened.best.candidate == exhaustive.best.candidate
    assert screened.best.energy == exhaustive.best.energy
    for o, full in zip(screened.outcomes, exhaustive.outcomes, strict=True):
        if full.ok:  # the bound holds wherever the exhaustive search reached the goal
            assert o.energy_bound_equal_time <= full.energy_equal_time * (1 + 1e-9)


@pytest.mark.slow
def test_screen_chooses_as_the_exhaustive_search_on_the_benchmarks_20_tasks(sim4):
    """The 20 seeded one-arm tasks of benchmarks/bench_screen.py (issue 14 item 4): the same
    sequence and energy as the exhaustive search on every one."""
    for seed in range(20):
        start, goal = random_task(seed)
        screened, exhaustive = screened_and_exhaustive(sim4, start, goal)
        assert screened.best.candidate == exhaustive.best.candidate, seed
        assert screened.best.energy == exhaustive.best.energy, seed


def test_comparison_json_marks_screened_rows_and_exhaustive_has_none(sim4):
    doc = api.compare_sequences(sim4, jobs=2).document
    assert all("screened" in row and "energy_bound" in row for row in doc["rows"])
    assert doc["rows"][0]["screened"] is False and any(row["screened"] for row in doc["rows"])
    for row in doc["rows"]:  # which were searched, which only bounded
        assert (row["status"] == "bounded") == row["screened"]
        assert (row["energy"] is None) == row["screened"]
    assert doc["screen"]["searched"] + doc["screen"]["bounded"] == len(doc["rows"])
    # comparison.csv has the bounds too (a bounded row's energy is empty)
    table = list(csv.DictReader(io.StringIO(comparison_csv(doc))))
    for line, row in zip(table, doc["rows"], strict=True):
        assert line["energy_bound"] == (
            "" if row["energy_bound"] is None else repr(row["energy_bound"])
        )
        assert (line["energy"] == "") == row["screened"]
    full = api.compare_sequences(sim4, jobs=2, exhaustive=True).document
    assert not any(row["screened"] for row in full["rows"]) and full["screen"] is None
    assert full["rows"][0]["sequence"] == doc["rows"][0]["sequence"] == ["S1", "S3"]


def test_the_screen_does_not_depend_on_the_processes_or_the_executor(sim4):
    """Rounds depend only on what earlier rounds found: one process, two, or threads (the
    executor path) give the same document."""
    from concurrent.futures import ThreadPoolExecutor

    from stratcli.records.comparison import without_timings

    one = api.compare_sequences(sim4, jobs=1).document
    two = api.compare_sequences(sim4, jobs=2).document
    with ThreadPoolExecutor(2) as pool:
        threads = api.compare_sequences(sim4, executor=pool).document
    assert one["screen"]["searched"] >= 1 and one["screen"]["bounded"] >= 1
    assert without_timings(one) == without_timings(two) == without_timings(threads)


HOPELESS_LEG = """
name = "two_arm_hopeless_leg"
[model]
kind = "preset"
name = "two-arm"
[task]
start = [0, 0, 0, 0, 0]
goal = [0, 0, 0.3, 0.2, 2]
[decompose]
max_length = 2
"""


@pytest.mark.slow  # two two-arm comparisons and one hopeless sequence planned in full: ~25 s
def test_a_sequence_with_a_leg_that_has_no_plan_alone_fails_unsearched(monkeypatch):
    """A new user's two-arm task took 79 s: an S13 leg with no plan even free at both ends was
    bounded again under its own conditions and three of its sequences searched, each failing
    after seconds. Such sequences now fail unsearched, naming the leg; planned in full (as
    --exhaustive does) one of them fails too, and the choice is the same. With the legs'
    floors (`leg_floors`) they are not even reached: bounded, the same choice."""
    import stratcli.screen
    from stratcli.objectives import plan_sequence

    task = load_scenario(HOPELESS_LEG)
    floored = api.compare_sequences(task, jobs=2).document
    assert floored["screen"]["legs_floored"] > 0 and floored["screen"]["failed_unsearched"] == 0
    assert floored["rows"][0]["sequence"] == ["S2"] and floored["rows"][0]["status"] == "ok"
    # without floors (as for a model that has none) the legs are searched alone
    monkeypatch.setattr(stratcli.screen, "leg_floor", lambda *args: 0.0)
    outcome = api.compare_sequences(task, jobs=2)
    doc = outcome.document
    assert doc["rows"][0]["energy"] == floored["rows"][0]["energy"]
    sunk = [r for r in doc["rows"] if "has no plan even alone" in (r["reason"] or "")]
    assert sunk and doc["screen"]["failed_unsearched"] == len(sunk)
    assert all(r["status"] == "failed" and r["energy"] is None for r in sunk)
    assert doc["rows"][0]["sequence"] == ["S2"] and doc["rows"][0]["status"] == "ok"
    row = sunk[0]
    (candidate,) = [
        c
        for c in outcome.decomposition.candidates
        if [leg.stratum for leg in c.legs] == row["sequence"] and c.strategy == row["strategy"]
    ]
    assert not plan_sequence(task.system, task.start, list(candidate.legs), task.settings).ok


def _arm3_auto_energy(strata: bool = True):
    """arm3_auto (robots/arm3.urdf) with the energy objective; without its strata list S1 is
    a candidate too (it cannot turn the base about z at j1 = 0)."""
    text = (ROOT / "scenarios" / "spatial" / "arm3_auto.toml").read_text()
    text = text.replace('objective = "newton"', 'objective = "energy"')
    text = text.replace("../../robots/", f"{ROOT}/robots/")
    if not strata:
        text = "\n".join(line for line in text.splitlines() if not line.startswith("strata"))
    return load_scenario(text)


def _arm3_candidates(task):
    from stratcli.api.auto import auto_settings, decompose_task

    return decompose_task(task, auto_settings(task)).candidates


def test_without_a_shared_leg_the_comparison_searches_every_candidate(sim4):
    """arm3_auto's two candidates (S2 > S3, S3 > S2) share no leg: bounds would each serve one
    candidate. The screen bounded eight legs, took a failed tight search's Newton plan (115)
    for a bound and pruned S2 > S3 (83.12) for S3 > S2 (99.59); now both are searched (and
    S3 > S2's lowest legs start ends at 72.80: it is chosen)."""
    from stratcli.screen import legs_shared

    task = _arm3_auto_energy()
    candidates = _arm3_candidates(task)
    valid = list(range(len(candidates)))
    assert len(valid) == 2 and not legs_shared(task.system, candidates, valid, task.start)
    dec4 = decompose(sim4.system, sim4.start, sim4.goal, max_length=3)
    valid4 = list(range(len(dec4.candidates)))
    assert legs_shared(sim4.system, dec4.candidates, valid4, sim4.start)
    result = compare(task.system, task.start, candidates, task.settings, screen=SCREEN_TOP)
    assert result.screen is None and all(o.status == "ok" for o in result.outcomes)
    best = result.best
    assert [leg.stratum for leg in best.candidate.legs] == ["S3", "S2"]
    assert best.energy < 83.1241  # --exhaustive before: 83.12405 (S2 > S3)


def test_a_tight_bound_comes_from_a_search_not_from_a_failed_one(monkeypatch):
    """When the tight bound's warm start cannot be restored onto the goals, the next starts
    (Newton plans) are searched: the bound is a minimum found, not the Newton plan's energy
    (115). URDF legs race seeded starts too (`BOUND_STARTS`): from the Newton plan alone
    this leg's loose bound was 42.02 and its tight one 45-50, where 31.76 and 33.81 exist."""
    from stratcli.leg_bounds import leg_minimum

    task = _arm3_auto_energy()
    (cand,) = [c for c in _arm3_candidates(task) if [leg.stratum for leg in c.legs] == ["S2", "S3"]]
    legs = list(cand.legs)
    loose, free, why = leg_minimum(task.system, task.start, legs[:1], 0, _free(task.settings))
    assert free is not None and why == "" and loose < 42.02  # below the one start's minimum
    tight, coefficients, _ = leg_minimum(task.system, task.start, legs, 0, task.settings, free)
    assert coefficients is not None and loose <= tight < 45  # the Newton plan's energy: 115


def _free(settings):
    from stratcli.leg_bounds import _relaxed

    return _relaxed(settings)


@pytest.mark.slow  # six arm3 candidates, three searched: ~20 s (it was ~50 s)
def test_a_urdf_leg_out_of_reach_fails_its_candidates_naming_the_direction():
    """With all three strata arm3's six candidates share 9 distinct legs among 12: too few
    for bounds without floors to pay (screened 12.9 s, searched 9.5 s), so every candidate
    is searched, and the S1-first ones fail naming the direction S1 cannot turn. Up to three
    legs they share 12 among 48, and the screen pays (17.1 s against 62.0 s)."""
    from stratcli.screen import legs_shared

    task = _arm3_auto_energy(strata=False)
    candidates = _arm3_candidates(task)
    valid = list(range(len(candidates)))
    assert not legs_shared(task.system, candidates, valid, task.start)
    longer = task.with_changes({"decompose.max_length": 3})  # 12 distinct legs among 48
    more = _arm3_candidates(longer)
    assert legs_shared(task.system, more, list(range(len(more))), task.start)
    doc = api.compare_sequences(task, jobs=1).document
    assert not any(r["status"] == "bounded" for r in doc["rows"])
    sunk = [r for r in doc["rows"] if r["sequence"][0] == "S1"]
    assert len(sunk) == 2 and all(r["status"] == "failed" for r in sunk)
    for row in sunk:
        assert row["reason"].startswith("leg 1 on S1: error ")
        assert "(S1 cannot move rz from the leg's start" in row["reason"]
    assert doc["rows"][0]["sequence"] == ["S3", "S1"]


def test_a_urdf_leg_bound_stops_earlier_within_rounding_of_the_minimum(monkeypatch):
    """Without exact Hessians a bound's search stops at a relative projected gradient of
    `BOUND_PG_TOL` (1e-6), not 1e-10: the energy is the same to 1e-9."""
    from stratcli import leg_bounds

    task = _arm3_auto_energy()
    (cand,) = [c for c in _arm3_candidates(task) if c.legs[0].stratum == "S3"]
    settings = _free(task.settings)
    early, _, _ = leg_bounds.leg_minimum(task.system, task.start, cand.legs[:1], 0, settings)
    monkeypatch.setattr(leg_bounds, "BOUND_PG_TOL", leg_bounds.PG_TOL)
    full, _, _ = leg_bounds.leg_minimum(task.system, task.start, cand.legs[:1], 0, settings)
    assert early == pytest.approx(full, rel=1e-9) and early >= full * (1 - 1e-12)


ARM3_YAW = """
name = "arm3_yaw"
[model]
kind = "urdf"
path = "{root}/robots/arm3.urdf"
[task]
start = {{ j1 = 0, j2 = 0, j3 = 0, attitude = [0, 0, 0] }}
goal = {{ j1 = 0, j2 = "10deg", j3 = 0, attitude = [0, 0, "20deg"] }}
[planner]
continuity = "lr-C1"
tolerance = 1e-6
leg_duration = 2.0
[decompose]
max_length = 2
"""


def _arm3_yaw_s1_leg():
    """A new user's arm3 task (j2 10 deg, base yaw 20 deg, every stratum, energy): the S1 leg
    of S2 > S1, from the via (yaw 20 deg) to j2 = 10 deg, planned alone and free."""
    task = load_scenario(ARM3_YAW.format(root=ROOT))
    (cand,) = [c for c in _arm3_candidates(task) if [leg.stratum for leg in c.legs] == ["S2", "S1"]]
    at = np.asarray(cand.legs[0].goal, dtype=float)
    return task, at, cand.legs[1:]


def test_a_urdf_leg_whose_stratum_cannot_turn_some_axes_is_bounded_by_a_converged_search():
    """S1 at j1 = 0 turns the base about y only: the leg's rx and rz rows are zero to rounding.
    Restoring trial points inverted them (|λ| ~ 1e8, Magnus steps at their cap): 40 SQP
    iterations, 117 s, no result, and the Newton plan's 7.82 taken for the bound. Restored on
    the rows' range, the search converges (0.07 s) to 6.36, below that."""
    from stratcli.leg_bounds import leg_minimum

    task, at, legs = _arm3_yaw_s1_leg()
    value, coefficients, why = leg_minimum(task.system, at, legs, 0, _free(task.settings))
    assert coefficients is not None and why == ""
    assert 0 < value < 7.8  # a search's minimum (6.36), below the Newton plan's 7.82


def test_a_leg_bound_whose_search_has_no_result_is_zero_not_the_newton_plans_energy(monkeypatch):
    """A search that ends with no feasible start certifies nothing: the Newton plan's energy
    is above the minimum it was heading for, no lower bound. The bound is 0 (the screen takes
    the leg's floor), the leg keeps its plan (a warm start; not a leg without one)."""
    from types import SimpleNamespace

    from stratcli import leg_bounds

    task, at, legs = _arm3_yaw_s1_leg()
    monkeypatch.setattr(
        leg_bounds, "optimise_energy", lambda *a, **k: (None, SimpleNamespace(starts=()))
    )
    settings = _free(task.settings)
    value, coefficients, why = leg_bounds.leg_minimum(task.system, at, legs, 0, settings)
    assert value == 0.0 and coefficients is not None and why == ""


def test_an_exhaustive_comparisons_failed_row_says_why_its_leg_cannot_reach():
    """A candidate searched whole, not screened, whose S1 leg cannot turn arm3's base about z
    at j1 = 0 says so in its row, as the screen's rows do (it read only "leg 1 on S1: error
    0.35 > tolerance 1e-06")."""
    from dataclasses import replace

    task = _arm3_auto_energy(strata=False)
    first_s1 = [c for c in _arm3_candidates(task) if c.legs[0].stratum == "S1"]
    assert first_s1
    newton = replace(task.settings, objective="newton")
    result = compare(task.system, task.start, first_s1[:1], newton, screen=None)
    (row,) = result.outcomes
    assert row.status == "failed"
    assert row.reason.startswith("leg 1 on S1: error ")
    assert "(S1 cannot move rz from the leg's start: " in row.reason


def test_off_linux_a_comparison_runs_on_spawned_workers_with_the_same_result(monkeypatch):
    """`compare_sequences` forked its workers wherever "fork" exists, macOS included (whose
    Accelerate is not fork-safe); off Linux it plans on spawned workers, as a sweep does,
    and the comparison is the one forked workers give."""
    import sys

    from stratcli.records.comparison import without_timings
    from stratcli.sweep import executors

    task = load_scenario(ROOT / "scenarios" / "sim4_auto.toml")
    task = task.with_changes({"decompose": {"max_length": 2}})
    forked = api.compare_sequences(task, jobs=2).document
    made = []
    real = executors.local_executor
    monkeypatch.setattr(executors, "local_executor", lambda jobs: made.append(jobs) or real(jobs))
    monkeypatch.setattr(sys, "platform", "darwin")
    spawned = api.compare_sequences(task, jobs=2).document
    assert made == [2] and not executors._fork_is_safe()  # (spawned, not forked)
    assert without_timings(spawned) == without_timings(forked)


def test_a_leg_bound_above_a_searched_plans_own_leg_is_corrected(sim4, monkeypatch):
    """A leg's search alone can miss its minimum; a searched sequence whose own leg costs less
    lowers that bound (`Screen.corrections`), so that no bound stays above a minimum found
    (the screen prunes on them). Here every leg search is made to report 5 % too much."""
    from stratcli import screen as screen_module

    alone = screen_module.plan_alone

    def high(work):
        return {k: (v * 1.05, *rest) for k, (v, *rest) in alone(work).items()}

    monkeypatch.setattr(screen_module, "plan_alone", high)
    dec = decompose(sim4.system, sim4.start, sim4.goal, max_length=3, strategies=("conservative",))
    result = compare(sim4.system, sim4.start, dec.candidates, sim4.settings, jobs=1, screen=1)
    assert result.screen.corrections > 0
    for o in result.outcomes:
        if o.ok and not o.screened:  # searched: its bound is at most its own energy
            assert o.energy_bound <= o.energy * (1 + 1e-9), o.candidate.label
            for (_, bound), leg in zip(o.leg_bounds, o.plan.legs, strict=True):
                assert bound <= leg.energy * (1 + 1e-9)
