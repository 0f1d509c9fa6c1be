"""Distances between the bodies of a planar manipulator and obstacles (no I/O).

Links are capsules (a segment between the link's ends, swept by a radius), the base is its
rectangle, obstacles are circles and rotated boxes in the inertial frame. Every function
works on arrays over many samples at once. A distance is between the geometric primitives
(segments, polygons, circle centres) and is 0 when they touch or overlap; radii are
subtracted by the caller (`constraints`).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "box_corners",
    "point_polygon_distance",
    "polygon_polygon_distance",
    "segment_polygon_distance",
    "segment_segment_distance",
]


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", a, b)


def point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from points p to segments [a, b] (broadcast over leading axes)."""
    d = b - a
    length2 = _dot(d, d)
    t = np.clip(_dot(p - a, d) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
    closest = a + t[..., None] * d
    return np.linalg.norm(p - closest, axis=-1)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _segments_cross(a, b, c, d) -> np.ndarray:
    """Whether segments [a, b] and [c, d] intersect (proper crossing or touching)."""
    ab, cd = b - a, d - c
    d1, d2 = _cross(ab, c - a), _cross(ab, d - a)
    d3, d4 = _cross(cd, a - c), _cross(cd, b - c)
    return (d1 * d2 <= 0) & (d3 * d4 <= 0) & ~((d1 == 0) & (d2 == 0) & (d3 == 0) & (d4 == 0))


def segment_segment_distance(a, b, c, d) -> np.ndarray:
    """Distance between segments [a, b] and [c, d] in the plane (0 where they cross)."""
    ends = np.minimum.reduce(
        [
            point_segment_distance(a, c, d),
            point_segment_distance(b, c, d),
            point_segment_distance(c, a, b),
            point_segment_distance(d, a, b),
        ]
    )
    return np.where(_segments_cross(a, b, c, d), 0.0, ends)


def _inside(p: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Whether points p (..., 2) lie in convex polygons poly (..., V, 2), either winding."""
    edges = np.roll(poly, -1, axis=-2) - poly
    side = _cross(edges, p[..., None, :] - poly)
    return np.all(side >= 0, axis=-1) | np.all(side <= 0, axis=-1)


def point_polygon_distance(p: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance from points to convex polygons (0 inside)."""
    nxt = np.roll(poly, -1, axis=-2)
    edge = point_segment_distance(p[..., None, :], poly, nxt).min(axis=-1)
    return np.where(_inside(p, poly), 0.0, edge)


def segment_polygon_distance(a: np.ndarray, b: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance from segments [a, b] to convex polygons (0 where they overlap)."""
    nxt = np.roll(poly, -1, axis=-2)
    edge = segment_segment_distance(a[..., None, :], b[..., None, :], poly, nxt).min(axis=-1)
    return np.where(_inside(a, poly) | _inside(b, poly), 0.0, edge)


def polygon_polygon_distance(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Distance between convex polygons p (..., V, 2) and q (..., W, 2) (0 where they overlap)."""
    p_next, q_next = np.roll(p, -1, axis=-2), np.roll(q, -1, axis=-2)
    edges = segment_segment_distance(
        p[..., :, None, :], p_next[..., :, None, :], q[..., None, :, :], q_next[..., None, :, :]
    )
    best = edges.min(axis=(-2, -1))
    overlap = _inside(p[..., 0, :], q) | _inside(q[..., 0, :], p)
    return np.where(overlap, 0.0, best)


def box_corners(centre, size, rotation: float) -> np.ndarray:
    """The four corners (4, 2) of a box of `size` (w, h) at `centre`, turned by `rotation`."""
    w, h = size[0] / 2, size[1] / 2
    local = np.array([[w, h], [-w, h], [-w, -h], [w, -h]])
    c, s = np.cos(rotation), np.sin(rotation)
    return local @ np.array([[c, s], [-s, c]]) + np.asarray(centre, dtype=float)


# --------------------------------------------------------------------------------------------
# Separating-axis depth: negative where shapes are apart, with a gradient inside too
# --------------------------------------------------------------------------------------------


def _edge_normals(poly: np.ndarray) -> np.ndarray:
    """Unit normals of the edges of convex polygons (..., V, 2) (V = 2: a segment)."""
    e = np.roll(poly, -1, axis=-2) - poly
    n = np.stack((-e[..., 1], e[..., 0]), axis=-1)
    length = np.linalg.norm(n, axis=-1, keepdims=True)
    return n / np.where(length > 0, length, 1.0)


def separating_axes(s: np.ndarray) -> np.ndarray:
    """The axes (..., K, 2) that `penetration` projects a convex shape s (..., V, 2) on: a
    segment's normal and direction, a polygon's edge normals, none for a point."""
    if s.shape[-2] == 2:  # a segment: its normal and its direction
        d = s[..., 1, :] - s[..., 0, :]
        d = d / np.maximum(np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2), 1e-300)[..., None]
        return np.concatenate(
            [np.stack((-d[..., 1], d[..., 0]), axis=-1)[..., None, :], d[..., None, :]], axis=-2
        )
    if s.shape[-2] > 2:
        return _edge_normals(s)
    return np.zeros((*s.shape[:-2], 0, 2))


def penetration(p: np.ndarray, q: np.ndarray, p_axes=None, q_axes=None) -> np.ndarray:
    """Depth of overlap of convex shapes p (..., V, 2) and q (..., W, 2) (points, segments or
    polygons): the shortest translation that separates them, by the separating-axis theorem
    (axes: the edge normals of both, and a segment's own direction); where they are apart,
    minus the widest gap along those axes (a lower bound of their distance, equal to it
    unless the closest points are two corners). `p_axes`, `q_axes`: their
    `separating_axes`, if already at hand."""
    lead = np.broadcast_shapes(p.shape[:-2], q.shape[:-2])
    p = np.broadcast_to(p, (*lead, *p.shape[-2:]))
    q = np.broadcast_to(q, (*lead, *q.shape[-2:]))
    axes = [
        np.broadcast_to(a, (*lead, *a.shape[-2:]))
        for a in (
            separating_axes(p) if p_axes is None else p_axes,
            separating_axes(q) if q_axes is None else q_axes,
        )
        if a.shape[-2]
    ]
    axes = np.concatenate(axes, axis=-2)  # (..., K, 2)
    ax, ay = axes[..., 0], axes[..., 1]
    # extreme projections vertex by vertex (a few vertices: cheaper than reducing an axis)
    p_lo, p_hi = _extent(p, ax, ay)
    q_lo, q_hi = _extent(q, ax, ay)
    overlap = np.minimum(p_hi - q_lo, q_hi - p_lo)  # (..., K)
    depth = overlap[..., 0].copy()
    for k in range(1, overlap.shape[-1]):
        np.minimum(depth, overlap[..., k], out=depth)
    return depth


def _extent(s: np.ndarray, ax: np.ndarray, ay: np.ndarray):
    """Smallest and largest projection of the vertices of s (..., V, 2) on axes (..., K)."""
    lo = s[..., 0, 0, None] * ax + s[..., 0, 1, None] * ay
    hi = lo.copy()
    for v in range(1, s.shape[-2]):
        x = s[..., v, 0, None] * ax + s[..., v, 1, None] * ay
        np.minimum(lo, x, out=lo)
        np.maximum(hi, x, out=hi)
    return lo, hi
