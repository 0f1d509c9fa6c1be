"""Clearances of a planar robot's bodies to each other and to the obstacles of a
[constraints] table, pair by pair and named ("link 3 and the base", "link 2 and
obstacles[0] (a circle)"): the margins of `constraints.verify` and the configurations the
scenario checks (`check_configuration`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .clearance import (
    penetration,
    point_polygon_distance,
    point_segment_distance,
    polygon_polygon_distance,
    segment_polygon_distance,
    segment_segment_distance,
)
from .errors import Problem
from .models.geometry import world_geometry

if TYPE_CHECKING:
    from .constraints import Constraints

__all__ = ["check_configuration", "clearances", "closest_pair", "self_pairs"]


def _obstacle_names(c: Constraints) -> tuple[list[str], list[str]]:
    """The circles' and the boxes' names as the table gives them: obstacles[i] (shape)."""
    shapes = [o.get("shape") for o in c.spec.get("obstacles") or []]
    named = {kind: [f"obstacles[{i}] (a {s})" for i, s in enumerate(shapes) if s == kind]
             for kind in ("circle", "box")}  # fmt: skip
    circles = named["circle"] or [f"circle {i + 1}" for i in range(len(c.circles))]
    boxes = named["box"] or [f"box {i + 1}" for i in range(len(c.boxes))]
    return circles, boxes


def _signed(d: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Distances `d` between the cores p and q (..., V, 2) where they are apart; where they
    overlap (d = 0), minus the depth of the overlap (`penetration`), so that a margin tells
    how deep a link went into the base or a box, not only that it touched."""
    inside = d <= 0.0
    if not inside.any():
        return d
    out = np.array(d, dtype=float)
    out[inside] = -penetration(p[inside], q[inside])
    return out


def self_pairs(geo: dict[str, np.ndarray], c: Constraints) -> list[tuple[int, int, np.ndarray]]:
    """Surface distances per sample of each pair of non-adjacent bodies of `world_geometry`
    `geo`, as (i, j, distances): links by index from 0, the base as -1 (`j` only); negative
    where they overlap, by how deep. Empty without `self_collision`."""
    if not c.self_collision:
        return []
    a, b = geo["proximal"], geo["distal"]  # (N, k, 2)
    corners = geo["base_corners"]  # (N, 4, 2)
    arm = geo["arm_of_link"]
    r = c.link_radius
    k = a.shape[1]
    link = [np.stack((a[:, i], b[:, i]), axis=-2) for i in range(k)]  # (N, 2, 2) cores
    first = [j for j in range(k) if j == 0 or arm[j] != arm[j - 1]]
    out = []
    for i in range(k):
        if i not in first:  # a first link is mounted on the base: not checked against it
            d = _signed(segment_polygon_distance(a[:, i], b[:, i], corners), link[i], corners)
            out.append((i, -1, d - r))
        for j in range(i + 1, k):
            if arm[j] == arm[i] and j == i + 1:
                continue  # neighbours share a joint
            d = segment_segment_distance(a[:, i], b[:, i], a[:, j], b[:, j])
            out.append((i, j, _signed(d, link[i], link[j]) - 2 * r))
    return out


def _pair_distances(robot, q: np.ndarray, c: Constraints) -> tuple[list, list]:
    """Surface distances per sample of each pair of non-adjacent bodies and of each body and
    obstacle, named: two lists of (name, distances); negative where they overlap, by how deep."""
    geo = world_geometry(robot, q)
    a, b = geo["proximal"], geo["distal"]  # (N, k, 2)
    corners = geo["base_corners"]  # (N, 4, 2)
    r = c.link_radius
    k = a.shape[1]
    link = [np.stack((a[:, i], b[:, i]), axis=-2) for i in range(k)]  # (N, 2, 2) cores
    own = [
        (f"link {i + 1} and the base" if j < 0 else f"links {i + 1} and {j + 1}", d)
        for i, j, d in self_pairs(geo, c)
    ]
    world = []
    circle_names, box_names = _obstacle_names(c)
    for (centre, radius), name in zip(c.circles, circle_names, strict=True):
        point = np.broadcast_to(centre, (len(q), 2))
        d = _signed(point_polygon_distance(point, corners), point[:, None, :], corners)
        world.append((f"the base and {name}", d - radius))
        for i in range(k):  # exact inside too: the centre's distance to the link's core
            d = point_segment_distance(centre, a[:, i], b[:, i]) - r - radius
            world.append((f"link {i + 1} and {name}", d))
    for box, name in zip(c.boxes, box_names, strict=True):
        boxes = np.broadcast_to(box, (len(q), 4, 2))
        d = _signed(polygon_polygon_distance(corners, boxes), corners, boxes)
        world.append((f"the base and {name}", d))
        for i in range(k):
            d = _signed(segment_polygon_distance(a[:, i], b[:, i], boxes), link[i], boxes)
            world.append((f"link {i + 1} and {name}", d - r))
    return own, world


def _smallest(pairs: list, n: int, clearance: float) -> np.ndarray:
    """Per sample, the smallest of the pairs' distances less the clearance (inf if none)."""
    out = np.full(n, np.inf)
    for _, d in pairs:
        out = np.minimum(out, d)
    return out - clearance


def clearances(robot, q: np.ndarray, c: Constraints) -> tuple[np.ndarray, np.ndarray]:
    """Per sample: smallest surface distance between non-adjacent bodies, and from any body
    to any obstacle, less the clearance (inf where there is nothing to measure)."""
    own, world = _pair_distances(robot, q, c)
    return _smallest(own, len(q), c.clearance), _smallest(world, len(q), c.clearance)


def closest_pair(robot, q: np.ndarray, c: Constraints, obstacles: bool) -> tuple[str, float]:
    """At one configuration: the pair (of bodies, or a body and an obstacle) closest to
    touching, and its surface distance."""
    own, world = _pair_distances(robot, q[None, :], c)
    name, d = min(world if obstacles else own, key=lambda pair: pair[1][0])
    return name, float(d[0])


def _digits(value: float, bound: float) -> int:
    """Significant digits (at least 4) that tell `value` from `bound` apart when printed."""
    for d in range(4, 17):
        if f"{value:.{d}g}" != f"{bound:.{d}g}":
            return d
    return 17


def check_configuration(system, q: np.ndarray, c: Constraints, where: str) -> list[Problem]:
    """Problems (naming `where`) if configuration q breaks a joint limit or a clearance:
    the start and every via must be inside the limits for a plan to exist."""
    problems = []
    q = np.asarray(q, dtype=float)
    for i, name in enumerate(system.states):
        if np.isfinite(q[i]) and not c.lower[i] <= q[i] <= c.upper[i]:
            bound = c.lower[i] if q[i] < c.lower[i] else c.upper[i]
            d = _digits(q[i], bound)  # (-2.0943951 outside -2.094395: not "-2.094", "-2.0944")
            problems.append(
                Problem(
                    where,
                    f"{name} = {q[i]:.{d}g} is outside its limits [{c.lower[i]:.{d}g}, "
                    f"{c.upper[i]:.{d}g}] ("  # where they come from (an attitude is no joint)
                    + (
                        "the URDF's joint limits"
                        if i in c.from_urdf
                        else "constraints.joint_limits"
                    )
                    + ")",
                )
            )
    robot = getattr(system, "robot", None)
    if c.geometric and robot is not None and np.all(np.isfinite(q)):
        sizes = f"clearance {c.clearance:g}, link radius {c.link_radius:g}"
        for pairs, what in zip(
            _pair_distances(robot, q[None, :], c),
            ("the robot collides with itself here", "the robot touches an obstacle here"),
            strict=True,
        ):
            if not pairs:
                continue
            pair, d = min(pairs, key=lambda named: named[1][0])
            if d[0] - c.clearance < 0:
                if d[0] > 0:  # apart: only nearer than the clearance
                    what = what.replace("touches", "comes within the clearance of").replace(
                        "collides with", "comes within the clearance of"
                    )
                fix = "move the obstacle or change" if "obstacle" in what else "change"
                fix += " this configuration" + (
                    " or lower constraints.clearance" if d[0] > 0 else ""
                )  # apart, but nearer than the clearance
                problems.append(
                    Problem(where, f"{what}: {pair} are {_apart(d[0])} ({sizes}); {fix}")
                )
    return problems


def _apart(d: float) -> str:
    """A surface distance in words; an overlap by its depth."""
    return f"{d:.3g} apart" if d > 0 else f"overlapping by {-d:.3g}"
