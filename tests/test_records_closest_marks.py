"""The stroboscope's closest approaches between the robot's own bodies (`self_collision`),
against distances between capsules and the base rectangle computed here with numpy."""

from __future__ import annotations

import dataclasses
import json
import re

import numpy as np
import pytest
from conftest import ROOT
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.colors import to_rgba

import stratcli
import stratcli.simulate as simulate
from stratcli.constraint_report import ConstraintReport
from stratcli.constraints import ConstraintsSpec, resolve, verify
from stratcli.records.closest_marks import SELF_COLOR
from stratcli.records.figure_common import FAILED_COLOR, save_figure
from stratcli.records.result import result_document
from stratcli.records.robot_figures import stroboscope_figure
from stratcli.records.trajectory import world_geometry

RADIUS, CLEARANCE = 0.05, 0.05  # sim4_task_d_constrained's link radius (default), clearance
SELF = re.compile(r"closest approach, (.+) – (.+):\nmargin (\S+), near t = (\S+) s")


def _point_segment(p, a, b):
    """Distance from points p (..., 2) to segments [a, b] (..., 2)."""
    d = b - a
    t = np.clip(np.sum((p - a) * d, axis=-1) / np.sum(d * d, axis=-1), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * d), axis=-1)


def _crosses(a, b, c, d):
    def side(p, q, r):
        return np.sign((q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1])
                       - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0]))  # fmt: skip

    return (side(a, b, c) != side(a, b, d)) & (side(c, d, a) != side(c, d, b))


def _segment_segment(a, b, c, d):
    """Distance between segments (in the plane the nearest points include an end)."""
    ends = np.minimum.reduce([_point_segment(a, c, d), _point_segment(b, c, d),
                              _point_segment(c, a, b), _point_segment(d, a, b)])  # fmt: skip
    return np.where(_crosses(a, b, c, d), 0.0, ends)


def _inside(p, corners):
    edges = np.roll(corners, -1, axis=-2) - corners
    rel = p[..., None, :] - corners
    cross = edges[..., 0] * rel[..., 1] - edges[..., 1] * rel[..., 0]
    return np.all(cross >= 0, axis=-1) | np.all(cross <= 0, axis=-1)


def _self_margins(robot, q):
    """Per sample and per pair of bodies that do not share a joint (one arm: link 2 – base,
    link 3 – base, link 1 – link 3): the surface distance less the clearance."""
    geo = world_geometry(robot, q)
    a, b, corners = geo["proximal"], geo["distal"], geo["base_corners"]
    nxt = np.roll(corners, -1, axis=-2)
    out = {}
    for i in (1, 2):
        d = _segment_segment(a[:, i, None], b[:, i, None], corners, nxt).min(axis=-1)
        d = np.where(_inside(a[:, i], corners) | _inside(b[:, i], corners), 0.0, d)
        out[(f"link {i + 1}", "base")] = d - RADIUS - CLEARANCE
    d = _segment_segment(a[:, 0], b[:, 0], a[:, 2], b[:, 2])
    out[("link 1", "link 3")] = d - 2 * RADIUS - CLEARANCE
    return out, geo


@pytest.fixture(scope="module")
def constrained():
    """sim4_task_d_constrained (self-collision on), 60 samples per leg, its result.json."""
    plan = stratcli.plan(ROOT / "scenarios" / "sim4_task_d_constrained.toml")
    assert plan.ok and plan.constraints.spec["self_collision"] is True
    doc = json.loads(json.dumps(result_document(plan, "sim4_task_d_constrained", "one-arm")))
    return plan, simulate.sample(plan, 60), doc


def _self_marks(ax):
    """The self-collision mark of a panel: its text's fields, its segment, its pose."""
    texts = [m.groups() for t in ax.texts if (m := SELF.fullmatch(t.get_text()))]
    segments = [
        line for line in ax.get_lines()
        if line.get_marker() == "o" and to_rgba(line.get_color()) == to_rgba(SELF_COLOR)
    ]  # fmt: skip
    poses = [
        c for c in ax.collections
        if isinstance(c, LineCollection) and np.allclose(c.get_colors(), to_rgba(SELF_COLOR))
    ]  # fmt: skip
    return texts, segments, poses


def test_the_stroboscope_marks_each_legs_closest_approach_between_the_robots_bodies(
    constrained,
):
    plan, traj, doc = constrained
    fig = stroboscope_figure(plan, traj)
    for leg, ax in enumerate(fig.axes[: len(plan.legs)]):
        s = traj.leg_slice(leg)
        margins, geo = _self_margins(plan.system.robot, traj.q[s])
        assert all((m > 0).all() for m in margins.values())  # apart: the distances are exact
        pair, per_sample = min(margins.items(), key=lambda item: item[1].min())
        n = int(np.argmin(per_sample))
        ((first, second, margin, when),), (segment,), (pose,) = _self_marks(ax)
        # the pose of the smallest margin, and the pair of bodies of that margin
        assert (first, second) == pair
        assert when == f"{traj.t[s][n]:.4g}"
        drawn = np.stack((geo["proximal"][n], geo["distal"][n]), axis=-2)
        np.testing.assert_allclose(np.asarray(pose.get_segments()), drawn, atol=1e-12)
        # the leg's margin in result.json (2000 samples: at most the drawn samples' minimum)
        leg_margin = doc["constraints"]["legs"][leg]["self_clearance"]
        assert leg_margin <= per_sample.min() + 1e-9
        assert margin == f"{leg_margin:.3g}"
        # the two points: on the link's capsule surface and on the base's outline, as far
        # apart as the two bodies' surfaces are at that sample (found among 101 points along
        # each core: to a fraction of a millimetre)
        p, q = segment.get_xydata()
        link = int(first.removeprefix("link ")) - 1
        core = _point_segment(p, geo["proximal"][n, link], geo["distal"][n, link])
        assert RADIUS - 1e-4 < core <= RADIUS + 1e-12
        corners = geo["base_corners"][n]
        outline = _point_segment(q, corners, np.roll(corners, -1, axis=0)).min()
        assert second == "base" and outline == pytest.approx(0.0, abs=1e-9)
        gap = per_sample[n] + CLEARANCE  # the surfaces' distance
        assert np.linalg.norm(q - p) == pytest.approx(gap, abs=2e-3)
    assert "closest approach (self)" in [t.get_text() for t in fig.legends[0].get_texts()]


def test_the_closest_pose_shows_its_links_as_the_capsules_measured(constrained):
    """The links were thin lines: nothing showed the capsules (radius 0.05) the clearances
    are measured on. The closest pose's are drawn: every outline point at the radius from
    its link's core, round both ends."""
    from matplotlib.collections import PolyCollection

    plan, traj, _ = constrained
    fig = stroboscope_figure(plan, traj)
    for leg, ax in enumerate(fig.axes[: len(plan.legs)]):
        purple = to_rgba(SELF_COLOR)[:3]
        (capsules,) = [
            c for c in ax.collections
            if isinstance(c, PolyCollection) and len(c.get_facecolor())
            and np.allclose(c.get_facecolor()[0][:3], purple)
        ]  # fmt: skip
        s = traj.leg_slice(leg)
        margins, geo = _self_margins(plan.system.robot, traj.q[s])
        n = int(np.argmin(np.min([m for m in margins.values()], axis=0)))
        outlines = capsules.get_paths()
        assert len(outlines) == geo["proximal"].shape[1]  # one per link
        for link, path in enumerate(outlines):
            core = _point_segment(path.vertices, geo["proximal"][n, link], geo["distal"][n, link])
            np.testing.assert_allclose(core, RADIUS, atol=1e-12)


def test_a_plan_without_self_collision_has_no_such_mark(constrained):
    plan, traj, _ = constrained
    for spec in ({}, {"joint_limits": [-2.5, 2.5], "self_collision": False}):
        free = dataclasses.replace(plan, constraints=ConstraintReport(spec))
        fig = stroboscope_figure(free, traj)
        for ax in fig.axes:
            assert _self_marks(ax) == ([], [], [])
            assert not any(t.get_text().startswith("closest") for t in ax.texts)
        assert "closest approach (self)" not in [t.get_text() for t in fig.legends[0].get_texts()]


def test_obstacle_and_self_marks_are_both_shown_and_their_texts_apart(constrained):
    plan, traj, _ = constrained
    spec = {**plan.constraints.spec,
            "obstacles": [{"shape": "circle", "centre": [1.6, 1.1], "radius": 0.1}]}  # fmt: skip
    both = dataclasses.replace(plan, constraints=dataclasses.replace(plan.constraints, spec=spec))
    fig = stroboscope_figure(both, traj)
    renderer = FigureCanvasAgg(fig).get_renderer()
    for ax in fig.axes[: len(plan.legs)]:
        texts, segments, poses = _self_marks(ax)
        assert len(texts) == len(segments) == len(poses) == 1
        (obstacle,) = [t for t in ax.texts if t.get_text().startswith("closest approach: ")]
        assert to_rgba(obstacle.get_color()) == to_rgba(FAILED_COLOR)
        assert [line.get_marker() for line in ax.get_lines()].count("x") == 1
        (own,) = [t for t in ax.texts if SELF.fullmatch(t.get_text())]
        a, b = obstacle.get_window_extent(renderer), own.get_window_extent(renderer)
        assert not a.overlaps(b)
        assert ax.get_window_extent(renderer).contains(b.x0, b.y0)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert {"obstacle", "closest approach", "closest approach (self)"} <= set(labels)


@pytest.fixture(scope="module")
def failed():
    """sim4_task_c with one Newton iteration (fails), self-collision and an obstacle set."""
    from stratcli.objectives import plan_sequence
    from stratcli.scenario import load_scenario

    task = load_scenario(ROOT / "scenarios" / "sim4_task_c.toml")
    settings = dataclasses.replace(task.settings, objective="newton", max_iterations=1, restarts=0)
    plan = plan_sequence(task.system, task.start, task.legs, settings)
    assert not plan.ok
    spec = {"self_collision": True, "clearance": CLEARANCE,
            "obstacles": [{"shape": "circle", "centre": [1.6, 1.1], "radius": 0.1}]}  # fmt: skip
    report = verify(plan, resolve(ConstraintsSpec.model_validate(spec), plan.system), 200)
    return dataclasses.replace(plan, constraints=report), simulate.sample(plan, 40)


def test_a_failed_plans_figure_still_draws_with_the_marks(failed):
    plan, traj = failed
    fig = stroboscope_figure(plan, traj, "t")
    assert save_figure(fig).startswith(b"\x89PNG")
    assert fig._suptitle.get_text().endswith("FAILED")
    assert all(len(_self_marks(ax)[0]) == 1 for ax in fig.axes[: len(plan.legs)])
    # a leg whose re-integration diverged (NaN from some sample on): marked among the rest
    s = traj.leg_slice(0)
    q = traj.q.copy()
    q[s.start + 10 :] = np.nan
    fig = stroboscope_figure(plan, dataclasses.replace(traj, q=q), "t")
    assert save_figure(fig).startswith(b"\x89PNG")
    ((*_, when),) = _self_marks(fig.axes[0])[0]
    assert float(when) <= traj.t[s.start + 9] + 1e-9
    assert len([t for t in fig.axes[0].texts if "margin nan" in t.get_text()]) == 0
