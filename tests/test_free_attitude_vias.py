"""A URDF via whose attitude is left free ("*"): the energy search starts the next leg where
the leg before ends (`stacked._chained`), so the energy it finds is the plan's own.

It held the next leg's start where the Newton plan left the via, and re-chaining its controls
re-planned that leg: a new user's arm3 task was searched to 28.31 and planned at 28.78."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

from spatial_reintegrate import verify_spatial  # noqa: E402

from stratcli.api import plan_run  # noqa: E402
from stratcli.planners.stacked import StackedProblem  # noqa: E402
from stratcli.scenario import load_scenario, parse_scenario  # noqa: E402
from stratcli.stratified import nominal_starts  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

TEXT = f"""
name = "free_via"
[model]
kind = "urdf"
path = "{ROOT / "robots" / "arm3.urdf"}"
[task]
start = {{ j1 = 0, j2 = "20deg", j3 = "-30deg", attitude = [0, 0, 0] }}
goal = {{ j1 = "40deg", j2 = "10deg", j3 = "-10deg", rpy = ["2deg", 0, "-4deg"] }}
[planner]
tolerance = 1e-6
leg_duration = 2.0
[[legs]]
stratum = "S3"
goal = {{ j1 = "40deg", j2 = "10deg", j3 = "-30deg", attitude = {{via}} }}
[[legs]]
stratum = "S2"
"""


def _task(via='"*"'):
    return parse_scenario(TEXT.replace("{via}", via))


def _planar(name: str, tolerance=1e-8, obstacles=False):
    """A shipped planar task with θ free at every via (`sim4_task_d_obstacles`: obstacles)."""
    raw = tomllib.loads((ROOT / "scenarios" / f"{name}.toml").read_text())
    for leg in raw["legs"][:-1]:
        leg["goal"][-1] = "*"
    raw.pop("reference", None)
    raw["planner"]["tolerance"] = tolerance
    return load_scenario(raw), raw


def _searched(task):
    """The plan of `task` (the energy objective), checked to be the search's own: its energy
    the best start's, no leg re-planned by re-chaining."""
    outcome = plan_run(task, check=False)
    plan = outcome.result
    assert plan.ok, plan.message
    joints = task.system.n - (3 if getattr(task.system, "spatial", None) else 1)  # then θ/R
    held = any(n.startswith("the energy search held") for n in plan.notes)
    assert held == any(np.isnan(leg.goal[:joints]).any() for leg in task.legs[:-1])
    best = plan.optimisation.starts[plan.optimisation.best]
    assert plan.total_energy == pytest.approx(best.energy, rel=1e-9)
    assert not any("re-chained" in note for note in plan.notes)
    assert all(leg.iterations == 0 for leg in plan.legs)  # re-chaining polished nothing
    return outcome


def _stacked(task, scale: float, seed: int):
    """The stacked problem seeded from the Newton plan of `task`, a point near that plan, and
    a problem of the same legs whose leg 2 starts where leg 1 ends there (none chained)."""
    newton = plan_run(task.with_changes({"planner.objective": "newton"}), check=False).result
    legs = list(task.legs)
    targets = [np.array(leg.targets, dtype=int) for leg in newton.legs]
    problem = StackedProblem(
        task.system, nominal_starts(task.start, legs, newton), legs, task.settings, targets
    )
    lam = np.concatenate([leg.coefficients.ravel() for leg in newton.legs])
    rng = np.random.default_rng(seed)
    z = problem.project(lam) + scale * rng.standard_normal(problem.null.shape[1])
    end = problem.endpoints[0](problem.split(problem.coefficients(z))[0], False)[0]
    k = task.system.n - (3 if problem.chained[1] == "rotation" else 1)  # the attitude's first
    started = [ep.q0 for ep in problem.endpoints]
    assert not np.allclose(end[k:], started[1][k:], atol=1e-4)  # leg 1 moved the via's
    started[1] = np.concatenate([started[1][:k], end[k:]])
    direct = StackedProblem(task.system, started, legs, task.settings, targets)
    direct.chained = [None] * len(legs)
    return problem, z, direct


def _differences(f, z, h=1e-6):
    """Central differences of `f` at z, one column per coordinate of z."""
    columns = []
    for j in range(z.size):
        e = np.zeros(z.size)
        e[j] = h
        columns.append((f(z + e) - f(z - e)) / (2 * h))
    return np.stack(columns, axis=-1)


@pytest.mark.parametrize("via", ['"*"', '["*", 0.01, "*"]'])
def test_the_search_energy_is_the_plans_and_it_verifies(via):
    task = _task(via)
    verify_spatial(_searched(task).document, task.system.spatial)


@pytest.mark.parametrize("name", ["arm7_three_legs", None])
def test_chained_goal_jacobian_equals_central_differences(name):
    spatial = ROOT / "scenarios" / "spatial"
    task = _task() if name is None else load_scenario(spatial / f"{name}.toml")
    problem, z, direct = _stacked(task, 0.01, 0)
    assert problem.chained[:2] == [None, "rotation"]
    for ep in (*problem.endpoints, *direct.endpoints):
        ep.steps_override = 200  # one discrete map: its derivative is exact
    J = problem.constraint_jac(z).copy()
    np.testing.assert_allclose(J, _differences(problem.constraint, z), atol=1e-8 * np.abs(J).max())
    # leg 2's residual is that of leg 2 started where leg 1 ends
    rows = slice(problem.targets[0].size, problem.targets[0].size + problem.targets[1].size)
    np.testing.assert_allclose(direct.constraint(z)[rows], problem.constraint(z)[rows], atol=1e-12)


# ---- a planar base's θ: a quadrature coordinate, chained by adding ----------------------


@pytest.mark.parametrize("name", ["sim4_task_a", "sim4_task_c"])
def test_a_free_theta_via_chains_the_legs_and_verifies(name):
    """Task A with θ free at its via was planned at 443.06 (the search held leg 2's start
    where Newton left θ; re-chaining left the goal off by ~5e-4, within 1e-3); chained, the
    search's plan is the plan, on the goals to rounding."""
    from reintegrate import verify

    task = _planar(name)[0]
    outcome = _searched(task)
    assert all(leg.error < 1e-9 for leg in outcome.result.legs)
    verify(task, outcome.document)  # goals, continuity and energies on re-integration


def test_the_chained_hessian_equals_differences_of_the_jacobian():
    problem, z, _ = _stacked(_planar("sim4_task_c", tolerance=1e-3)[0], 0.01, 1)
    assert [link is not None for link in problem.chained] == [False, True, True]
    mu = np.random.default_rng(1).standard_normal(problem.n_residuals)
    H = problem.constraint_hessian(z, mu)
    fd = _differences(lambda z: problem.constraint_jac(z).T @ mu, z)
    np.testing.assert_allclose(H, fd, atol=1e-6 * np.abs(H).max())


def test_obstacle_margins_follow_a_chained_theta():
    """Obstacles are measured at θ along each leg: a chained leg's θ starts where the leg
    before ends (`StackedProblem.start_shifts`), as a problem started there measures it, and
    the margins' Jacobian follows leg 1's coefficients through it."""
    from stratcli.constraints import ConstraintsSpec, resolve
    from stratcli.node_margins import NodeMargins

    task, raw = _planar("sim4_task_d_obstacles", tolerance=1e-3)
    constraints = resolve(ConstraintsSpec.model_validate(raw["constraints"]), task.system)
    problem, z, direct = _stacked(task, 0.05, 2)
    assert problem.chained[1].tolist() == [3]
    margins = NodeMargins(problem, task.system, constraints, nodes=16)
    g, G = (a.copy() for a in margins(z, jacobian=True))
    g_direct = NodeMargins(direct, task.system, constraints, nodes=16)(z, False)[0]
    np.testing.assert_allclose(g_direct, g, atol=1e-10)
    moving = np.abs(G).sum(axis=1) > 0  # (rows beyond reach have no slope)
    fd = _differences(lambda z: margins(z, False)[0], z)
    np.testing.assert_allclose(G[moving], fd[moving], atol=1e-5)


def test_a_free_theta_via_under_obstacles_plans_clear():
    """With θ free at the via, the plan is verified clear of the obstacles (dense
    re-integration), planned as one chain (no leg re-planned after the search)."""
    plan = plan_run(_planar("sim4_task_d_obstacles", tolerance=1e-3)[0], check=False).result
    assert plan.ok, plan.message
    margins = [m.obstacle_clearance for m in plan.constraints.legs]
    assert len(margins) == 2 and min(margins) >= -1e-6
    assert not any(note.startswith("constrained search from the re-chained") for note in plan.notes)


def test_a_free_joint_at_a_via_is_held_so_the_plan_is_the_searchs():
    """Task D with q2 (a joint) and θ free at its via: the search moved leg 1's q2 where leg 2,
    started at its nominal start, did not follow, and re-chaining re-planned leg 2 (96.00,
    above the 67.61 of before θ chained). q2 is held where the Newton plan left it
    (`stacked._held`), θ chained: the search's plan is the plan."""
    from reintegrate import verify

    raw = tomllib.loads((ROOT / "scenarios" / "sim4_task_d.toml").read_text())
    raw["legs"][0]["goal"] = ["-pi/3", "*", 0, "*"]
    raw["planner"]["tolerance"] = 1e-8
    raw.pop("reference")
    task = load_scenario(raw)
    outcome = _searched(task)
    verify(task, outcome.document)
    newton = plan_run(task.with_changes({"planner.objective": "newton"}), check=False).result
    q2 = outcome.result.legs[0].end[1]
    assert q2 == pytest.approx(newton.legs[0].end[1], abs=1e-8)  # held there, and said so
    (note,) = [n for n in outcome.result.notes if n.startswith("the energy search held")]
    assert note.startswith(f"the energy search held leg 1's via q2 {q2:.4g} where the Newton")


def test_a_free_via_coordinate_that_later_legs_keep_locked_takes_the_goals_value():
    """Task D with q1 free at its via: leg 2 (S1) locks q1, so the plan ended where leg 1
    left it, 1.24 rad from the goal, with every leg's error tiny and status ok."""
    from stratcli.leg_checks import pinned_vias
    from stratcli.models.presets import preset
    from stratcli.stratified import LegSpec

    raw = tomllib.loads((ROOT / "scenarios" / "sim4_task_d.toml").read_text())
    raw["legs"][0]["goal"] = ["*", "pi/3", 0, "-pi/12"]
    task = load_scenario(raw)
    assert task.legs[0].goal[0] == pytest.approx(-np.pi / 3)  # pinned to the goal's q1
    plan = plan_run(task, check=False).result
    assert plan.ok
    np.testing.assert_allclose(plan.end, task.goal, atol=task.settings.tolerance)
    # through two legs that lock it, and a given value left alone (check_legs judges it)
    system, nan = preset("one-arm"), np.nan
    legs = [
        LegSpec("S3", np.array([nan, 0.2, 0.0, nan])),
        LegSpec("S1", np.array([nan, 0.3, 0.1, nan])),
        LegSpec("S1", np.array([-1.0, 0.4, 0.2, 0.1])),
    ]
    pinned = pinned_vias(system, legs)
    assert [leg.goal[0] for leg in pinned] == [-1.0, -1.0, -1.0]
    assert all(np.isnan(leg.goal[3]) for leg in pinned[:2])  # θ moves on every stratum
    given = [legs[0], LegSpec("S1", np.array([0.5, 0.3, 0.1, nan])), legs[2]]
    assert pinned_vias(system, given)[1].goal[0] == 0.5
