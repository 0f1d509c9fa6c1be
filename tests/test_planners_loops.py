"""The loop starts of the energy search (`planners.loops`) and the curvature they read."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import IPOPT_BEST, energy_plan
from reintegrate import verify

from stratcli.curvature import curvature, driven
from stratcli.planners import loops
from stratcli.records.result import result_document
from stratcli.resultdoc import plan_document
from stratcli.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"


def _stratum(name: str = "sim4_task_a", stratum: str = "S2"):
    task = load_scenario(SCENARIOS / f"{name}.toml")
    cs = task.system.compiled(stratum)
    return task, cs, driven(cs)


@pytest.mark.parametrize("name", ["sim1_l_c1", "sim4_task_a"])
def test_a_loop_start_reaches_a_lower_minimum_than_the_plain_starts(name):
    """On Sim 1 (l-C1) and Sim 4 A the plain starts end with one large loop in the S2 leg; a
    loop start (two turns round the nearest curvature peak) ends lower, at or below the best
    IPOPT found on the same Fourier problem, and the plan keeps it: a true minimum that
    re-integrates independently onto every via with continuous controls at the switches."""
    task = load_scenario(SCENARIOS / f"{name}.toml")
    plain = energy_plan(task, "starts")
    task = task.with_changes({"planner": {"search": "loops"}})
    looped = energy_plan(task, "loops")
    assert looped.ok and plain.ok
    opt = looped.optimisation
    best = opt.starts[opt.best]
    assert best.kind == "loop" and best.projected_gradient <= 1e-8
    # the other starts are the plain search's, raced as without the loop starts
    others = [s.energy for s in opt.starts if s.kind != "loop"]
    assert others == [s.energy for s in plain.optimisation.starts]
    assert looped.total_energy < 0.95 * plain.total_energy  # another, lower basin
    assert looped.total_energy <= IPOPT_BEST[name]
    verify(task, result_document(looped, task.scenario.name, task.model_name))


def test_a_loop_start_that_ends_higher_is_raced_but_not_kept():
    """Sim 1 lr-C1 races a loop start that does not end lower: the plan is the plain
    search's, its other starts raced as without it."""
    task = load_scenario(SCENARIOS / "sim1_lr_c1.toml")
    plain = energy_plan(task, "starts")
    looped = energy_plan(task, "loops")
    opt = looped.optimisation
    kinds = [s.kind for s in opt.starts]
    assert "loop" in kinds and opt.starts[opt.best].kind != "loop"
    others = [s.energy for s in opt.starts if s.kind != "loop"]
    assert others == [s.energy for s in plain.optimisation.starts]
    assert looped.total_energy == plain.total_energy


def test_a_loop_start_at_the_plain_minimum_does_not_change_the_plan(monkeypatch):
    """A loop start that leads back to the minimum the other starts reached (here: that
    minimum itself) is not a new plan: the best start stays the plain search's."""
    from stratcli.planners import energy

    task = load_scenario(SCENARIOS / "sim4_task_d.toml")
    plain = energy_plan(task, "starts")
    monkeypatch.setattr(energy, "loop_starts", lambda problem, z: ([z.copy()], ""))
    looped = energy_plan(task, "loops")
    opt = looped.optimisation
    assert [s.kind for s in opt.starts][-1] == "loop"
    assert opt.best == plain.optimisation.best
    assert looped.total_energy == plain.total_energy


@pytest.mark.parametrize(
    ("name", "search", "why"),
    [
        ("sim4_task_d", "loops", loops.NO_PATH),
        ("unicycle", "loops", loops.NO_LEG),
        ("sim4_task_a", "loops", ""),
        ("sim4_task_d", "starts", ""),
    ],
    ids=["D", "unicycle", "A", "D starts"],
)
def test_the_record_says_which_search_ran_and_why_it_made_no_loop_start(name, search, why):
    """result.json's optimisation holds the search as run and why the loop search made no
    loop start: Sim 4 D's loops all cost more than the screen allows, the unicycle has no
    leg whose two inputs each drive one joint; task A made one, and with `search = "starts"`
    none was looked for (both empty). The record reads back the same."""
    task = load_scenario(SCENARIOS / f"{name}.toml")
    found = energy_plan(task, search)
    opt = found.optimisation
    assert (opt.search, opt.no_loop_start) == (search, why)
    assert any(s.kind == "loop" for s in opt.starts) == (name == "sim4_task_a")
    doc = plan_document(found)
    assert (doc["optimisation"]["search"], doc["optimisation"]["no_loop_start"]) == (search, why)
    again = type(found).from_dict(doc).optimisation
    assert (again.search, again.no_loop_start) == (search, why)


@pytest.mark.parametrize("why", ["not fitted", "not numbers", "no minimum"])
def test_a_search_whose_loop_starts_fail_says_why(why, monkeypatch):
    """Task A makes a loop start; where no loop path is fitted onto the goals, where the
    geometry breaks down, or where no start reached a minimum to begin from, the plan is the
    plain search's and the record names that reason."""
    from stratcli.planners import energy

    expected = {
        "not fitted": loops.NOT_FITTED,
        "not numbers": loops.NOT_NUMBERS,
        "no minimum": energy.NO_MINIMUM,
    }[why]
    if why == "not fitted":
        monkeypatch.setattr(loops, "_fitted", lambda *args: None)
    elif why == "not numbers":
        monkeypatch.setattr(loops, "_peaks", lambda *args: 1 / 0)
    else:
        monkeypatch.setattr(energy, "MINIMUM", ())
    task = load_scenario(SCENARIOS / "sim4_task_a.toml")
    found = energy_plan(task, "loops")
    opt = found.optimisation
    assert opt.no_loop_start == expected and "loop" not in [s.kind for s in opt.starts]


# A custom model whose first input drives its joint backwards (q̇_a = -u1): the curvature is
# taken in the plane of the inputs' integrals, whose orientation the sign flips.
BACKWARDS = {
    "name": "backwards",
    "model": {
        "kind": "custom",
        "states": ["a", "b", "th"],
        "inputs": ["u1", "u2"],
        "fields": {
            "u1": [-1, 0, "0.3*cos(b) + sin(a)*sin(b)"],
            "u2": [0, 1, "0.5*sin(a)*cos(2*b)"],
        },
        "strata": [{"name": "S", "active": ["u1", "u2"]}],
    },
    "task": {"start": [0, 0, 0], "goal": [0.5, 0.3, 3.0]},
    "legs": [{"stratum": "S"}],
}


def _strata():
    """(start, compiled stratum, driven inputs) of Sim 4's S2 and of the backwards model."""
    task, cs, inputs = _stratum()
    yield np.asarray(task.start, float), cs, inputs
    task = load_scenario(BACKWARDS)
    cs = task.system.compiled("S")
    yield np.asarray(task.start, float), cs, driven(cs)


@pytest.mark.parametrize("which", [0, 1], ids=["sim4 S2", "backwards input"])
def test_the_curvature_is_the_curl_of_the_connection(which):
    """F = ∂A_2/∂w_1 - ∂A_1/∂w_2 (w the inputs' integrals, q_j = q_j0 ± w) against central
    differences of the connection itself, also where an input drives its joint backwards."""
    start, cs, inputs = list(_strata())[which]
    (j0, s0), (j1, s1) = inputs
    assert which == 0 or s0 * s1 < 0
    rng = np.random.default_rng(5)
    q = np.repeat(start[None], 6, axis=0)
    q[:, [j0, j1]] = rng.uniform(-3, 3, (6, 2))
    F, A = curvature(cs, q, inputs, 0)
    h = 1e-6

    def connection(q):
        return cs.quadrature_terms(q, 0)[0][:, 0, :]  # (K, 2 inputs)

    def along(j, sign):
        up, down = q.copy(), q.copy()
        up[:, j] += sign * h
        down[:, j] -= sign * h
        return (connection(up) - connection(down)) / (2 * h)

    curl = along(j0, s0)[:, 1] - along(j1, s1)[:, 0]
    np.testing.assert_allclose(F, curl, rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(A[:, 0, :], connection(q), rtol=0, atol=0)


def test_a_lollipop_runs_at_constant_speed_from_start_to_end_winding_its_turns():
    start, end, centre = np.array([0.0, 0.8]), np.array([-1.0, 0.8]), np.array([1.9, 1.5])
    s = np.linspace(0.0, 1.0, 4001)
    for turns in (1, 2):
        for sense in (1.0, -1.0):
            (path,) = loops.lollipop(start, end, centre, [turns], [sense], [0.7], s)[0]
            np.testing.assert_allclose(path[0], start, atol=1e-12)
            np.testing.assert_allclose(path[-1], end, atol=1e-12)
            steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
            length = loops._length(start, end, centre, turns, sense, 0.7)
            # equal steps of the path's length (chords, on the circle), but the two that cut
            # its corners
            assert np.sum(np.abs(steps - length / steps.size) > 1e-5 * steps.mean()) <= 2
            assert steps.sum() == pytest.approx(length, rel=1e-4)
            # winding number about the centre: the angle swept, in turns
            angle = np.unwrap(np.arctan2(*(path - centre).T[::-1]))
            assert (angle[-1] - angle[0]) / (2 * math.pi) == pytest.approx(sense * turns, abs=0.1)


@pytest.mark.parametrize("which", [0, 1], ids=["sim4 S2", "backwards input"])
def test_a_small_circle_turns_the_base_by_its_curvature_times_its_area(which):
    """Stokes: round a circle of radius r about c, `turns` times in the joints' plane, the
    base turns by about s0 s1 x turns x F(c) x πr² (the trapezoid rule on the path, against
    the curvature; s0 s1 = -1 where one input drives its joint backwards, which turns the
    circle's sense in the plane of the inputs' integrals)."""
    q_s, cs, inputs = list(_strata())[which]
    signs = inputs[0][1] * inputs[1][1]
    centre, radius = np.array([0.4, -0.7]), 0.02
    on = centre + np.array([radius, 0.0])  # start = end on the circle: a closed path
    s = np.linspace(0.0, 1.0, 801)
    q_c = q_s.copy()
    q_c[[inputs[0][0], inputs[1][0]]] = centre
    F = curvature(cs, q_c[None], inputs, 0)[0][0]
    assert abs(F) > 1e-3  # a circle that turns the base
    for turns, sense in ((1, 1.0), (2, -1.0)):
        paths = loops.lollipop(on, on, centre, [turns], [sense], [radius], s)
        turned = loops._turns(cs, q_s, inputs, paths)[0, 0]
        expected = signs * sense * turns * F * math.pi * radius**2
        assert turned == pytest.approx(expected, rel=1e-3)


def test_only_strata_with_two_driven_joints_are_loop_strata():
    """A stratum is a loop stratum when exactly two inputs each drive one joint: the
    two-arm robot's S12..S34 are, its three-input S1..S4 and the unicycle's are not."""
    two_arm = load_scenario(SCENARIOS / "sim2.toml").system
    for name, stratum in two_arm.strata.items():
        inputs = driven(two_arm.compiled(name))
        assert (inputs is not None) == (len(stratum.active) == 2)
        if inputs is not None:
            assert sorted(j for j, _ in inputs) == sorted(stratum.active)
    unicycle = load_scenario(SCENARIOS / "unicycle.toml").system
    assert all(driven(unicycle.compiled(name)) is None for name in unicycle.strata)
