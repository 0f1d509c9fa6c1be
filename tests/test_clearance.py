"""Distances between segments and convex polygons, against brute force on dense points."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from stratcli.clearance import (
    box_corners,
    point_polygon_distance,
    point_segment_distance,
    polygon_polygon_distance,
    segment_polygon_distance,
    segment_segment_distance,
)

RNG = np.random.default_rng(17)
DENSE = np.linspace(0.0, 1.0, 2001)


def _points(a, b):
    return a + DENSE[:, None] * (b - a)


def _outline(poly):
    return np.concatenate([_points(poly[i], poly[(i + 1) % len(poly)]) for i in range(len(poly))])


def _brute(p, q):
    """The least distance between two dense point sets, nearest neighbour by nearest
    neighbour (all pairs of two outlines were 64 M: a 1 GB array a call, 88 s a test)."""
    return float(np.min(cKDTree(q).query(p)[0]))


def _inside(p, poly):
    edges = np.roll(poly, -1, axis=0) - poly
    side = edges[:, 0] * (p[1] - poly[:, 1]) - edges[:, 1] * (p[0] - poly[:, 0])
    return bool(np.all(side >= 0) or np.all(side <= 0))


def test_point_and_segment_distances_match_brute_force():
    for _ in range(30):
        a, b, c, d = RNG.uniform(-1, 1, (4, 2))
        p = RNG.uniform(-1, 1, 2)
        assert abs(point_segment_distance(p, a, b) - _brute(p[None], _points(a, b))) < 1e-3
        got = float(segment_segment_distance(a, b, c, d))
        assert abs(got - _brute(_points(a, b), _points(c, d))) < 2e-3


def test_crossing_segments_are_at_distance_zero():
    a, b = np.array([-1.0, 0.0]), np.array([1.0, 0.0])
    c, d = np.array([0.0, -1.0]), np.array([0.0, 1.0])
    assert segment_segment_distance(a, b, c, d) == 0.0
    assert segment_segment_distance(a, b, c + np.array([0, 1.5]), d + np.array([0, 1.5])) == 0.5


def test_polygon_distances_match_brute_force_and_are_zero_inside():
    for _ in range(20):
        box = box_corners(RNG.uniform(-1, 1, 2), RNG.uniform(0.2, 1.0, 2), RNG.uniform(-3, 3))
        other = box_corners(RNG.uniform(-2, 2, 2), RNG.uniform(0.2, 1.0, 2), RNG.uniform(-3, 3))
        a, b = RNG.uniform(-2, 2, (2, 2))
        p = RNG.uniform(-2, 2, 2)
        want = 0.0 if _inside(p, box) else _brute(p[None], _outline(box))
        assert abs(float(point_polygon_distance(p, box)) - want) < 2e-3
        seg = float(segment_polygon_distance(a, b, box))
        crossing = _inside(a, box) or _inside(b, box)
        want = 0.0 if crossing else _brute(_points(a, b), _outline(box))
        assert seg <= want + 2e-3 and (seg == 0.0 or abs(seg - want) < 2e-3)
        got = float(polygon_polygon_distance(box, other))
        assert abs(got - _brute(_outline(box), _outline(other))) < 2e-3 or got == 0.0


def test_distances_broadcast_over_samples():
    a = RNG.uniform(-1, 1, (50, 2))
    b = RNG.uniform(-1, 1, (50, 2))
    box = np.broadcast_to(box_corners([0.5, 0.5], [0.4, 0.2], 0.3), (50, 4, 2))
    many = segment_polygon_distance(a, b, box)
    one = [float(segment_polygon_distance(a[k], b[k], box[k])) for k in range(50)]
    np.testing.assert_array_equal(many, one)


def test_a_polygon_wholly_inside_another_is_at_distance_zero_and_penetrates():
    """No edge of either crosses the other's, so their edges are apart: only the containment
    test says they overlap (either way round), and the signed clearance is then the depth."""
    from stratcli.body_clearances import _signed
    from stratcli.clearance import penetration

    big = box_corners([0.1, -0.2], [2.0, 1.0], 0.3)
    small = box_corners([0.15, -0.1], [0.3, 0.2], -0.7)
    assert float(segment_segment_distance(big[0], big[1], small[0], small[1])) > 0.1
    for p, q in ((big, small), (small, big)):
        assert float(polygon_polygon_distance(p, q)) == 0.0
        signed = float(_signed(polygon_polygon_distance(p, q)[None], p[None], q[None])[0])
        assert signed == -float(penetration(p, q)) < -0.1
