"""Node margins of the constrained search: values equal the verification's clearances where
bodies are apart, signed distances keep a gradient where they overlap, and the Jacobian in the
search's coordinates equals finite differences (joints, self-collision, obstacles via θ)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from stratcli import load_scenario, plan
from stratcli.clearance import (
    box_corners,
    segment_polygon_distance,
    segment_segment_distance,
    signed_segment_polygon,
    signed_segment_segment,
)
from stratcli.node_margins import NodeMargins
from stratcli.planners.energy import _Problem

ROOT = Path(__file__).resolve().parents[1]


def test_signed_distances_equal_the_distances_apart_and_are_negative_inside():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(2, 500, 2)) * 1.5
    c, d = rng.normal(size=(2, 500, 2)) * 1.5
    box = np.broadcast_to(box_corners([0.2, -0.1], [1.0, 0.6], 0.4), (500, 4, 2))
    for signed, plain in (
        (signed_segment_polygon(a, b, box), segment_polygon_distance(a, b, box)),
        (signed_segment_segment(a, b, c, d), segment_segment_distance(a, b, c, d)),
    ):
        apart = plain > 0
        np.testing.assert_allclose(signed[apart], plain[apart], atol=1e-12)
        assert np.all(signed[~apart] <= 0) and np.any(signed[~apart] < 0)
    # inside: a segment through a box's middle must move by half the box to get out
    depth = signed_segment_polygon(np.array([0.0, -3.0]), np.array([0.0, 3.0]), box[0] * 0 +
                                   box_corners([0, 0], [2.0, 2.0], 0.0))  # fmt: skip
    assert depth == pytest.approx(-1.0)


def _problem(raw):
    task = load_scenario(raw)
    result = plan({k: v for k, v in raw.items() if k != "constraints"})  # the free plan
    starts = [task.start, *[np.asarray(leg.goal) for leg in task.legs[:-1]]]
    targets = [np.array(leg.targets, dtype=int) for leg in result.legs]
    problem = _Problem(task.system, starts, task.legs, task.settings, targets)
    lam = np.concatenate([leg.coefficients.ravel() for leg in result.legs])
    return task, problem, problem.project(lam)


@pytest.mark.parametrize("obstacles", [False, True])
def test_the_jacobian_in_the_search_coordinates_equals_finite_differences(obstacles):
    raw = tomllib.loads((ROOT / "scenarios" / "sim4_task_d_constrained.toml").read_text())
    raw["planner"]["objective"] = "newton"
    if obstacles:
        raw["constraints"]["obstacles"] = [
            {"shape": "circle", "centre": [1.2, 0.8], "radius": 0.3},
            {"shape": "box", "centre": [-1.0, 1.5], "size": [0.4, 0.8], "rotation": 0.3},
        ]
    task, problem, z = _problem(raw)
    margins = NodeMargins(problem, task.system, task.constraints, nodes=40)
    g, G = margins(z)
    assert len(margins.labels) == g.size
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
