"""Node margins of the constrained search: the separating-axis gap is a lower bound of the
distance apart and minus the depth inside, and the Jacobian in the search's coordinates equals
finite differences (joints, self-collision, obstacles via θ)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from stratcli import load_scenario, plan
from stratcli.clearance import (
    box_corners,
    penetration,
    segment_polygon_distance,
    segment_segment_distance,
)
from stratcli.geometric_margins import GeometricMargins
from stratcli.models.geometry import world_bodies
from stratcli.node_margins import NodeMargins
from stratcli.planners.stacked import StackedProblem

ROOT = Path(__file__).resolve().parents[1]


def test_the_separating_axis_gap_bounds_the_distance_apart_and_is_the_depth_inside():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(2, 2000, 2)) * 1.5
    c, d = rng.normal(size=(2, 2000, 2)) * 1.5
    box = np.broadcast_to(box_corners([0.2, -0.1], [1.0, 0.6], 0.4), (2000, 4, 2))
    link, other = np.stack((a, b), axis=1), np.stack((c, d), axis=1)
    for gap, plain in (
        (-penetration(link, box), segment_polygon_distance(a, b, box)),
        (-penetration(link, other), segment_segment_distance(a, b, c, d)),
    ):
        apart = plain > 0
        # apart: a lower bound of the distance (conservative), positive, and equal to it
        # unless the closest points are two corners
        assert np.all(gap[apart] <= plain[apart] + 1e-12) and np.all(gap[apart] > 0)
        assert np.mean(np.isclose(gap[apart], plain[apart])) > 0.5
        assert np.all(gap[~apart] <= 1e-12)  # overlapping: minus a depth
    # a segment through the middle of a 2 x 2 box must move by 1 to get out
    square = box_corners([0, 0], [2.0, 2.0], 0.0)
    assert penetration(np.array([[0.0, -3.0], [0.0, 3.0]]), square) == pytest.approx(1.0)
    assert penetration(np.array([[0.5, -3.0], [0.5, 3.0]]), square) == pytest.approx(0.5)


def test_batched_clearances_are_each_pairs_separating_axis_gap_to_the_bit():
    """`GeometricMargins` measures all pairs at once; each column must be what
    `penetration` gives for that pair of bodies alone (its arithmetic), less the radii and
    the clearance, and a circle's column to a link the centre's distance to the segment."""
    raw = tomllib.loads((ROOT / "scenarios" / "sim4_task_d_constrained.toml").read_text())
    raw["constraints"]["clearance"] = 0.03
    raw["constraints"]["obstacles"] = [
        {"shape": "circle", "centre": [1.2, 0.8], "radius": 0.3},
        {"shape": "box", "centre": [-1.0, 1.5], "size": [0.4, 0.8], "rotation": 0.3},
        {"shape": "box", "centre": [0.4, -1.2], "size": [0.6, 0.2], "rotation": -0.7},
    ]
    c = load_scenario(raw).constraints
    robot = load_scenario(raw).system.robot
    q = np.random.default_rng(5).uniform(-3.0, 3.0, (300, robot.n_joints + 1))
    g, kinds = GeometricMargins(robot, c)(q)
    corners, links = world_bodies(robot, q)
    r, less = c.link_radius, c.clearance
    expected = {  # (bodies, gap): the columns of one arm of three links, in their order
        "link 0 - link 2": -penetration(links[:, 0], links[:, 2]) - 2 * r,
        "link 1 - base": -penetration(links[:, 1], corners) - r,
        "link 2 - base": -penetration(links[:, 2], corners) - r,
    }
    centre, radius = c.circles[0]
    expected["circle - base"] = -penetration(np.broadcast_to(centre, (300, 1, 2)), corners) - radius
    for i in range(3):
        a, b = links[:, i, 0], links[:, i, 1]
        t = np.clip(np.sum((centre - a) * (b - a), -1) / np.sum((b - a) ** 2, -1), 0, 1)
        distance = np.linalg.norm(centre - (a + t[:, None] * (b - a)), axis=-1)
        expected[f"circle - link {i}"] = distance - r - radius
    for o, box in enumerate(c.boxes):
        shape = np.broadcast_to(box, (300, 4, 2))
        expected[f"box {o} - base"] = -penetration(corners, shape)
        for i in range(3):
            expected[f"box {o} - link {i}"] = -penetration(links[:, i], shape) - r
    assert g.shape == (300, len(expected)) and kinds == ["self-collision"] * 3 + ["an obstacle"] * (
        len(expected) - 3
    )
    for column, (name, gap) in enumerate(expected.items()):
        if name.startswith("circle - link"):  # (a dot product in another order)
            np.testing.assert_allclose(g[:, column], gap - less, rtol=0, atol=1e-12)
        else:
            assert np.array_equal(g[:, column], gap - less), name
    assert (g < 0).any() and (g > 0).any()  # both overlapping and apart configurations


def _problem(raw):
    task = load_scenario(raw)
    result = plan({k: v for k, v in raw.items() if k != "constraints"})  # the free plan
    starts = [task.start, *[np.asarray(leg.goal) for leg in task.legs[:-1]]]
    targets = [np.array(leg.targets, dtype=int) for leg in result.legs]
    problem = StackedProblem(task.system, starts, task.legs, task.settings, targets)
    lam = np.concatenate([leg.coefficients.ravel() for leg in result.legs])
    return task, problem, problem.project(lam)


@pytest.mark.parametrize(("obstacles", "physical"), [(False, False), (True, False), (True, True)])
def test_the_jacobian_in_the_search_coordinates_equals_finite_differences(obstacles, physical):
    """(`physical`: a robot from its physical parameters, whose θ row is the closed-form
    connection rather than compiled rows.) The margins asked for without the Jacobian are
    those with it, to the bit, whichever is asked first."""
    raw = tomllib.loads((ROOT / "scenarios" / "sim4_task_d_constrained.toml").read_text())
    raw["planner"]["objective"] = "newton"
    if physical:
        model = tomllib.loads((ROOT / "scenarios" / "rods_three_link.toml").read_text())
        raw["model"] = model["model"]
    if obstacles:
        raw["constraints"]["obstacles"] = [
            {"shape": "circle", "centre": [1.2, 0.8], "radius": 0.3},
            {"shape": "box", "centre": [-1.0, 1.5], "size": [0.4, 0.8], "rotation": 0.3},
        ]
    task, problem, z = _problem(raw)
    margins = NodeMargins(problem, task.system, task.constraints, nodes=40)
    alone = margins(z, False)[0]
    g, G = margins(z)
    assert len(margins.labels) == g.size
    other = NodeMargins(problem, task.system, task.constraints, nodes=40)
    first = other(z)[0]
    assert np.array_equal(alone, g) and np.array_equal(other(z, False)[0], first)
    assert np.array_equal(first, g)
    rng = np.random.default_rng(0)
    direction = rng.normal(size=z.size)
    direction *= 1e-2 / np.linalg.norm(direction)
    h = 1e-4
    numeric = (margins(z + h * direction, False)[0] - margins(z - h * direction, False)[0]) / (
        2 * h
    )
    joints = np.array(["joint" in what for _, what in margins.labels])
    np.testing.assert_allclose(G[joints] @ direction, numeric[joints], atol=1e-8)
    # clearances: differenced in the configuration, piecewise smooth (kinks where the
    # closest features change): most rows agree closely
    close = np.abs(G[~joints] @ direction - numeric[~joints]) <= 1e-4 + 1e-3 * np.abs(
        numeric[~joints]
    )
    assert close.mean() > 0.97
    if obstacles:
        assert any(what == "an obstacle" for _, what in margins.labels)


def _jacobian_differences(margins, z, weights, rng):
    """A random unit direction and the central difference of `Gᵀ weights` along it."""
    direction = rng.normal(size=z.size)
    direction /= np.linalg.norm(direction)
    h = 1e-4
    plus = margins(z + h * direction)[1].T @ weights
    minus = margins(z - h * direction)[1].T @ weights
    return direction, (plus - minus) / (2 * h)


@pytest.mark.parametrize(
    ("scenario", "kind"),
    [("sim4_task_d_constrained", "self-collision"), ("sim4_task_d_obstacles", "an obstacle")],
)
def test_the_clearances_curvature_equals_differences_of_their_jacobian(scenario, kind):
    """`NodeMargins.curvature` (Σ w_r ∇²g_r over the clearance rows) against central
    differences of the weighted Jacobian: on self-collision (the joints are affine in z) and
    on obstacles, whose clearances move with θ, so that θ's own exact curvature at the nodes
    enters (without it the obstacles' case is off by 10-30 %)."""
    raw = tomllib.loads((ROOT / "scenarios" / f"{scenario}.toml").read_text())
    raw["planner"]["objective"] = "newton"
    task, problem, z = _problem(raw)
    margins = NodeMargins(problem, task.system, task.constraints, nodes=40)
    g, _ = margins(z)
    clearance = np.array([what == kind for _, what in margins.labels])
    rng = np.random.default_rng(1)
    weights = np.zeros(g.size)
    # a few rows near contact, where the gap is smooth (away from kinks)
    rows = np.flatnonzero(clearance)[np.argsort(np.abs(g[clearance]))[:40]]
    weights[rng.choice(rows, 5, replace=False)] = rng.uniform(0.5, 2.0, 5)
    H = margins.curvature(z, weights)
    assert np.allclose(H, H.T)
    direction, numeric = _jacobian_differences(margins, z, weights, rng)
    assert np.abs(numeric).max() > 1e-3  # a curvature to compare
    np.testing.assert_allclose(H @ direction, numeric, rtol=2e-2, atol=2e-3 * np.abs(numeric).max())


def test_the_curvature_of_limits_on_theta_is_its_exact_curvature_at_the_nodes():
    """A limit on the base angle is not affine in z: `NodeMargins.curvature` gives θ's
    exact second derivatives at the nodes, equal to central differences of the Jacobian."""
    raw = tomllib.loads((ROOT / "scenarios" / "sim4_task_d.toml").read_text())
    raw["planner"]["objective"] = "newton"
    raw["constraints"] = {"joint_limits": {"theta": [-0.5, 0.5]}}
    task, problem, z = _problem(raw)
    margins = NodeMargins(problem, task.system, task.constraints, nodes=40)
    g, _ = margins(z)
    assert {what for _, what in margins.labels} == {"the joint limits of theta"}
    rng = np.random.default_rng(1)
    weights = rng.uniform(0.0, 1.0, g.size) * (rng.uniform(size=g.size) < 0.2)
    H = margins.curvature(z, weights)
    direction, numeric = _jacobian_differences(margins, z, weights, rng)
    assert np.abs(numeric).max() > 1e-2  # a curvature to compare
    np.testing.assert_allclose(H @ direction, numeric, atol=1e-6 * np.abs(numeric).max())


def test_a_joint_limits_rows_are_its_distance_to_the_bound_less_the_cushion():
    """At every node, the lower and the upper bound's rows of one joint give the same joint
    value (bound ± margin, the cushion added back), and at each leg's last node (its end) it
    is the free plan's own end; the cushion lowers each row by itself."""
    from stratcli.node_margins import CUSHION

    raw = tomllib.loads((ROOT / "scenarios" / "sim4_task_d_constrained.toml").read_text())
    raw["planner"]["objective"] = "newton"
    del raw["constraints"]["self_collision"], raw["constraints"]["clearance"]
    task, problem, z = _problem(raw)
    result = plan({k: v for k, v in raw.items() if k != "constraints"})
    margins = NodeMargins(problem, task.system, task.constraints, nodes=40)
    g = margins(z, False)[0]
    bare = NodeMargins(problem, task.system, task.constraints, nodes=40, cushion=0.0)
    np.testing.assert_allclose(g, bare(z, False)[0] - CUSHION, rtol=0, atol=1e-15)
    lower, upper = task.constraints.lower, task.constraints.upper
    rows: dict[tuple[int, int], dict[float, np.ndarray]] = {}
    for leg, i, sign, first, count in margins._limit_rows:
        value = g[first : first + count] + CUSHION
        q = lower[i] + value if sign > 0 else upper[i] - value
        rows.setdefault((leg, i), {})[sign] = q
    assert rows
    for (leg, i), both in rows.items():
        np.testing.assert_allclose(both[1.0], both[-1.0], rtol=0, atol=1e-12)
        # (z is the plan's coefficients projected onto the continuity conditions: to 1e-6)
        assert both[1.0][-1] == pytest.approx(result.legs[leg].end[i], abs=1e-6)
