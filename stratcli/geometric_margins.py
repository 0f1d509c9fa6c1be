"""Signed clearances of a planar robot's bodies at many configurations at once, less the link
radius and the clearance: to each other (self-collision) and to the obstacles (no I/O).

What the constrained search measures at its nodes (`node_margins.NodeMargins`), hundreds of
times a plan: `GeometricMargins` works out once which pairs of bodies it measures on which
separating axes, and then measures every pair at every configuration in a few array
operations (every vertex projected on every axis once, the extents per body, the overlaps per
pair), with the arithmetic of `clearance.penetration` and `models.geometry.world_bodies`, so
that its values are theirs to the bit. The named, pair-by-pair check of a single
configuration is `body_clearances`.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .clearance import separating_axes
from .models.geometry import base_extent
from .models.planar import kinematics, structure

__all__ = ["GeometricMargins"]


@lru_cache(maxsize=64)
def _corners(robot) -> np.ndarray:
    """The base rectangle's corners (4, 2) in the base frame, as `world_bodies` has them."""
    hx, hy = base_extent(robot)
    return np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])


class GeometricMargins:
    """Signed clearances (separating-axis gaps: exact inside, never above the distance apart,
    so that a plan with positive margins here has them in `constraints.verify` too), less the
    link radius and the clearance, one column per pair of bodies (the pairs
    `body_clearances.clearances` checks); `kinds[j]` is column j's ("self-collision" or "an
    obstacle").

    Bodies are the base (4 corners), each link (its 2 ends), each circle's centre and each
    box (4 corners); axes are the base's 4 edge normals, each link's normal and direction
    and each box's edge normals. A pair is measured on its two bodies' axes (a circle's
    centre has none); a circle and a link by the centre's distance to the segment.
    """

    def __init__(self, robot, c):
        self.robot, self.c = robot, c
        k = robot.n_joints
        self.k = k
        arm, r = robot.joint_arm, c.link_radius
        circles, boxes = len(c.circles), len(c.boxes)
        # bodies by vertex count (the extents are taken run by run): the base and the boxes
        # (4 corners), the links (2 ends), the circles' centres; the vertex bank of
        # `_vertices` is base corners, proximal ends, distal ends, centres, box corners
        self.counts = (1 + boxes, k, circles)
        base, box_body = 0, (lambda o: 1 + o)
        link, circle_body = (lambda i: 1 + boxes + i), (lambda o: 1 + boxes + k + o)
        box_at = 4 + 2 * k + circles
        order = [0, 1, 2, 3, *range(box_at, box_at + 4 * boxes)]
        for i in range(k):
            order += [4 + i, 4 + k + i]  # each link's ends together
        order += list(range(4 + 2 * k, box_at))
        self.order = np.array(order)
        # axes: base edge normals 0-3, link i's normal 4+2i and direction 5+2i, box axes
        axes_of = {base: [0, 1, 2, 3]}
        for i in range(k):
            axes_of[link(i)] = [4 + 2 * i, 5 + 2 * i]
        for o in range(boxes):
            axes_of[box_body(o)] = [4 + 2 * k + 4 * o + a for a in range(4)]
        for o in range(circles):
            axes_of[circle_body(o)] = []
        self.box_axes = np.array(
            [separating_axes(box[None, None])[0, 0] for box in c.boxes]
        ).reshape(-1, 2)
        self.axes = 4 + 2 * k + 4 * boxes
        fixed = [centre for centre, _ in c.circles] + [corner for box in c.boxes for corner in box]
        self.fixed = np.asarray(fixed, dtype=float).reshape(-1, 2)
        sat: list[tuple[int, int, float]] = []  # (p body, q body, less) of each SAT column
        columns: list[tuple[str, object]] = []  # per column: ("sat", j) or ("line", (o, i))
        kinds: list[str] = []

        def add(p, q, less, kind):
            columns.append(("sat", len(sat)))
            sat.append((p, q, less))
            kinds.append(kind)

        if c.self_collision:
            first = {j for j in range(k) if j == 0 or arm[j] != arm[j - 1]}
            neighbours = {(i, i + 1) for i in range(k - 1) if arm[i] == arm[i + 1]}
            pairs = [(i, j) for i in range(k) for j in range(i + 1, k) if (i, j) not in neighbours]
            for i in range(k):
                if i not in first:
                    add(link(i), base, r, "self-collision")
                for a, j in pairs:
                    if a == i:
                        add(link(i), link(j), 2 * r, "self-collision")
        for o, (_, radius) in enumerate(c.circles):
            add(circle_body(o), base, radius, "an obstacle")
            for i in range(k):
                columns.append(("line", (o, i)))
                kinds.append("an obstacle")
        for o in range(boxes):
            add(base, box_body(o), 0.0, "an obstacle")
            for i in range(k):
                add(link(i), box_body(o), r, "an obstacle")
        self.kinds = kinds
        self.columns = columns
        width = max((len(axes_of[p]) + len(axes_of[q]) for p, q, _ in sat), default=0)
        pad = [(axes_of[p] + axes_of[q]) for p, q, _ in sat]
        pad = [a + [a[0]] * (width - len(a)) for a in pad]  # repeated: the min unchanged
        self.sat_axes = np.array(pad, dtype=int).reshape(len(sat), width)
        bodies = 1 + boxes + k + circles  # flat indices into the extents (axis, body)
        sat_p = np.array([p for p, _, _ in sat], dtype=int)[:, None]
        sat_q = np.array([q for _, q, _ in sat], dtype=int)[:, None]
        self.sat_index = np.array(
            [(self.sat_axes * bodies + sat_p).ravel(), (self.sat_axes * bodies + sat_q).ravel()]
        )
        self.sat_less = np.array([less for _, _, less in sat])
        self.sat_columns = np.array([j for j, (what, _) in enumerate(columns) if what == "sat"])
        self.line_columns = [
            [j for j, (what, at) in enumerate(columns) if what == "line" and at[0] == o]
            for o in range(circles)
        ]

    def __call__(self, q: np.ndarray) -> tuple[np.ndarray, list[str]]:
        """Signed clearances (N, P) at configurations q (N, k + 1 or more) and the kinds.
        Arrays run over the configurations last (contiguous), the bodies and axes first."""
        c, k = self.c, self.k
        q = np.atleast_2d(np.asarray(q, dtype=float))
        N = len(q)
        if not self.columns:
            return np.zeros((N, 0)) - c.clearance, []
        X, Y = self._vertices(q)  # (V, N) each, inertial frame
        # axes (A, N): the base's edge normals (`clearance._edge_normals`), each link's
        # normal and direction (`clearance.separating_axes`), the boxes' (constant)
        ex, ey = X[[1, 2, 3, 0]] - X[:4], Y[[1, 2, 3, 0]] - Y[:4]
        nx, ny = -ey, ex
        length = np.sqrt(nx * nx + ny * ny)
        length = np.where(length > 0, length, 1.0)
        dx, dy = X[4 + k : 4 + 2 * k] - X[4 : 4 + k], Y[4 + k : 4 + 2 * k] - Y[4 : 4 + k]
        size = np.maximum(np.sqrt(dx**2 + dy**2), 1e-300)
        dx, dy = dx / size, dy / size
        AX = np.empty((self.axes, N))
        AY = np.empty((self.axes, N))
        AX[:4], AY[:4] = nx / length, ny / length
        AX[4 : 4 + 2 * k : 2], AY[4 : 4 + 2 * k : 2] = -dy, dx
        AX[5 : 4 + 2 * k : 2], AY[5 : 4 + 2 * k : 2] = dx, dy
        AX[4 + 2 * k :], AY[4 + 2 * k :] = self.box_axes[:, 0, None], self.box_axes[:, 1, None]
        out = np.empty((len(self.columns), N))
        if self.sat_index.size:
            # every vertex on every axis (A, V, N), each body's extent (`clearance._extent`),
            # each pair's overlaps on its axes
            Xo, Yo = X[self.order], Y[self.order]
            proj = AX[:, None] * Xo[None] + AY[:, None] * Yo[None]
            n4, n2, _ = self.counts
            four, two = proj[:, : 4 * n4], proj[:, 4 * n4 : 4 * n4 + 2 * n2]
            points = proj[:, 4 * n4 + 2 * n2 :]
            lo = np.concatenate([
                np.minimum(np.minimum(four[:, 0::4], four[:, 1::4]),
                           np.minimum(four[:, 2::4], four[:, 3::4])),
                np.minimum(two[:, 0::2], two[:, 1::2]), points], axis=1,
            ).reshape(-1, N)  # fmt: skip
            hi = np.concatenate([
                np.maximum(np.maximum(four[:, 0::4], four[:, 1::4]),
                           np.maximum(four[:, 2::4], four[:, 3::4])),
                np.maximum(two[:, 0::2], two[:, 1::2]), points], axis=1,
            ).reshape(-1, N)  # fmt: skip
            p, qb = self.sat_index
            shape = (*self.sat_axes.shape, N)
            overlap = np.minimum((hi[p] - lo[qb]).reshape(shape), (hi[qb] - lo[p]).reshape(shape))
            out[self.sat_columns] = -overlap.min(axis=1) - self.sat_less[:, None]
        out = out.T  # (N, P)
        if c.circles:  # circle to link: the centre's distance to the segment
            ends = [
                np.stack((X[4 + e * k : 4 + (e + 1) * k].T, Y[4 + e * k : 4 + (e + 1) * k].T), -1)
                for e in (0, 1)
            ]
        for o, (centre, radius) in enumerate(c.circles):
            point = np.broadcast_to(centre, (N, 1, 2))
            d = np.linalg.norm(point - _closest(point, *ends), axis=-1) - c.link_radius - radius
            out[:, self.line_columns[o]] = d
        out -= c.clearance
        return out, list(self.kinds)

    def _vertices(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Inertial-frame x and y (V, N) of every vertex: base corners, proximal and distal
        link ends (`world_bodies`' arithmetic), circle centres, box corners."""
        robot, k = self.robot, self.k
        st = structure(robot)
        _, (ux, uy), (ox, oy), (px, py) = kinematics(st, np.ascontiguousarray(q[:, :k].T))
        pcx, pcy = (st.m @ px) / st.M, (st.m @ py) / st.M  # (N,): p_c
        theta = q[:, k]
        cos, sin = np.cos(theta), np.sin(theta)
        corners = _corners(robot)
        N = len(q)
        bx = np.concatenate([np.broadcast_to(corners[:, 0, None], (4, N)), ox, ox + st.length * ux])
        by = np.concatenate([np.broadcast_to(corners[:, 1, None], (4, N)), oy, oy + st.length * uy])
        dx, dy = bx - pcx, by - pcy
        X, Y = cos * dx - sin * dy, sin * dx + cos * dy
        if len(self.fixed):
            fixed = self.fixed
            X = np.concatenate([X, np.broadcast_to(fixed[:, 0, None], (len(fixed), N))])
            Y = np.concatenate([Y, np.broadcast_to(fixed[:, 1, None], (len(fixed), N))])
        return X, Y


def _closest(p, a, b):
    d = b - a
    length2 = np.einsum("...i,...i->...", d, d)
    t = np.clip(np.einsum("...i,...i->...", p - a, d) / np.where(length2 > 0, length2, 1), 0, 1)
    return a + t[..., None] * d
