"""The dense trajectory of a record: re-integrated legs, world geometry."""

from __future__ import annotations

import numpy as np
import pytest

from stratcli.models.geometry import base_extent, world_bodies, world_geometry
from stratcli.models.presets import preset


def test_trajectory_reintegrates_every_leg(any_run):
    plan, traj = any_run.plan, any_run.traj
    assert np.all(np.diff(traj.t) >= 0)
    for k, leg in enumerate(plan.legs):
        s = traj.leg_slice(k)
        assert s.stop - s.start >= 200
        assert np.all(traj.leg[s] == k)
        assert traj.t[s][0] == leg.t0 and traj.t[s][-1] == pytest.approx(leg.t0 + leg.duration)
        np.testing.assert_array_equal(traj.q[s][0], leg.start)
        np.testing.assert_allclose(traj.q[s][-1], leg.end, rtol=0, atol=1e-8)
        for i in leg.locked:  # locked coordinates do not move
            np.testing.assert_allclose(traj.q[s][:, i], leg.start[i], rtol=0, atol=1e-12)
        off = [j for j in range(plan.system.m) if j not in leg.active]
        assert np.all(traj.u[s][:, off] == 0.0) and np.all(traj.du[s][:, off] == 0.0)


def test_world_geometry_conserves_momentum(arm_run):
    """System CM fixed at the origin and zero angular momentum (finite differences)."""
    robot, traj = arm_run.plan.system.robot, arm_run.traj
    m = np.array([robot.base.mass] + [link.mass for link in robot.links])
    inertia = np.array([robot.base.inertia] + [link.inertia for link in robot.links])
    com = np.array([link.com / link.length for link in robot.links])[None, :, None]
    for k in range(len(arm_run.plan.legs)):
        s = traj.leg_slice(k)
        geo = world_geometry(robot, traj.q[s])
        d = geo["distal"] - geo["proximal"]
        r = np.concatenate([geo["base_center"][:, None], geo["proximal"] + com * d], axis=1)
        assert np.abs((m[None, :, None] * r).sum(axis=1)).max() < 1e-12
        phi = np.concatenate(
            [geo["theta"][:, None], np.unwrap(np.arctan2(d[..., 1], d[..., 0]), axis=0)], axis=1
        )
        rd = np.gradient(r, traj.t[s], axis=0)
        terms = m * (r[..., 0] * rd[..., 1] - r[..., 1] * rd[..., 0])
        terms = terms + inertia * np.gradient(phi, traj.t[s], axis=0)
        scale = np.abs(terms).sum(axis=1).max()
        assert np.abs(terms.sum(axis=1)).max() < 1e-3 * scale


def test_base_rectangle_carries_the_arms(arm_run):
    """Every arm's first joint lies on the edge of the base rectangle."""
    robot = arm_run.plan.system.robot
    hx, hy = base_extent(robot)
    assert {round(2 * hx, 12), round(2 * hy, 12)} == {robot.base.a, robot.base.b}
    geo = world_geometry(robot, arm_run.traj.q[::50])
    first = [joints[0] for joints in robot.arm_joints]
    c, s = np.cos(geo["theta"]), np.sin(geo["theta"])
    rel = geo["proximal"][:, first] - geo["base_center"][:, None]
    x = c[:, None] * rel[..., 0] + s[:, None] * rel[..., 1]  # back to the base frame
    y = -s[:, None] * rel[..., 0] + c[:, None] * rel[..., 1]
    np.testing.assert_allclose(np.maximum(np.abs(x) / hx, np.abs(y) / hy), 1.0, atol=1e-12)


@pytest.mark.parametrize("name", ["one-arm", "two-arm"])
def test_world_bodies_are_world_geometrys_bodies_to_the_bit(name):
    """The search's lean geometry places the base and the links as the records draw them."""
    robot = preset(name).robot
    q = np.random.default_rng(5).normal(scale=2.0, size=(64, robot.n_joints + 1))
    corners, links = world_bodies(robot, q)
    geo = world_geometry(robot, q)
    np.testing.assert_array_equal(corners, geo["base_corners"])
    np.testing.assert_array_equal(links[:, :, 0], geo["proximal"])
    np.testing.assert_array_equal(links[:, :, 1], geo["distal"])
