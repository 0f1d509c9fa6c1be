"""Run-record outputs: dense trajectory, MCAP log (read back with mcap's reader), plots.

Scenarios: sim4_task_c (one-arm, 3 legs), sim2_soft (two-arm, mirrored arms, soft start and
full stop) and the biped (a custom model without a robot drawing; planned with the automatic
evaluator to keep this fast).
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from PIL import Image

from stratcli.records.mcap_log import epoch_ns, mcap_bytes
from stratcli.records.mcap_schemas import SCHEMA_NAMES
from stratcli.records.plots import render_plots
from stratcli.records.result import result_document
from stratcli.records.trajectory import base_extent, sample, world_geometry
from stratcli.scenario import load_scenario
from stratcli.stratified import plan_sequence

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
STARTED = "2026-11-22T09:05:08.123456+00:00"
EPOCH = 1_795_338_308_123_456_000  # STARTED in ns since 1970
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@dataclasses.dataclass
class Run:
    name: str
    task: object
    plan: object
    traj: object
    doc: dict
    manifest: dict
    data: bytes


def _run(name: str, evaluator: str | None = None) -> Run:
    task = load_scenario(SCENARIOS / f"{name}.toml")
    changes = {"evaluator": evaluator} if evaluator else {}
    if "objective" in {f.name for f in dataclasses.fields(task.settings)}:
        changes["objective"] = "newton"  # the paper's method: fast; these tests need any plan
    settings = dataclasses.replace(task.settings, **changes)
    plan = plan_sequence(task.system, task.start, task.legs, settings)
    assert plan.ok
    traj = sample(plan)
    doc = json.loads(json.dumps(result_document(plan, name, task.model_name)))  # as on disk
    manifest = {"schema": "stratplan.manifest/1", "started": STARTED, "seeds": {"planner": 0}}
    data = mcap_bytes(plan, traj, doc, manifest, task.text, name)
    return Run(name, task, plan, traj, doc, manifest, data)


@pytest.fixture(scope="module")
def one_arm() -> Run:
    return _run("sim4_task_c")


@pytest.fixture(scope="module")
def two_arm() -> Run:
    return _run("sim2_soft")


@pytest.fixture(scope="module")
def biped() -> Run:
    return _run("biped", evaluator="auto")


@pytest.fixture(params=["one_arm", "two_arm", "biped"])
def any_run(request) -> Run:
    return request.getfixturevalue(request.param)


@pytest.fixture(params=["one_arm", "two_arm"])
def arm_run(request) -> Run:
    return request.getfixturevalue(request.param)


def _conforms(value, schema: dict, path: str = "") -> None:
    """Every field written is declared in the channel's JSON Schema, with a matching type."""
    kinds = schema.get("type")
    kinds = [kinds] if isinstance(kinds, str) else kinds or []
    python = {
        "object": dict,
        "array": list,
        "string": str,
        "boolean": bool,
        "integer": int,
        "number": (int, float),
        "null": type(None),
    }
    if kinds:
        assert any(isinstance(value, python[k]) for k in kinds), (path, value, kinds)
        if isinstance(value, bool):
            assert "boolean" in kinds, path
    if "enum" in schema:
        assert value in schema["enum"], path
    if isinstance(value, dict) and "properties" in schema:
        for key, item in value.items():
            assert key in schema["properties"], f"{path}.{key} is not in the schema"
            _conforms(item, schema["properties"][key], f"{path}.{key}")
    if isinstance(value, list) and "items" in schema:
        for item in value:
            _conforms(item, schema["items"], f"{path}[]")


def _messages(data: bytes, topic: str) -> list[tuple[int, dict]]:
    reader = make_reader(io.BytesIO(data))
    return [(m.log_time, json.loads(m.data)) for _, _, m in reader.iter_messages(topics=[topic])]


# --------------------------------------------------------------------------------------------
# Trajectory
# --------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------
# MCAP
# --------------------------------------------------------------------------------------------


def test_mcap_channels_schemas_and_counts(any_run):
    reader = make_reader(io.BytesIO(any_run.data))
    summary = reader.get_summary()
    topics = {ch.topic: ch for ch in summary.channels.values()}
    manipulator = any_run.plan.system.robot is not None
    expected = {"/state", "/controls", "/legs", "/summary"}
    if manipulator:
        expected |= {"/tf", "/scene"}
    assert set(topics) == expected
    counts = {
        ch.topic: summary.statistics.channel_message_counts.get(ch.id, 0) for ch in topics.values()
    }
    legs = len(any_run.plan.legs)
    for topic, ch in topics.items():
        schema = summary.schemas[ch.schema_id]
        assert (schema.name, schema.encoding, ch.message_encoding) == (
            SCHEMA_NAMES[topic],
            "jsonschema",
            "json",
        )
        assert json.loads(schema.data)["title"] == schema.name
    assert counts["/state"] == counts["/controls"] == any_run.traj.size >= 200 * legs
    assert counts["/legs"] == legs + len(any_run.plan.switches)
    assert counts["/summary"] == 1
    if manipulator:
        assert counts["/tf"] == counts["/state"]
        assert counts["/scene"] == 1
    for schema, channel, message in reader.iter_messages():
        _conforms(json.loads(message.data), json.loads(schema.data), channel.topic)
    times = [m.log_time for _, _, m in reader.iter_messages(log_time_order=False)]
    assert times == sorted(times)  # in file order, not only after sorting by the reader
    assert times[0] == EPOCH and times[-1] == EPOCH + round(any_run.plan.duration * 1e9)


def test_mcap_metadata_and_attachment(one_arm):
    reader = make_reader(io.BytesIO(one_arm.data))
    metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    assert metadata["manifest"]["started"] == STARTED
    assert json.loads(metadata["manifest"]["seeds"]) == {"planner": 0}
    attachments = {a.name: a for a in reader.iter_attachments()}
    scenario = attachments["scenario.toml"]
    assert scenario.media_type == "application/toml"
    assert scenario.data.decode("utf-8") == one_arm.task.text
    assert epoch_ns({"started": STARTED}) == EPOCH
    assert epoch_ns({}) == epoch_ns(None) == 0


def test_mcap_state_reproduces_result(any_run):
    doc, names = any_run.doc, any_run.doc["coordinates"]
    states = _messages(any_run.data, "/state")
    for log_time, msg in states:
        assert abs(log_time - EPOCH - msg["t"] * 1e9) <= 1
    q = np.array([[msg["q"][c] for c in names] for _, msg in states])
    leg = np.array([msg["leg"] for _, msg in states])
    np.testing.assert_allclose(q[0], doc["start"], rtol=0, atol=1e-8)
    np.testing.assert_allclose(q[-1], doc["end"], rtol=0, atol=1e-8)
    for k, leg_doc in enumerate(doc["legs"]):
        rows = np.flatnonzero(leg == k)
        assert {states[i][1]["stratum"] for i in rows} == {leg_doc["stratum"]}
        np.testing.assert_allclose(q[rows[0]], leg_doc["start"], rtol=0, atol=1e-8)
        np.testing.assert_allclose(q[rows[-1]], leg_doc["end"], rtol=0, atol=1e-8)
        assert states[rows[0]][1]["t"] == leg_doc["t0"]
        assert states[rows[-1]][1]["t"] == pytest.approx(leg_doc["t0"] + leg_doc["duration"])


def test_mcap_locked_input_is_exactly_zero(any_run):
    doc = any_run.doc
    seen_off = 0
    for _, msg in _messages(any_run.data, "/controls"):
        active = doc["legs"][msg["leg"]]["active_inputs"]
        for name in doc["inputs"]:
            if name not in active:
                assert msg["u"][name] == 0.0 and msg["du"][name] == 0.0
                seen_off += 1
    assert seen_off > 0 or all(
        len(leg["active_inputs"]) == len(doc["inputs"]) for leg in doc["legs"]
    )


def test_mcap_legs_and_summary(any_run):
    doc = any_run.doc
    events = _messages(any_run.data, "/legs")
    legs = [msg for _, msg in events if msg["kind"] == "leg"]
    switches = [(t, msg) for t, msg in events if msg["kind"] == "switch"]
    assert [m["stratum"] for m in legs] == [leg["stratum"] for leg in doc["legs"]]
    for msg, leg_doc in zip(legs, doc["legs"], strict=True):
        assert msg["energy"] == leg_doc["energy"] and msg["error"] == leg_doc["error"]
        assert [msg["goal"][c] for c in doc["coordinates"]] == leg_doc["goal"]  # null kept
    for (t, msg), sw in zip(switches, doc["switches"], strict=True):
        assert t == EPOCH + round(sw["time"] * 1e9)
        assert msg["jump"] == sw["jump"] and msg["after_leg"] == sw["after_leg"]
    ((_, summary),) = _messages(any_run.data, "/summary")
    assert summary["status"] == "ok" and summary["total_energy"] == doc["total_energy"]
    assert [summary["end"][c] for c in doc["coordinates"]] == doc["end"]


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
    states = _messages(arm_run.data, "/state")
    tfs = _messages(arm_run.data, "/tf")
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
    ((_, scene),) = _messages(arm_run.data, "/scene")
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


# --------------------------------------------------------------------------------------------
# Plots
# --------------------------------------------------------------------------------------------


def test_plots_of_a_manipulator(one_arm):
    files = render_plots(one_arm.plan, one_arm.traj, one_arm.name)
    assert set(files) == {"configuration.png", "controls.png", "stroboscope.png", "motion.gif"}
    for name in ("configuration.png", "controls.png", "stroboscope.png"):
        data = files[name]
        assert data.startswith(PNG_MAGIC) and 20_000 < len(data) < 2_000_000
        width, height = Image.open(io.BytesIO(data)).size
        assert 600 <= width <= 2000 and 300 <= height <= 2000
    gif = Image.open(io.BytesIO(files["motion.gif"]))
    assert files["motion.gif"][:6] == b"GIF89a" and len(files["motion.gif"]) < 2_000_000
    assert 10 <= gif.n_frames <= 120 and gif.info.get("loop") == 0
    gif.seek(0)
    first = np.asarray(gif.convert("RGB")).copy()
    gif.seek(gif.n_frames // 2)
    assert not np.array_equal(first, np.asarray(gif.convert("RGB")))  # it moves


def test_plots_without_animation(two_arm):
    files = render_plots(two_arm.plan, two_arm.traj, two_arm.name, animation=False)
    assert set(files) == {"configuration.png", "controls.png", "stroboscope.png"}
    assert all(data.startswith(PNG_MAGIC) for data in files.values())


def test_plots_of_a_custom_model(biped):
    files = render_plots(biped.plan, biped.traj, biped.name)
    assert set(files) == {"configuration.png", "controls.png"}
    for data in files.values():
        assert data.startswith(PNG_MAGIC) and len(data) > 20_000


def test_failed_run_is_logged_up_to_the_failing_leg():
    task = load_scenario(SCENARIOS / "sim4_task_c.toml")
    changes = {"max_iterations": 1, "restarts": 0}
    if "objective" in {f.name for f in dataclasses.fields(task.settings)}:
        changes["objective"] = "newton"
    plan = plan_sequence(
        task.system, task.start, task.legs, dataclasses.replace(task.settings, **changes)
    )
    assert not plan.ok and len(plan.legs) == 1
    traj = sample(plan)
    doc = result_document(plan, "failed", task.model_name)
    data = mcap_bytes(plan, traj, doc, None, task.text, "failed")
    ((log_time, summary),) = _messages(data, "/summary")
    assert summary["status"] == "failed" and "leg 1" in summary["message"]
    assert log_time == round(plan.legs[0].duration * 1e9)  # no manifest: the epoch is 0
    assert len(_messages(data, "/state")) == len(_messages(data, "/tf")) == traj.size
