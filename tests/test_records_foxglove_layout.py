"""`layout.json`: the Foxglove layout written beside `run.mcap` and attached to it."""

from __future__ import annotations

import io
import json

from mcap.reader import make_reader

from stratcli.records.foxglove_layout import (
    LAYOUT_PANELS,
    foxglove_layout,
    message_paths,
    run_layout,
)
from stratcli.records.mcap_log import layout_bytes
from stratcli.records.run import record_files


def _leaves(tree) -> list[str]:
    """Panel ids of a layout's split tree, in order."""
    if isinstance(tree, str):
        return [tree]
    assert set(tree) == {"direction", "first", "second", "splitPercentage"}, tree
    assert tree["direction"] in ("row", "column") and 0 < tree["splitPercentage"] < 100
    return _leaves(tree["first"]) + _leaves(tree["second"])


def _field(schema: dict, fields: list[str]) -> dict:
    """The JSON Schema of `fields` (a message path without its topic) inside `schema`."""
    for name in fields:
        assert schema.get("type") == "object", (fields, schema.get("type"))
        assert name in schema["properties"], f"{name} is not a field ({fields})"
        schema = schema["properties"][name]
    return schema


def _mcap(data: bytes) -> tuple[dict[str, dict], dict[str, bytes]]:
    """(topic → its channel's JSON Schema, attachment name → data) of an MCAP file."""
    reader = make_reader(io.BytesIO(data))
    summary = reader.get_summary()
    schemas = {
        ch.topic: json.loads(summary.schemas[ch.schema_id].data) for ch in summary.channels.values()
    }
    return schemas, {a.name: a.data for a in reader.iter_attachments()}


def test_layout_names_only_topics_and_fields_of_the_log(any_run):
    layout = run_layout(any_run.plan, any_run.traj)
    schemas, attachments = _mcap(any_run.data)
    assert attachments["layout.json"] == layout_bytes(layout)  # mcap_bytes attaches the same
    assert set(layout) == {
        "configById",
        "globalVariables",
        "userNodes",
        "linkedGlobalVariables",
        "playbackConfig",
        "layout",
    }
    panels = _leaves(layout["layout"])
    assert sorted(panels) == sorted(layout["configById"])  # every panel placed, once
    robot = "/tf" in schemas
    margins = "/margins" in schemas  # a plan with [constraints]: its margins plotted
    shown = [p for p in LAYOUT_PANELS if (robot or not p.startswith("3D!"))]
    assert panels == [p for p in shown if margins or p != "Plot!margins"]
    for panel, paths in message_paths(layout).items():
        assert paths, panel
        for path in paths:
            topic, *fields = path.split(".")
            assert topic in schemas, f"{panel}: {topic} is not a channel"
            kind = _field(schemas[topic], fields).get("type")
            if panel.startswith("Plot!"):
                assert kind == "number", (panel, path)
            elif panel.startswith("StateTransitions!"):
                assert kind in ("string", "integer"), (panel, path)
            elif panel.startswith("Indicator!"):  # the status strip: ok or failed
                assert path == "/summary.status" and kind == "string", (panel, path)
                rules = layout["configById"][panel]["rules"]
                assert {r["rawValue"] for r in rules} == set(_field(schemas[topic], fields)["enum"])
            else:
                assert fields == [], (panel, path)  # the 3-D panel names topics
    if robot:
        three_d = layout["configById"]["3D!motion"]
        assert set(three_d["topics"]) == {"/tf", "/scene"} and three_d["followTf"] == "world"
        assert three_d["cameraState"]["distance"] > 0


def test_every_input_and_coordinate_is_plotted(any_run):
    system = any_run.plan.system
    config = run_layout(any_run.plan, any_run.traj)["configById"]
    controls = [p["value"] for p in config["Plot!controls"]["paths"]]
    assert controls == [f"/controls.u.{u}" for u in system.inputs]
    configuration = [p["value"] for p in config["Plot!configuration"]["paths"]]
    assert configuration == [f"/state.q.{q}" for q in system.states]
    stratum = [p["value"] for p in config["StateTransitions!stratum"]["paths"]]
    assert stratum[0] == "/state.stratum"


def test_follow_the_base_frame_and_no_robot():
    layout = foxglove_layout(("x", "theta"), ("u",), robot=True, follow="base", distance=2.0)
    three_d = layout["configById"]["3D!motion"]
    assert three_d["followTf"] == "base" and three_d["followMode"] == "follow-position"
    assert three_d["cameraState"]["distance"] == 2.0
    plain = foxglove_layout(("x", "theta"), ("u",), robot=False)
    assert not any(p.startswith("3D!") for p in plain["configById"])
    json.dumps(layout, allow_nan=False)  # plain JSON


def test_record_files_include_the_layout(biped):
    files = record_files(biped.task, biped.plan, biped.doc, biped.manifest, animation=False)
    _, attachments = _mcap(files["run.mcap"])
    assert layout_bytes(files["layout.json"]) == attachments["layout.json"]
