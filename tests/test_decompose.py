"""Task decomposer (paper §5.3): essential coordinates, sequences, vias; compare-sequences."""

from __future__ import annotations

import dataclasses
import itertools
import json
import math

import numpy as np
import pytest
from conftest import ROOT
from typer.testing import CliRunner

import stratcli.cli as cli
from stratcli.compare import compare
from stratcli.decompose import (
    boundary_configurations,
    candidate_strata,
    decompose,
    enumerate_sequences,
    essential_coordinates,
    format_configuration,
    moved_coordinates,
    pi_fraction,
)
from stratcli.errors import InputError
from stratcli.records.comparison import without_timings
from stratcli.scenario import load_scenario, parse_scenario
from stratcli.stratified import check_legs, plan_sequence
from stratcli.trie import build_trie

runner = CliRunner()
AUTO = ROOT / "scenarios" / "sim4_auto.toml"
AUTO_TEXT = AUTO.read_text()
PI = math.pi

# Paper Sim 4 (DESIGN §11): the sequences of tasks A-D and their printed via configurations.
PAPER = {
    ("S1", "S2"): [(0, PI / 3, PI / 4, -PI / 12)],
    ("S2", "S1"): [(-PI / 3, PI / 4, PI / 4, -PI / 12)],
    ("S3", "S2", "S1"): [(-PI / 3, PI / 3, 0, -PI / 12), (-PI / 3, PI / 3, PI / 4, -PI / 12)],
    ("S3", "S1"): [(-PI / 3, PI / 3, 0, -PI / 12)],
}


def _newton(settings):
    """The paper's Newton method (fast); a no-op before planner settings had an objective."""
    if "objective" in {f.name for f in dataclasses.fields(settings)}:
        return dataclasses.replace(settings, objective="newton")
    return settings


@pytest.fixture
def newton(monkeypatch):
    """Make the command line plan with the Newton objective whatever the default is."""

    def load(path):
        task = load_scenario(path)
        task.settings = _newton(task.settings)
        return task

    monkeypatch.setattr(cli, "load_scenario", load)


@pytest.fixture(scope="module")
def sim4():
    task = load_scenario(AUTO)
    task.settings = _newton(task.settings)
    return task


# ------------------------------------------------------------------------------------------
# The decomposer (pure functions)
# ------------------------------------------------------------------------------------------


def test_essential_coordinates():
    assert essential_coordinates([0, PI / 4, 0, 0], [-PI / 3, PI / 3, PI / 4, -PI / 12]) == (
        0,
        1,
        2,
        3,
    )
    # equal within the tolerance, or not prescribed ("*" = NaN): not essential
    assert essential_coordinates([0, 1, 2, 3], [1e-12, 1.5, np.nan, 3]) == (1,)


def test_sim4_conservative_contains_the_papers_tasks_with_its_vias(sim4):
    dec = decompose(sim4.system, sim4.start, sim4.goal, max_length=3)
    assert dec.essential == (0, 1, 2, 3)  # the paper: "all coordinates are essential"
    assert dec.candidates_strata == ("S1", "S2", "S3")
    found = {c.sequence: c for c in dec.candidates}
    for sequence, vias in PAPER.items():
        cand = found[sequence]
        assert cand.strategy == "conservative"
        assert len(cand.vias) == len(vias)
        for got, want in zip(cand.vias, vias, strict=True):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
        np.testing.assert_array_equal(cand.legs[-1].goal, sim4.goal)
    # the paper's redundant task C: its last leg only closes a loop
    assert found[("S3", "S2", "S1")].redundant_legs(sim4.start) == (3,)
    assert found[("S3", "S1")].redundant_legs(sim4.start) == ()


def test_sequences_never_repeat_a_stratum_and_cover_every_essential_coordinate(sim4):
    system = sim4.system
    dec = decompose(system, sim4.start, sim4.goal, max_length=3)
    assert len(dec.sequences) == 3 * 2 + 3 * 2 * 2  # one-arm: any two strata cover
    for seq in dec.sequences:
        assert all(a != b for a, b in itertools.pairwise(seq))
    # on the two-arm model only some sequences cover: compare with brute force
    two = load_scenario(ROOT / "scenarios" / "sim2.toml")
    essential = essential_coordinates(two.start, two.goal)
    assert [two.system.states[i] for i in essential] == ["q2", "q4"]
    cands = candidate_strata(two.system, essential)
    assert "S24" not in cands  # moves neither q2 nor q4
    moves = {s: moved_coordinates(two.system, s) for s in cands}
    got = enumerate_sequences(moves, essential, 3)
    brute = [
        seq
        for n in (1, 2, 3)
        for seq in itertools.product(cands, repeat=n)
        if all(a != b for a, b in itertools.pairwise(seq))
        and set(essential) <= set().union(*(moves[s] for s in seq))
    ]
    assert got == brute and ("S2",) not in got and ("S2", "S4") in got
    assert len(got) < len(list(itertools.product(cands, repeat=3)))


def test_every_via_is_reachable_locked_coordinates_keep_their_value(sim4):
    for task, length in ((sim4, 3), (load_scenario(ROOT / "scenarios" / "sim2.toml"), 2)):
        dec = decompose(
            task.system,
            task.start,
            task.goal,
            max_length=length,
            strategies=("conservative", "postponed"),
        )
        for cand in dec.candidates:
            check_legs(task.system, task.start, list(cand.legs), task.settings)  # raises if not
            q = task.start
            for leg in cand.legs:
                locked = list(task.system.stratum(leg.stratum).locked)
                np.testing.assert_array_equal(leg.goal[locked], q[locked])
                q = leg.goal


def test_postponed_leaves_a_coordinate_to_the_last_leg_that_moves_it(sim4):
    system, q0, qd = sim4.system, sim4.start, sim4.goal
    cons = boundary_configurations(system, q0, qd, ("S1", "S2"), "conservative")
    post = boundary_configurations(system, q0, qd, ("S1", "S2"), "postponed")
    np.testing.assert_allclose(cons[0], (0, PI / 3, PI / 4, -PI / 12), atol=1e-15)
    # q3 and θ are moved by S2 later: postponed leaves them; q2 only S1 moves: set now
    np.testing.assert_allclose(post[0], (0, PI / 3, 0, 0), atol=1e-15)
    np.testing.assert_array_equal(post[-1], qd)
    # (S3, S2, S1): every coordinate S3 moves is moved again later, so leg 1 only loops
    post = boundary_configurations(system, q0, qd, ("S3", "S2", "S1"), "postponed")
    np.testing.assert_allclose(post[0], q0, atol=0)
    np.testing.assert_allclose(post[1], (-PI / 3, PI / 4, 0, 0), atol=1e-15)


def test_two_level_strata_on_the_two_arm_model():
    task = load_scenario(ROOT / "scenarios" / "sim2.toml")
    system = task.system
    assert moved_coordinates(system, "S12") == (2, 3, 4)  # q3, q4, θ
    dec = decompose(system, task.start, task.goal, max_length=2)
    assert ("S13",) in dec.sequences and ("S1",) in dec.sequences
    legs = {c.sequence: c.legs for c in dec.candidates}
    # S12 locks q1, q2: it sets q4 (and keeps θ, not essential); S34 then sets q2
    (via,) = [leg.goal for leg in legs[("S12", "S34")][:-1]]
    np.testing.assert_allclose(via, (0, PI / 3, 0, -PI / 3, 0), atol=1e-15)
    # plan the one-leg candidates (two-level S13 among them), shared work, Newton
    short = [c for c in dec.candidates if len(c.sequence) == 1]
    settings = _newton(task.settings)
    result = compare(system, task.start, short, settings)
    assert {o.candidate.sequence for o in result.outcomes} == {("S1",), ("S3",), ("S13",)}
    assert result.best.ok
    for o in result.outcomes:
        again = plan_sequence(system, task.start, list(o.candidate.legs), settings)
        assert o.plan.total_energy == again.total_energy


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
    result = compare(system, task.start, dec.candidates, _newton(task.settings))
    best, other = (result.outcomes[k] for k in result.ranking)
    assert best.candidate.sequence == ("drive", "turn") and best.ok
    # heading π/2 first, the car can no longer reach x = 1: failed, with its reason
    assert not other.ok and other.rank == 2
    assert "leg 2 on drive" in other.reason and "did not reach its goal" in other.message


def test_biped_unprescribed_coordinates_are_left_to_the_planner():
    task = load_scenario(ROOT / "scenarios" / "biped.toml")
    goal = np.array([np.nan, np.nan, np.nan, 0.5, -0.5])
    dec = decompose(task.system, task.start, goal, max_length=2)
    assert dec.essential == (3, 4)
    assert ("S12",) in dec.sequences
    legs = {c.sequence: c.legs for c in dec.candidates}[("S1", "S12")]
    # S1 moves the body: x, y, θ free ("*"), the legs set; S12 locks the body
    np.testing.assert_array_equal(np.isnan(legs[0].goal), [True, True, True, False, False])
    np.testing.assert_array_equal(legs[0].goal[3:], [0.5, -0.5])


def test_nothing_to_decompose_and_too_short_are_input_errors(sim4):
    with pytest.raises(InputError, match="nothing to decompose"):
        decompose(sim4.system, sim4.start, sim4.start, max_length=3)
    with pytest.raises(InputError, match="the shortest needs 2") as info:
        decompose(sim4.system, sim4.start, sim4.goal, max_length=1)
    assert info.value.problems[0].path == "max_length"
    with pytest.raises(InputError, match="moves q1") as info:
        decompose(sim4.system, sim4.start, sim4.goal, strata=["S1"])
    assert info.value.problems[0].path == "strata"


def test_pi_fractions():
    assert [pi_fraction(x) for x in (-PI / 3, PI / 4, -PI / 12, 0.0, 2 * PI / 3, PI)] == [
        "-π/3",
        "π/4",
        "-π/12",
        "0",
        "2π/3",
        "π",
    ]
    assert pi_fraction(0.5) is None and pi_fraction(PI / 3 + 1e-9) is None
    assert format_configuration([0, PI / 3, 0.5, np.nan]) == "(0, π/3, 0.5, *)"
    assert format_configuration([0, PI / 3], "rad") == "(0, 1.0472)"


# ------------------------------------------------------------------------------------------
# Sharing and ranking
# ------------------------------------------------------------------------------------------


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
    energies = [result.outcomes[k].energy for k in result.ranking if result.outcomes[k].ok]
    assert energies == sorted(energies)
    assert "lowest total energy" in result.choice()
    by_peak = compare(
        sim4.system, sim4.start, dec.candidates[:6], sim4.settings, criterion="peak-control"
    )
    peaks = [by_peak.outcomes[k].peak_control for k in by_peak.ranking]
    assert peaks == sorted(peaks)


# ------------------------------------------------------------------------------------------
# Command line
# ------------------------------------------------------------------------------------------


def test_decompose_command_lists_the_papers_sequences(tmp_path):
    result = runner.invoke(cli.app, ["decompose", str(AUTO)])
    assert result.exit_code == 0, result.output
    assert "essential coordinates: q1, q2, q3, theta" in result.output
    out = result.output
    assert "S3 → S2 → S1" in out and "-π/12" in out and "-0.2618" in out  # π and radians
    doc = json.loads(runner.invoke(cli.app, ["decompose", str(AUTO), "--json"]).stdout)
    rows = {tuple(r["sequence"]): r for r in doc["sequences"]}
    assert rows[("S3", "S2", "S1")]["vias_pi"] == [
        ["-π/3", "π/3", "0", "-π/12"],
        ["-π/3", "π/3", "π/4", "-π/12"],
    ]
    assert rows[("S1", "S2")]["vias_pi"] == [["0", "π/3", "π/4", "-π/12"]]
    both = json.loads(
        runner.invoke(
            cli.app, ["decompose", str(AUTO), "--json", "--strategy", "both", "--max-length", "2"]
        ).stdout
    )
    assert len(both["sequences"]) == 12 and both["strategies"] == ["conservative", "postponed"]


def test_compare_sequences_writes_the_record_and_jobs_do_not_matter(tmp_path, newton):
    docs, results = [], []
    for jobs in ("1", "2"):
        out = tmp_path / jobs
        args = ["compare-sequences", str(AUTO), "--max-length", "2", "--strategy", "both"]
        result = runner.invoke(
            cli.app, [*args, "--jobs", jobs, "--out", str(out), "--no-animation"]
        )
        assert result.exit_code == 0, result.output
        assert "best: (" in result.output and "legs planned" in result.output
        (run_dir,) = out.iterdir()
        names = {p.name for p in run_dir.iterdir()}
        assert {"comparison.json", "comparison.csv", "ranking.png", "result.json"} <= names
        assert {"manifest.json", "scenario.toml", "resolved.json"} <= names
        assert (run_dir / "ranking.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        doc = json.loads((run_dir / "comparison.json").read_text())
        csv = (run_dir / "comparison.csv").read_text().splitlines()
        assert len(csv) == 1 + len(doc["rows"]) == 13 and csv[0].startswith("rank,sequence")
        best = json.loads((run_dir / "result.json").read_text())
        assert [leg["stratum"] for leg in best["legs"]] == doc["rows"][0]["sequence"]
        assert best["total_energy"] == doc["rows"][0]["energy"]
        resolved = json.loads((run_dir / "resolved.json").read_text())
        assert [leg["stratum"] for leg in resolved["legs"]] == doc["rows"][0]["sequence"]
        assert runner.invoke(cli.app, ["show", str(run_dir)]).exit_code == 0
        docs.append(doc)
        results.append(best)
    assert docs[0]["jobs"] == 1 and docs[1]["jobs"] == 2
    assert without_timings(docs[0]) == without_timings(docs[1])
    assert results[0] == results[1]


def test_plan_in_auto_mode_chooses_and_says_why(tmp_path, newton):
    result = runner.invoke(cli.app, ["plan", str(AUTO), "--out", str(tmp_path), "--no-animation"])
    assert result.exit_code == 0, result.output
    assert "auto mode: 18 candidate sequences" in result.output
    assert "lowest total energy" in result.output and "total energy" in result.output
    (run_dir,) = tmp_path.iterdir()
    doc = json.loads((run_dir / "result.json").read_text())
    comparison = json.loads((run_dir / "comparison.json").read_text())
    assert doc["status"] == "ok" and doc["scenario"] == "sim4_auto"
    ok = [r["energy"] for r in comparison["rows"] if r["status"] == "ok"]
    assert doc["total_energy"] == min(ok)
    assert [leg["stratum"] for leg in doc["legs"]] == comparison["rows"][0]["sequence"]


BAD = {
    "max_length": ("max_length = 3", "max_length = 0", "decompose.max_length: Input should be"),
    "strategy": (
        'strategy = "conservative"',
        'strategy = "eager"',
        "decompose.strategy: Input should be 'conservative', 'postponed' or 'both'",
    ),
    "criterion": (
        'criterion = "energy"',
        'criterion = "cost"',
        "decompose.criterion: Input should be",
    ),
    "unknown key": (
        "max_length = 3",
        "max_len = 3",
        "decompose.max_len: unknown key (allowed: max_length, strategy, criterion, strata)",
    ),
    "strata": (
        "max_length = 3",
        'max_length = 3\nstrata = ["S1", "S9"]',
        "decompose.strata[1]: unknown stratum 'S9' (this model has: S1, S2, S3)",
    ),
    "neither": ("[decompose]", "[other]", "legs: give either [[legs]]"),
    "too short": (
        "max_length = 3",
        "max_length = 1",
        "decompose.max_length: no sequence of at most 1 strata",
    ),
    "strata move too little": (
        "max_length = 3",
        'max_length = 3\nstrata = ["S1"]',
        "decompose.strata: none of the strata listed moves q1",
    ),
}


@pytest.mark.parametrize("case", list(BAD), ids=list(BAD))
def test_bad_decompose_values_exit_2_naming_the_field(tmp_path, case):
    old, new, message = BAD[case]
    text = AUTO_TEXT.replace(old, new, 1)
    if case == "neither":
        text = text.split("[other]")[0]
    path = tmp_path / "auto.toml"
    path.write_text(text)
    result = runner.invoke(cli.app, ["decompose", str(path)])
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    lines = [x for x in result.output.splitlines() if x.startswith("error:")]
    assert lines and all(str(path) in x for x in lines)
    assert any(message in x for x in lines), result.output


def test_bad_options_exit_2_naming_the_option():
    result = runner.invoke(cli.app, ["compare-sequences", str(AUTO), "--strategy", "eager"])
    assert result.exit_code == 2 and "--strategy: must be conservative, postponed or both" in (
        result.output
    )
    result = runner.invoke(cli.app, ["decompose", str(AUTO), "--max-length", "1"])
    assert result.exit_code == 2 and "--max-length: no sequence of at most 1 strata" in (
        result.output
    )
