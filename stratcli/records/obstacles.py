"""The [constraints] of a plan as its figures draw them: the table resolved on the model, and
the obstacles (hatched patches, and the points the axes must include to show them whole)."""

from __future__ import annotations

import numpy as np
from matplotlib.patches import Circle, Polygon

from ..constraints import ConstraintsSpec, resolve
from ..sequence import SequencePlan
from .figure_common import FAILED_COLOR

__all__ = [
    "OBSTACLE_STYLE",
    "draw_obstacles",
    "has_obstacles",
    "obstacle_points",
    "resolved_constraints",
]


def resolved_constraints(plan: SequencePlan):
    """The plan's [constraints] table resolved on its model (limits per coordinate)."""
    return resolve(ConstraintsSpec.model_validate(plan.constraints.spec), plan.system)


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
