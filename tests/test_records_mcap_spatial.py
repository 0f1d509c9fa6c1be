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
