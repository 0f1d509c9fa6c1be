"""Task decomposer (paper §5.3): essential coordinates, sequences, vias."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from conftest import (
    ROOT,
    newton_objective,
)

from stratcli.compare import compare
from stratcli.decomposition import (
    boundary_configurations,
    candidate_strata,
    decompose,
    enumerate_sequences,
    essential_coordinates,
    moved_coordinates,
)
from stratcli.errors import InputError
from stratcli.format import format_configuration, pi_fraction
from stratcli.leg_checks import check_legs
from stratcli.objectives import plan_sequence
from stratcli.scenario import load_scenario

PI = math.pi


# Paper Sim 4 (DESIGN §11): the sequences of tasks A-D and their printed via configurations.
PAPER = {
    ("S1", "S2"): [(0, PI / 3, PI / 4, -PI / 12)],
    ("S2", "S1"): [(-PI / 3, PI / 4, PI / 4, -PI / 12)],
    ("S3", "S2", "S1"): [(-PI / 3, PI / 3, 0, -PI / 12), (-PI / 3, PI / 3, PI / 4, -PI / 12)],
    ("S3", "S1"): [(-PI / 3, PI / 3, 0, -PI / 12)],
}


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
    settings = newton_objective(task.settings)
    result = compare(system, task.start, short, settings)
    assert {o.candidate.sequence for o in result.outcomes} == {("S1",), ("S3",), ("S13",)}
    assert result.best.ok
    for o in result.outcomes:
        again = plan_sequence(system, task.start, list(o.candidate.legs), settings)
        assert o.plan.total_energy == again.total_energy


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
    with pytest.raises(InputError, match="equals the start on every prescribed coordinate"):
        decompose(sim4.system, sim4.start, sim4.start, max_length=3)
    free = np.full_like(sim4.start, np.nan)  # every "*": it said "equals the start" too
    with pytest.raises(InputError, match=r'prescribes no coordinate \(every one is "\*"\)'):
        decompose(sim4.system, sim4.start, free, max_length=3)
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
