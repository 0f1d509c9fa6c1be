"""The MCAP log (read back with mcap's reader): channels, schemas, messages, metadata."""

from __future__ import annotations

import dataclasses
import io
import json

import numpy as np
import pytest
from conftest import (
    EPOCH,
    ROOT,
    STARTED,
    mcap_messages,
)
from mcap.reader import make_reader

import stratcli
import stratcli.simulate as simulate
from stratcli.api.planning import plan_run
from stratcli.objectives import plan_sequence
from stratcli.records.mcap_log import _json, _log_time, epoch_ns, mcap_bytes
from stratcli.records.mcap_schemas import SCHEMA_NAMES
from stratcli.records.plots import render_plots
from stratcli.records.result import result_document
from stratcli.records.trajectory import sample
from stratcli.scenario import load_scenario


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


def test_mcap_channels_schemas_and_counts(any_run):
    reader = make_reader(io.BytesIO(any_run.data))
    summary = reader.get_summary()
    topics = {ch.topic: ch for ch in summary.channels.values()}
    manipulator = any_run.plan.system.robot is not None
    expected = {"/state", "/controls", "/legs", "/summary"}
    if manipulator:
        expected |= {"/tf", "/scene"}
    if any_run.plan.constraints is not None:
        expected |= {"/margins"}
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
    assert counts.get("/margins", counts["/state"]) == counts["/state"]
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
    states = mcap_messages(any_run.data, "/state")
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
    for _, msg in mcap_messages(any_run.data, "/controls"):
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
    events = mcap_messages(any_run.data, "/legs")
    legs = [msg for _, msg in events if msg["kind"] == "leg"]
    switches = [(t, msg) for t, msg in events if msg["kind"] == "switch"]
    assert [m["stratum"] for m in legs] == [leg["stratum"] for leg in doc["legs"]]
    for msg, leg_doc in zip(legs, doc["legs"], strict=True):
        assert msg["energy"] == leg_doc["energy"] and msg["error"] == leg_doc["error"]
        goal = [msg["goal"].get(c) for c in doc["coordinates"]]  # not prescribed: left out
        assert goal == leg_doc["goal"]
    for (t, msg), sw in zip(switches, doc["switches"], strict=True):
        assert t == EPOCH + round(sw["time"] * 1e9)
        assert msg["jump"] == sw["jump"] and msg["after_leg"] == sw["after_leg"]
    ((_, summary),) = mcap_messages(any_run.data, "/summary")
    assert summary["status"] == "ok" and summary["total_energy"] == doc["total_energy"]
    assert [summary["end"][c] for c in doc["coordinates"]] == doc["end"]
    assert summary["objective"] == doc["objective"] and summary["time_scale"] == doc["time_scale"]
    limits = doc.get("constraints")
    for k, msg in enumerate(legs):  # result.json's margins of the leg, where it has them
        leg_doc = limits["legs"][k] if limits else {}
        assert msg.get("margins", {}) == {k: v for k, v in leg_doc.items() if v is not None}


def test_margins_are_the_room_to_each_limit_at_every_sample():
    """/margins against the limits measured here from /state and /controls (joint limits of
    ±π, rate 0.5, acceleration 1), and each leg's smallest clearance against result.json's."""
    task = load_scenario(ROOT / "scenarios" / "sim4_task_d_rate_limited.toml")
    plan = plan_run(task, check=False).result  # the time scaling and verification too
    assert plan.ok and plan.constraints is not None
    traj = sample(plan)
    doc = json.loads(json.dumps(result_document(plan, "rate", task.model_name)))
    data = mcap_bytes(plan, traj, doc, {"started": STARTED}, task.text, "rate")
    margins = [msg for _, msg in mcap_messages(data, "/margins")]
    states = [msg for _, msg in mcap_messages(data, "/state")]
    controls = [msg for _, msg in mcap_messages(data, "/controls")]
    assert len(margins) == len(states) == traj.size
    joints = ("q1", "q2", "q3")
    for m, s, c in zip(margins, states, controls, strict=True):
        assert (m["t"], m["leg"], m["stratum"]) == (s["t"], s["leg"], s["stratum"])
        room = min(min(s["q"][j] + np.pi, np.pi - s["q"][j]) for j in joints)
        assert m["joint_limit"] == pytest.approx(room, abs=1e-12)
        assert m["rate"] == pytest.approx(0.5 - max(abs(v) for v in c["u"].values()), abs=1e-12)
        accel = 1.0 - max(abs(v) for v in c["du"].values())
        assert m["acceleration"] == pytest.approx(accel, abs=1e-12)
        assert set(m) == {"t", "leg", "stratum", "joint_limit", "rate", "acceleration"}
    for k, leg in enumerate(doc["constraints"]["legs"]):  # 2000 other samples a leg there
        rates = [m["rate"] for m in margins if m["leg"] == k]
        assert min(rates) == pytest.approx(leg["rate"], abs=1e-3)


def test_obstacle_margins_are_the_clearances_result_json_measures(obstacles):
    margins = [msg for _, msg in mcap_messages(obstacles.data, "/margins")]
    assert margins and all(set(m) == {"t", "leg", "stratum", "obstacle_clearance"} for m in margins)
    for k, leg in enumerate(obstacles.doc["constraints"]["legs"]):
        low = min(m["obstacle_clearance"] for m in margins if m["leg"] == k)
        assert low == pytest.approx(leg["obstacle_clearance"], abs=2e-3)  # 2000 other samples


def test_failed_run_is_logged_up_to_the_failing_leg():
    task = load_scenario(ROOT / "scenarios" / "sim4_task_c.toml")
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
    ((log_time, summary),) = mcap_messages(data, "/summary")
    assert summary["status"] == "failed" and "leg 1" in summary["message"]
    assert log_time == 0  # at the start (no manifest: the epoch is 0): shown all along
    assert len(mcap_messages(data, "/state")) == len(mcap_messages(data, "/tf")) == traj.size


def test_nan_samples_still_give_a_valid_log_and_plots(unicycle_plan, monkeypatch):
    task, plan = unicycle_plan
    monkeypatch.setattr(simulate, "MAX_EVALUATIONS", 20)
    traj = simulate.sample(plan, 50)
    doc = result_document(plan, task.scenario.name, task.model_name, None)
    data = mcap_bytes(plan, traj, doc, {}, task.text, task.scenario.name)
    messages = list(make_reader(io.BytesIO(data)).iter_messages())
    state = next(json.loads(m.data) for _, c, m in messages if c.topic == "/state")
    assert state["q"] == {}  # NaN left out, never null
    files = render_plots(plan, traj, "nan")  # plots that cannot be drawn are left out
    assert set(files) <= {"configuration.png", "controls.png"}
    assert "controls.png" in files


def test_json_and_log_times_of_non_finite_values():
    assert json.loads(_json({"a": [1.0, float("nan"), float("inf")], "b": -np.inf})) == {
        "a": [1.0, None, None],  # a list keeps its indices; a mapping leaves the value out
    }
    assert _log_time(5, float("nan")) == 5
    assert _log_time(5, 1e308) == 2**64 - 1
    assert _log_time(5, 1.0) == 5 + 10**9


# ------------------------------------------------------------------------------------------
# Every message against its channel's JSON Schema, with the reference validator
# ------------------------------------------------------------------------------------------


def _schema_errors(data: bytes) -> list[str]:
    """Every message of an MCAP file validated against the JSON Schema its channel declares."""
    jsonschema = pytest.importorskip("jsonschema")
    errors, validators = [], {}
    for schema, channel, message in make_reader(io.BytesIO(data)).iter_messages():
        if schema.id not in validators:
            document = json.loads(schema.data)
            cls = jsonschema.validators.validator_for(document)
            cls.check_schema(document)
            validators[schema.id] = cls(document)
        for e in validators[schema.id].iter_errors(json.loads(message.data)):
            errors.append(f"{channel.topic} {list(e.absolute_path)}: {e.message}")
    return errors


def _foxglove_readable(schema: dict, path: str = "") -> None:
    """Foxglove reads a JSON Schema field by field: one type each, objects with properties."""
    assert schema.get("type") == "object" and "properties" in schema, path
    for name, field in schema["properties"].items():
        assert isinstance(field.get("type"), str), f"{path}.{name}: {field.get('type')!r}"
        if field["type"] == "object":
            _foxglove_readable(field, f"{path}.{name}")
        if field["type"] == "array":
            assert isinstance(field["items"].get("type"), str), f"{path}.{name}[]"
            if field["items"]["type"] == "object":
                _foxglove_readable(field["items"], f"{path}.{name}[]")


def test_every_message_validates_against_its_schema(any_run):
    assert _schema_errors(any_run.data) == []
    for schema in make_reader(io.BytesIO(any_run.data)).get_summary().schemas.values():
        _foxglove_readable(json.loads(schema.data), schema.name)


def test_failed_and_nan_runs_validate_against_their_schemas(unicycle_plan, monkeypatch):
    task = load_scenario(ROOT / "scenarios" / "sim4_task_c.toml")
    settings = dataclasses.replace(task.settings, max_iterations=1, restarts=0)
    plan = plan_sequence(task.system, task.start, task.legs, settings)
    assert not plan.ok
    doc = result_document(plan, "failed", task.model_name)
    assert _schema_errors(mcap_bytes(plan, sample(plan), doc, None, task.text, "failed")) == []
    task, plan = unicycle_plan  # the custom model, its samples NaN from the first step
    monkeypatch.setattr(simulate, "MAX_EVALUATIONS", 20)
    traj = simulate.sample(plan, 50)
    doc = result_document(plan, task.scenario.name, task.model_name, None)
    data = mcap_bytes(plan, traj, doc, {}, task.text, task.scenario.name)
    assert np.isnan(traj.q).all() and _schema_errors(data) == []


def test_layout_is_attached_as_json(arm_run):
    attachments = {a.name: a for a in make_reader(io.BytesIO(arm_run.data)).iter_attachments()}
    layout = attachments["layout.json"]
    assert layout.media_type == "application/json" and layout.log_time == EPOCH
    assert "3D!motion" in json.loads(layout.data)["configById"]


def test_a_lie_legs_every_step_is_in_its_legs_message_and_rebuilds_its_controls():
    """/legs carried the first piece's coefficients only, and no basis: Sim 3's Lie leg (8
    steps) rebuilt from the log missed /controls by 2060 rad/s. Every piece is there, as
    result.json has them, and the controls rebuilt from them are the logged ones."""
    task = load_scenario(ROOT / "scenarios" / "sim3_hybrid.toml")
    plan = plan_run(task, check=False).result
    traj = sample(plan)
    doc = json.loads(json.dumps(result_document(plan, "sim3", task.model_name)))
    data = mcap_bytes(plan, traj, doc, {"started": STARTED}, task.text, "sim3")
    legs = [msg for _, msg in mcap_messages(data, "/legs") if msg["kind"] == "leg"]
    controls = [msg for _, msg in mcap_messages(data, "/controls")]
    assert len(legs[2]["pieces"]) == len(doc["legs"][2]["pieces"]) > 1
    for k, leg in enumerate(legs):
        assert leg["pieces"] == doc["legs"][k]["pieces"]
        for sample_ in (c for c in controls if c["leg"] == k):
            tau = sample_["t"] - leg["t0"]
            piece = next(
                p for p in reversed(leg["pieces"]) if p["t0"] <= tau + 1e-12
            )  # (at a step's end: the next step's start, as the log samples it)
            basis = stratcli.FourierBasis(**{
                key: piece["basis"][key] for key in ("harmonics", "period")
            })  # fmt: skip
            values = basis.values(tau - piece["t0"])
            for name, coefficients in piece["coefficients"].items():
                rebuilt = float(np.dot(coefficients, values))
                assert abs(rebuilt - sample_["u"][name]) < 1e-9 * max(1.0, abs(rebuilt))
