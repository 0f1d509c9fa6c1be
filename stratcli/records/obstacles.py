"""The [constraints] of a plan as its figures draw them: the table resolved on the model, the
obstacles (hatched patches, and the points the axes must include to show them whole), and
each leg's closest approach to them (the instant and the point of the robot nearest one)."""

from __future__ import annotations

import numpy as np
from matplotlib.patches import Circle, Polygon

from ..body_clearances import clearances
from ..clearance import point_polygon_distance
from ..constraints import resolved_constraints
from ..models.geometry import world_geometry
from ..sequence import SequencePlan
from .figure_common import FAILED_COLOR

__all__ = [
    "OBSTACLE_STYLE",
    "closest_approach",
    "draw_obstacles",
    "has_obstacles",
    "obstacle_points",
    "resolved_constraints",
]


OBSTACLE_STYLE = {"facecolor": "#f5b7b1", "edgecolor": FAILED_COLOR, "hatch": "///", "lw": 1.0}


def has_obstacles(plan: SequencePlan) -> bool:
    return plan.constraints is not None and bool(plan.constraints.spec.get("obstacles"))


def obstacle_points(plan: SequencePlan) -> np.ndarray | None:
    """Points that bound the obstacles (box corners, circles' bounding squares), so that the
    figures show them whole."""
    if not has_obstacles(plan):
        return None
    c = resolved_constraints(plan)
    square = np.array([[-1, -1], [-1, 1], [1, -1], [1, 1]], dtype=float)
    points = [np.asarray(centre) + radius * square for centre, radius in c.circles]
    return np.concatenate([*points, *c.boxes]) if points or c.boxes else None


def draw_obstacles(ax, plan: SequencePlan) -> None:
    """The obstacles of [constraints], hatched."""
    if not has_obstacles(plan):
        return
    c = resolved_constraints(plan)
    for centre, radius in c.circles:
        ax.add_patch(Circle(centre, radius, zorder=1, **OBSTACLE_STYLE))
    for corners in c.boxes:
        ax.add_patch(Polygon(corners, closed=True, zorder=1, **OBSTACLE_STYLE))


ALONG = np.linspace(0.0, 1.0, 101)  # points along a link's core or a base edge


def closest_approach(plan: SequencePlan, q: np.ndarray) -> tuple[int, np.ndarray, float] | None:
    """Among configurations `q` (N, n) of a leg: the sample closest to an obstacle, the point
    of the robot nearest it there (on a link's core or the base's outline; 101 points along
    each) and that margin (surface distance less the clearance, as result.json's); None
    without obstacles or a finite configuration."""
    if not has_obstacles(plan) or not len(q):
        return None
    c = resolved_constraints(plan)
    _, world = clearances(plan.system.robot, q, c)
    world = np.where(np.isnan(world), np.inf, world)  # a failed leg's diverged samples
    if not (world < np.inf).any():
        return None
    k = int(np.argmin(world))
    geo = world_geometry(plan.system.robot, q[k : k + 1])
    corners = geo["base_corners"][0]
    ends = [
        (geo["proximal"][0, i], geo["distal"][0, i], c.link_radius)
        for i in range(len(geo["proximal"][0]))
    ]
    ends += [(corners[i], corners[(i + 1) % 4], 0.0) for i in range(4)]
    points = np.concatenate([p + ALONG[:, None] * (e - p) for p, e, _ in ends])
    radii = np.repeat([r for *_, r in ends], ALONG.size)
    near = np.full(len(points), np.inf)
    for centre, radius in c.circles:
        near = np.minimum(near, np.linalg.norm(points - centre, axis=1) - radius - radii)
    for box in c.boxes:
        inside = point_polygon_distance(points, np.broadcast_to(box, (len(points), 4, 2)))
        near = np.minimum(near, inside - radii)
    return k, points[int(np.argmin(near))], float(world[k])
