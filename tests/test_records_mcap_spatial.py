"""The MCAP of a spatial plan: /tf frames named after the URDF links, the URDF attached."""

import io
from pathlib import Path

import numpy as np
import pytest
from conftest import mcap_messages
from mcap.reader import make_reader

pytest.importorskip("pinocchio")

from stratcli import so3
from stratcli.api import plan_run
from stratcli.records.mcap_log import mcap_bytes
from stratcli.records.trajectory import sample
from stratcli.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def spatial_run():
    task = load_scenario(ROOT / "scenarios" / "spatial" / "arm3_reorient.toml")
    task = task.with_changes({"planner": {"objective": "newton"}})
    out = plan_run(task, check=False)
    traj = sample(out.result, samples_per_leg=20)
    data = mcap_bytes(out.result, traj, out.document, {}, task.text, "arm3_reorient")
    return task, out, traj, data


def test_tf_frames_are_the_urdf_links(spatial_run):
    _, out, traj, data = spatial_run
    messages = mcap_messages(data, "/tf")
    assert len(messages) == traj.size
    frames = {(t["parent_frame_id"], t["child_frame_id"]) for t in messages[-1][1]["transforms"]}
    assert frames == {("world", "base"), ("base", "l1"), ("l1", "l2"), ("l2", "l3")}
    # the last base rotation is the plan's end attitude (re-integrated samples)
    base = next(t for t in messages[-1][1]["transforms"] if t["child_frame_id"] == "base")
    r = base["rotation"]
    R = so3.matrix_from_quaternion([r["w"], r["x"], r["y"], r["z"]])
    end = np.array(out.document["end"])
    assert np.linalg.norm(so3.log(so3.exp(end[3:]).T @ R)) < 1e-7


def test_urdf_is_attached_and_published(spatial_run):
    task, out, traj, data = spatial_run
    attachments = {a.name: a for a in make_reader(io.BytesIO(data)).iter_attachments()}
    assert attachments["ff_arm3.urdf"].data.decode() == task.system.spatial.text
    ((ns, message),) = mcap_messages(data, "/robot_description")
    assert message == {"data": task.system.spatial.text}
    assert ns == mcap_messages(data, "/tf")[0][0]  # from the first sample on
    # named as the record's copy when the manifest says which (`model_files`)
    named = mcap_bytes(out.result, traj, out.document, {"urdf": {"file": "mine.urdf"}}, "", "x")
    names = {a.name for a in make_reader(io.BytesIO(named)).iter_attachments()}
    assert "mine.urdf" in names and "ff_arm3.urdf" not in names


def test_layout_draws_the_urdf_in_the_3d_panel_from_the_log(spatial_run):
    _, out, traj, _ = spatial_run
    from stratcli.records.foxglove_layout import THREE_D, run_layout

    panel = run_layout(out.result, traj)["configById"][THREE_D]
    assert panel["topics"]["/robot_description"] == {"visible": True}
    assert "urdf" not in panel["layers"]  # no file path, which the record could not keep
    assert panel["cameraState"]["perspective"]


# --------------------------------------------------------------------------------------------
# /scene: the robot drawn on the link frames of /tf
# --------------------------------------------------------------------------------------------


def _world_poses(transforms: list[dict]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """World pose (position, rotation) of every frame, composed from FrameTransforms."""
    by_child = {tf["child_frame_id"]: tf for tf in transforms}
    poses = {"world": (np.zeros(3), np.eye(3))}

    def pose(frame: str) -> tuple[np.ndarray, np.ndarray]:
        if frame not in poses:
            tf = by_child[frame]
            p, R = pose(tf["parent_frame_id"])
            t, r = tf["translation"], tf["rotation"]
            dR = so3.matrix_from_quaternion([r["w"], r["x"], r["y"], r["z"]])
            poses[frame] = (p + R @ np.array([t["x"], t["y"], t["z"]]), R @ dR)
        return poses[frame]

    for child in by_child:
        pose(child)
    return poses


def _rotation(pose: dict) -> np.ndarray:
    r = pose["orientation"]
    return so3.matrix_from_quaternion([r["w"], r["x"], r["y"], r["z"]])


def _xyz(v: dict) -> np.ndarray:
    return np.array([v["x"], v["y"], v["z"]])


def test_scene_draws_every_link_on_a_frame_tf_publishes(spatial_run):
    """One message, at the first sample; every link's entity hangs on the /tf frame of its
    name (frame-locked, for the whole log), the tip path on the world frame."""
    import jsonschema

    from stratcli.records.mcap_schemas import SCENE_UPDATE_SCHEMA

    _, _, traj, data = spatial_run
    ((ns, scene),) = mcap_messages(data, "/scene")
    tfs = mcap_messages(data, "/tf")
    assert ns == tfs[0][0]
    jsonschema.validate(scene, SCENE_UPDATE_SCHEMA)
    published = {t["child_frame_id"] for _, m in tfs for t in m["transforms"]}
    published |= {t["parent_frame_id"] for _, m in tfs for t in m["transforms"]}
    entities = {e["id"]: e for e in scene["entities"]}
    assert set(entities) == {"base", "l1", "l2", "l3", "path/l3"}
    assert {e["frame_id"] for e in scene["entities"]} <= published
    for name in ("base", "l1", "l2", "l3"):
        e = entities[name]
        assert e["frame_id"] == name and e["frame_locked"] is True
        assert e["lifetime"] == {"sec": 0, "nsec": 0}
    assert entities["path/l3"]["frame_id"] == "world"
    assert entities["path/l3"]["frame_locked"] is False
    assert len(entities["path/l3"]["lines"][0]["points"]) == traj.size
    sizes = [
        _xyz(p["size"])
        for e in scene["entities"]
        for kind in ("cubes", "spheres", "cylinders")
        for p in e.get(kind, [])
    ]
    assert len(sizes) == 1 + 3 + 4  # the box, a sphere per joint, a cylinder per segment
    assert all(np.all(np.isfinite(s)) and np.all(s > 0) for s in sizes)


def test_link_cylinders_span_the_joint_origins_pinocchio_parsed(spatial_run):
    """Each cylinder runs from its link's origin to a child joint's origin (Pinocchio's joint
    placement): its length is their distance and its axis (z) points at the child; the leaf l3
    runs to twice its URDF centre of mass (0.5 0 0)."""
    task, _, _, data = spatial_run
    model = task.system.spatial.model
    ((_, scene),) = mcap_messages(data, "/scene")
    entities = {e["id"]: e for e in scene["entities"]}
    children = {"base": "j1", "l1": "j2", "l2": "j3"}
    ends = {
        link: np.asarray(model.jointPlacements[model.getJointId(j)].translation)
        for link, j in children.items()
    }
    ends["l3"] = 2.0 * np.array([0.5, 0.0, 0.0])
    for link, end in ends.items():
        (cylinder,) = entities[link]["cylinders"]
        size = _xyz(cylinder["size"])
        assert size[2] == pytest.approx(np.linalg.norm(end), rel=1e-12)
        np.testing.assert_allclose(_xyz(cylinder["pose"]["position"]), end / 2, atol=1e-12)
        axis = _rotation(cylinder["pose"]) @ np.array([0.0, 0.0, 1.0])
        np.testing.assert_allclose(axis, end / np.linalg.norm(end), atol=1e-12)
        assert size[0] == size[1] < 0.2 * size[2]  # thin: a link, not a slab


def test_base_box_has_the_base_mass_and_inertia(spatial_run):
    """A uniform box of the base's mass with the drawn edges and orientation has the base
    body's inertia tensor about its centre of mass (Pinocchio's, base frame)."""
    task, _, _, data = spatial_run
    inertia = task.system.spatial.model.inertias[1]
    ((_, scene),) = mcap_messages(data, "/scene")
    (box,) = next(e for e in scene["entities"] if e["id"] == "base")["cubes"]
    a, b, c = _xyz(box["size"])
    m = inertia.mass
    local = np.diag([b * b + c * c, a * a + c * c, a * a + b * b]) * m / 12
    R = _rotation(box["pose"])
    np.testing.assert_allclose(R @ local @ R.T, inertia.inertia, atol=1e-12)
    np.testing.assert_allclose(_xyz(box["pose"]["position"]), inertia.lever, atol=1e-12)


def test_tip_path_is_the_leaf_tip_that_tf_moves(spatial_run):
    """The path's points are, sample by sample, the far end of l3's cylinder carried to the
    world by composing that sample's /tf."""
    _, _, _, data = spatial_run
    ((_, scene),) = mcap_messages(data, "/scene")
    entities = {e["id"]: e for e in scene["entities"]}
    points = np.array([_xyz(p) for p in entities["path/l3"]["lines"][0]["points"]])
    (cylinder,) = entities["l3"]["cylinders"]
    tip = 2.0 * _xyz(cylinder["pose"]["position"])
    tfs = mcap_messages(data, "/tf")
    for i in (0, len(tfs) // 2, len(tfs) - 1):
        p, R = _world_poses(tfs[i][1]["transforms"])["l3"]
        np.testing.assert_allclose(points[i], p + R @ tip, atol=1e-9)
    assert np.ptp(points, axis=0).max() > 0.1  # the arm moves


def test_links_foxglove_draws_from_their_visuals_are_left_out(tmp_path):
    """A link whose visuals are all primitives is Foxglove's to draw from the URDF; a mesh
    (a path the record does not hold) and no visual at all are drawn in /scene."""
    from types import SimpleNamespace

    from stratcli.models.spatial import load_spatial
    from stratcli.records.mcap_spatial_scene import spatial_scene, visual_links

    text = (ROOT / "robots" / "arm3.urdf").read_text()
    visual = "<visual><geometry><{}/></geometry></visual></link>"
    cylinder = visual.format('cylinder radius="0.05" length="1"')
    mesh = visual.format('mesh filename="package://a/b.stl"')
    text = text.replace('</link>\n  <link name="l3">', cylinder + '\n  <link name="l3">', 1)
    text = text.replace("</link>\n  <joint", mesh + "\n  <joint", 1)  # l3's, before the joints
    (tmp_path / "visual.urdf").write_text(text)
    robot = load_spatial(tmp_path / "visual.urdf").spatial
    drawn, coms = visual_links(robot.text)
    assert drawn == {"l2"} and coms["l3"].tolist() == [0.5, 0.0, 0.0]
    plan = SimpleNamespace(system=SimpleNamespace(spatial=robot))
    scene = spatial_scene(plan, np.zeros((2, robot.n_joints + 3)), 0)
    assert [e["id"] for e in scene["entities"]] == ["base", "l1", "l3", "path/l3"]


def test_fixed_joints_and_a_tool_tip_on_the_seven_joint_arm():
    """bus_arm7: the bus's cylinder reaches the fixed mount (0.3 0 0.4) and the tip path
    starts 0.145 m past joint 7 (twice link_7's centre of mass: its 0.1 m tool's end); every
    entity's frame is one /tf publishes."""
    from types import SimpleNamespace

    from stratcli.models.spatial import load_spatial
    from stratcli.records.mcap_spatial import spatial_transforms
    from stratcli.records.mcap_spatial_scene import spatial_scene

    robot = load_spatial(ROOT / "robots" / "bus_arm7.urdf").spatial
    plan = SimpleNamespace(system=SimpleNamespace(spatial=robot))
    q = np.zeros(robot.n_joints + 3)
    scene = spatial_scene(plan, q[None], 0)
    tf = spatial_transforms(plan, q, 0)["transforms"]
    frames = {t["child_frame_id"] for t in tf} | {"world"}
    entities = {e["id"]: e for e in scene["entities"]}
    assert set(entities) == {"bus", *(f"link_{i}" for i in range(8)), "path/link_7"}
    assert {e["frame_id"] for e in scene["entities"]} <= frames
    (mount,) = entities["bus"]["cylinders"]
    np.testing.assert_allclose(2 * _xyz(mount["pose"]["position"]), [0.3, 0.0, 0.4])
    (start,) = entities["path/link_7"]["lines"][0]["points"]
    p, R = _world_poses(tf)["link_7"]
    np.testing.assert_allclose(_xyz(start), p + R @ [0.0, 0.0, 0.145], atol=1e-12)


def test_a_leaf_fixed_to_the_base_gets_no_tip_path(tmp_path):
    """A camera on the bus (a fixed joint to the base) was drawn a 'tip path' in /scene,
    which traced only the base's own turning; a tool fixed to the last link keeps its."""
    from types import SimpleNamespace

    from stratcli.models.spatial import load_spatial
    from stratcli.records.mcap_spatial_scene import spatial_scene

    text = (ROOT / "robots" / "arm3.urdf").read_text()
    inertial = (
        '<inertial><mass value="0.1"/>'
        '<inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial>'
    )
    extra = (
        f'<link name="camera">{inertial}</link><joint name="cam" type="fixed"><parent link="base"/>'
        '<child link="camera"/><origin xyz="0.2 0 0.1"/></joint>'
        f'<link name="tool">{inertial}</link><joint name="flange" type="fixed"><parent link="l3"/>'
        '<child link="tool"/><origin xyz="0.1 0 0"/></joint></robot>'
    )
    (tmp_path / "cam.urdf").write_text(text.replace("</robot>", extra))
    robot = load_spatial(tmp_path / "cam.urdf").spatial
    plan = SimpleNamespace(system=SimpleNamespace(spatial=robot))
    scene = spatial_scene(plan, np.zeros((2, robot.n_joints + 3)), 0)
    paths = [e["id"] for e in scene["entities"] if e["id"].startswith("path/")]
    assert paths == ["path/tool"]
