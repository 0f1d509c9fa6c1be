"""Frames and scene of the MCAP log: /tf moves the manipulator, /scene draws it."""

from __future__ import annotations

import math

import numpy as np
from conftest import (
    mcap_messages,
)

from stratcli.models.geometry import base_extent, world_geometry


def _compose(transforms: list[dict]) -> dict[str, tuple[np.ndarray, float]]:
    """World pose (origin, yaw) of every frame from planar FrameTransforms."""
    by_child = {tf["child_frame_id"]: tf for tf in transforms}
    poses: dict[str, tuple[np.ndarray, float]] = {"world": (np.zeros(2), 0.0)}

    def pose(frame: str) -> tuple[np.ndarray, float]:
        if frame not in poses:
            tf = by_child[frame]
            origin, yaw = pose(tf["parent_frame_id"])
            rot = tf["rotation"]
            assert rot["x"] == rot["y"] == 0.0 and tf["translation"]["z"] == 0.0
            assert math.isclose(rot["z"] ** 2 + rot["w"] ** 2, 1.0)
            t = np.array([tf["translation"]["x"], tf["translation"]["y"]])
            c, s = math.cos(yaw), math.sin(yaw)
            poses[frame] = (
                origin + np.array([c * t[0] - s * t[1], s * t[0] + c * t[1]]),
                yaw + 2 * math.atan2(rot["z"], rot["w"]),
            )
        return poses[frame]

    for child in by_child:
        pose(child)
    return poses


def test_mcap_frames_move_the_manipulator(arm_run):
    """Composing /tf reproduces the drawn geometry; /scene hangs link geometry on the frames."""
    robot, names = arm_run.plan.system.robot, arm_run.doc["coordinates"]
    states = mcap_messages(arm_run.data, "/state")
    tfs = mcap_messages(arm_run.data, "/tf")
    pick = range(0, len(states), 37)
    q = np.array([[states[i][1]["q"][c] for c in names] for i in pick])
    geo = world_geometry(robot, q)
    lengths = [link.length for link in robot.links]
    for row, i in enumerate(pick):
        assert tfs[i][0] == states[i][0]
        tf_time = tfs[i][1]["transforms"][0]["timestamp"]
        assert tf_time["sec"] * 10**9 + tf_time["nsec"] == tfs[i][0]
        poses = _compose(tfs[i][1]["transforms"])
        np.testing.assert_allclose(poses["base"][0], geo["base_center"][row], atol=1e-12)
        assert math.isclose(
            math.remainder(poses["base"][1] - geo["theta"][row], 2 * math.pi), 0, abs_tol=1e-12
        )
        for j in range(robot.n_joints):
            origin, yaw = poses[f"link{j + 1}"]
            tip = origin + lengths[j] * np.array([math.cos(yaw), math.sin(yaw)])
            np.testing.assert_allclose(origin, geo["proximal"][row, j], atol=1e-12)
            np.testing.assert_allclose(tip, geo["distal"][row, j], atol=1e-12)
    ((_, scene),) = mcap_messages(arm_run.data, "/scene")
    entities = {e["id"]: e for e in scene["entities"]}
    hx, hy = base_extent(robot)
    base = entities["base"]
    assert base["frame_id"] == "base" and base["frame_locked"] is True
    assert (base["cubes"][0]["size"]["x"], base["cubes"][0]["size"]["y"]) == (2 * hx, 2 * hy)
    for j in range(robot.n_joints):
        link = entities[f"link{j + 1}"]
        assert link["frame_id"] == f"link{j + 1}"
        cube = link["cubes"][0]
        assert cube["size"]["x"] == lengths[j] and cube["pose"]["position"]["x"] == lengths[j] / 2


def test_the_scene_draws_the_obstacles_of_the_constraints():
    import dataclasses
    from pathlib import Path

    import stratcli
    from stratcli.constraint_report import ConstraintReport
    from stratcli.records.mcap_scene import scene_update

    root = Path(__file__).resolve().parents[1]
    plan = stratcli.plan(root / "scenarios" / "sim4_task_d.toml")
    obstacles = [
        {"shape": "circle", "centre": [-0.3, 1.3], "radius": 0.15},
        {"shape": "box", "centre": [1.9, 0.1], "size": [0.3, 0.2], "rotation": 0.5},
    ]
    plan = dataclasses.replace(plan, constraints=ConstraintReport({"obstacles": obstacles}))
    geo = world_geometry(plan.system.robot, plan.sample(20).q)
    found = {e["id"]: e for e in scene_update(plan, geo, 0)["entities"]}
    circle, box = found["obstacle0"], found["obstacle1"]
    assert circle["frame_id"] == box["frame_id"] == "world"
    (cylinder,) = circle["cylinders"]
    assert cylinder["pose"]["position"]["x"] == -0.3 and cylinder["size"]["x"] == 0.3
    (cube,) = box["cubes"]
    assert (cube["size"]["x"], cube["size"]["y"]) == (0.3, 0.2)
    q = cube["pose"]["orientation"]
    assert math.isclose(2 * math.atan2(q["z"], q["w"]), 0.5)
    # the links as thick as the capsules measured (link_radius, default 0.05): drawn 0.06
    # thick, a closest approach of 5e-4 showed a gap of 0.06 in Foxglove
    spec = {"obstacles": obstacles, "link_radius": 0.08}
    thick = dataclasses.replace(plan, constraints=ConstraintReport(spec))
    links = [e for e in scene_update(thick, geo, 0)["entities"] if e["id"].startswith("link")]
    assert links and all(math.isclose(link["cubes"][0]["size"]["y"], 0.16) for link in links), [
        link["id"] for link in links
    ]
