"""The loop starts of the energy search (`planners.loops`) and the curvature they read."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from reintegrate import verify

from stratcli.curvature import curvature, driven
from stratcli.objectives import plan_sequence
from stratcli.planners import loops
from stratcli.records.result import result_document
from stratcli.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
# the best minimum CasADi/IPOPT found on the same Fourier problem (issue 15, item 1)
IPOPT_BEST = {"sim1_l_c1": 367.30, "sim4_task_a": 448.04}


def _stratum(name: str = "sim4_task_a", stratum: str = "S2"):
    task = load_scenario(SCENARIOS / f"{name}.toml")
    cs = task.system.compiled(stratum)
    return task, cs, driven(cs)


def energy_plan(task, search):
    settings = replace(task.settings, objective="energy", search=search)
    return plan_sequence(task.system, task.start, task.legs, settings)


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


def test_the_loop_starts_never_raise_the_energy_and_are_raced_after_the_others():
    """Where no loop pays (Sim 4 D's minimum is its lowest), the plan is the plain search's."""
    task = load_scenario(SCENARIOS / "sim4_task_d.toml")
    plain = energy_plan(task, "starts")
    looped = energy_plan(task, "loops")
    kinds = [s.kind for s in looped.optimisation.starts]
    assert kinds[: len(plain.optimisation.starts)] == [s.kind for s in plain.optimisation.starts]
    assert set(kinds[len(plain.optimisation.starts) :]) <= {"loop"}
    assert looped.total_energy <= plain.total_energy * (1 + 1e-9)


def test_the_curvature_is_the_curl_of_the_connection():
    """F = ∂A_2/∂w_1 - ∂A_1/∂w_2 (w the inputs' integrals, q_j = q_j0 ± w) against central
    differences of the connection itself."""
    task, cs, inputs = _stratum()
    (j0, s0), (j1, s1) = inputs
    rng = np.random.default_rng(5)
    q = np.repeat(np.asarray(task.start, float)[None], 6, axis=0)
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


def test_a_small_circle_turns_the_base_by_its_curvature_times_its_area():
    """Stokes: round a circle of radius r about c, `turns` times, the base turns by about
    turns x F(c) x πr² (the trapezoid rule on the path, against the curvature)."""
    task, cs, inputs = _stratum()
    q_s = np.asarray(task.start, dtype=float)
    centre, radius = np.array([0.4, -0.7]), 0.02
    on = centre + np.array([radius, 0.0])  # start = end on the circle: a closed path
    s = np.linspace(0.0, 1.0, 801)
    q_c = q_s.copy()
    q_c[[inputs[0][0], inputs[1][0]]] = centre
    F = curvature(cs, q_c[None], inputs, 0)[0][0]
    for turns, sense in ((1, 1.0), (2, -1.0)):
        paths = loops.lollipop(on, on, centre, [turns], [sense], [radius], s)
        turned = loops._turns(cs, q_s, inputs, paths)[0, 0]
        assert turned == pytest.approx(sense * turns * F * math.pi * radius**2, rel=1e-3)


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
