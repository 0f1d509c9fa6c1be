"""Signed clearances of a planar robot's bodies at many configurations at once, less the link
radius and the clearance: to each other (self-collision) and to the obstacles (no I/O).

What the constrained search measures at its nodes (`node_margins.NodeMargins`), hundreds of
times a plan, so pairs of the same kinds of shape are measured in one batch; the named,
pair-by-pair check of a single configuration is `body_clearances`.
"""

from __future__ import annotations

import numpy as np

from .clearance import penetration, separating_axes
from .models.geometry import world_bodies

__all__ = ["geometric_margins"]


def geometric_margins(robot, q: np.ndarray, c) -> tuple[np.ndarray, list[str]]:
    """Signed clearances (N, P) at configurations q (N, n) less the link radius and the
    clearance (separating-axis gaps: exact inside, never above the distance apart, so a
    plan with positive margins here has them in `constraints.verify` too), one column per
    pair of bodies (the pairs `body_clearances.clearances` checks), and
    each column's kind ("self-collision" or "an obstacle"). Pairs of the same kinds of
    shape are measured in one batch (the search calls this hundreds of times a plan)."""
    corners, links = world_bodies(robot, q)  # (N, 4, 2), (N, k, 2, 2)
    arm, r, k = robot.joint_arm, c.link_radius, links.shape[1]
    link_axes, base_axes = separating_axes(links), separating_axes(corners)[:, None]
    columns: list[tuple[tuple, str]] = []  # (key into `values`, kind), in the output's order
    values: dict[tuple, np.ndarray] = {}

    def gaps(name, i, j, p, q, p_axes, q_axes, less):  # signed: minus the depth of overlap
        for n, value in enumerate((-penetration(p, q, p_axes, q_axes) - less).T):
            values[(name, i[n], j[n])] = value

    if c.self_collision:
        first = {j for j in range(k) if j == 0 or arm[j] != arm[j - 1]}
        on_base = [i for i in range(k) if i not in first]
        neighbours = {(i, i + 1) for i in range(k - 1) if arm[i] == arm[i + 1]}
        pairs = [(i, j) for i in range(k) for j in range(i + 1, k) if (i, j) not in neighbours]
        for i in range(k):
            if i in on_base:
                columns.append((("base", i, 0), "self-collision"))
            columns += [(("link", i, j), "self-collision") for a, j in pairs if a == i]
        if on_base:
            gaps("base", on_base, [0] * len(on_base), links[:, on_base], corners[:, None],
                 link_axes[:, on_base], base_axes, r)  # fmt: skip
        if pairs:
            a, b = (list(x) for x in zip(*pairs, strict=True))
            gaps("link", a, b, links[:, a], links[:, b], link_axes[:, a], link_axes[:, b], 2 * r)
    for o, (centre, radius) in enumerate(c.circles):
        point = np.broadcast_to(centre, (len(corners), 1, 1, 2))
        gaps("circle", [o], [-1], point, corners[:, None], None, base_axes, radius)
        ends = links[:, :, 0], links[:, :, 1]
        d = np.linalg.norm(point[:, 0] - _closest(point[:, 0], *ends), axis=-1) - r - radius
        for i in range(k):
            values[("circle", o, i)] = d[:, i]
        columns += [(("circle", o, i), "an obstacle") for i in range(-1, k)]
    for o, box in enumerate(c.boxes):
        shape = box[None, None]
        axes = separating_axes(shape)
        gaps("box", [o], [-1], corners[:, None], shape, base_axes, axes, 0.0)
        gaps("box", [o] * k, list(range(k)), links, shape, link_axes, axes, r)
        columns += [(("box", o, i), "an obstacle") for i in range(-1, k)]
    if not columns:
        return np.zeros((len(corners), 0)) - c.clearance, []
    out = np.stack([values[key] for key, _ in columns], axis=1)
    return out - c.clearance, [kind for _, kind in columns]


def _closest(p, a, b):
    d = b - a
    length2 = np.einsum("...i,...i->...", d, d)
    t = np.clip(np.einsum("...i,...i->...", p - a, d) / np.where(length2 > 0, length2, 1), 0, 1)
    return a + t[..., None] * d
