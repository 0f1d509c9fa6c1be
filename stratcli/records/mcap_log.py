"""`run.mcap`: the planned motion as an MCAP log that opens in Foxglove (DESIGN §10).

Every channel is JSON-encoded with a JSON Schema:

| topic | schema | messages |
|---|---|---|
| `/state` | `stratplan.State` | one per sample: `t`, `leg`, `stratum`, `q` {coordinate: value} |
| `/controls` | `stratplan.Controls` | one per sample: `t`, `leg`, `stratum`, `u`, `du` |
| `/legs` | `stratplan.Leg` | `kind: "leg"` at each leg's start, `kind: "switch"` at each switch |
| `/summary` | `stratplan.Summary` | one, at the end: status, energies, end point, ... |
| `/tf` | `foxglove.FrameTransforms` | manipulators: one per sample, world → base → links |
| `/scene` | `foxglove.SceneUpdate` | manipulators: once, base, links, end-effector path |

Samples are those of a `Trajectory` (both ends of every leg, so a switch instant appears twice).
Log times are nanoseconds: the run's start (`manifest["started"]`, else 0) plus the time on the
motion's own axis, and they never decrease along the file. The manifest is the metadata record
`"manifest"` (values that are not strings are JSON-encoded) and the scenario text is the
attachment `scenario.toml`.

Non-finite numbers (NaN or ±inf in the samples of a failed plan) are written as JSON `null`,
and log times are clamped to the range of an unsigned 64-bit nanosecond stamp (a NaN time
counts as the run's start), so a failed or extreme plan still gets a valid log.

Frames for Foxglove's 3-D panel: `world` is the inertial frame with its origin at the fixed
system CM; `base` sits at the base CM rotated by θ about z; each arm is a chain
`base → link1 → link2 ...` whose frames sit at the link's proximal joint with x along the link,
so the geometry, sent once in link-local coordinates, moves with the transforms.
"""

from __future__ import annotations

import io
import json
import math
from datetime import UTC, datetime
from typing import Any

import mcap
import numpy as np
from mcap.writer import Writer

from .. import __version__
from ..sequence import SequencePlan
from .rundir import finite_or_none
from .trajectory import Trajectory, base_extent, world_geometry

__all__ = ["SCHEMA_NAMES", "epoch_ns", "mcap_bytes"]

SCHEMA_NAMES = {
    "/state": "stratplan.State",
    "/controls": "stratplan.Controls",
    "/legs": "stratplan.Leg",
    "/summary": "stratplan.Summary",
    "/tf": "foxglove.FrameTransforms",
    "/scene": "foxglove.SceneUpdate",
}

# --------------------------------------------------------------------------------------------
# JSON Schemas
# --------------------------------------------------------------------------------------------

_NUMBER = {"type": "number"}
_NULLABLE = {"type": ["number", "null"]}
_STRING = {"type": "string"}
_INTEGER = {"type": "integer"}


def _named(names: tuple[str, ...], value: dict, description: str) -> dict:
    return {
        "type": "object",
        "description": description,
        "properties": {name: value for name in names},
    }


def _schema(title: str, description: str, properties: dict) -> dict:
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
        "description": description,
        "type": "object",
        "properties": properties,
    }


def _own_schemas(states: tuple[str, ...], inputs: tuple[str, ...]) -> dict[str, dict]:
    sample = {
        "t": {"type": "number", "description": "time [s] on the motion's axis"},
        "leg": {"type": "integer", "description": "leg index (0-based, as in result.json)"},
        "stratum": _STRING,
    }
    leg_fields = {
        "kind": {"enum": ["leg", "switch"]},
        "leg": {"type": "integer", "description": "kind leg: its index (0-based)"},
        "stratum": _STRING,
        "method": _STRING,
        "evaluator": _STRING,
        "active_inputs": {"type": "array", "items": _STRING},
        "locked": {"type": "array", "items": _STRING},
        "t0": _NUMBER,
        "duration": _NUMBER,
        "start": _named(states, _NUMBER, "configuration at the leg's start"),
        "goal": _named(states, _NULLABLE, "goal of the leg (null: not prescribed)"),
        "end": _named(states, _NUMBER, "configuration reached"),
        "error": _NUMBER,
        "converged": {"type": "boolean"},
        "iterations": _INTEGER,
        "attempts": _INTEGER,
        "free_coefficients": _INTEGER,
        "energy": _NUMBER,
        "coefficients": _named(
            inputs,
            {"type": "array", "items": _NUMBER},
            "Fourier coefficients per active input (λ0, sines, cosines)",
        ),
        "time": {"type": "number", "description": "kind switch: switch instant [s]"},
        "after_leg": {"type": "integer", "description": "kind switch: the leg it ends"},
        "jump": _named(inputs, _NUMBER, "u_next(0) − u_prev(T)"),
        "jump_derivative": _named(inputs, _NUMBER, "u'_next(0) − u'_prev(T)"),
        "max_jump": _NUMBER,
    }
    summary_fields = {
        "scenario": _STRING,
        "model": _STRING,
        "status": {"enum": ["ok", "failed"]},
        "message": _STRING,
        "total_energy": _NUMBER,
        "reference_energy": _NULLABLE,
        "duration": _NUMBER,
        "legs": _INTEGER,
        "switches": _INTEGER,
        "max_switch_jump": _NUMBER,
        "continuity": _STRING,
        "soft_start": {"type": "boolean"},
        "full_stop": {"type": "boolean"},
        "tolerance": _NUMBER,
        "start": _named(states, _NUMBER, "start configuration"),
        "goal": _named(states, _NULLABLE, "goal (null: not prescribed)"),
        "end": _named(states, _NUMBER, "configuration reached"),
    }
    return {
        "/state": _schema(
            "stratplan.State",
            "configuration of the system at one instant",
            {**sample, "q": _named(states, _NUMBER, "coordinates (rad for manipulators)")},
        ),
        "/controls": _schema(
            "stratplan.Controls",
            "controls and their derivatives at one instant (inactive inputs are 0)",
            {
                **sample,
                "u": _named(inputs, _NUMBER, "controls"),
                "du": _named(inputs, _NUMBER, "time derivatives of the controls"),
            },
        ),
        "/legs": _schema(
            "stratplan.Leg",
            "a leg (at its start time) or a switch between legs (at the switch time)",
            leg_fields,
        ),
        "/summary": _schema("stratplan.Summary", "outcome of the run", summary_fields),
    }


# Foxglove well-known schemas, JSON encoding (docs.foxglove.dev message schemas; the
# foxglove/schemas repository's jsonschema/FrameTransforms.json and SceneUpdate.json). Only the
# fields written here are described.
_TIME = {
    "type": "object",
    "title": "time",
    "properties": {
        "sec": {"type": "integer", "minimum": 0},
        "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999},
    },
}
_DURATION = {
    "type": "object",
    "title": "duration",
    "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer", "minimum": 0}},
}
_VECTOR3 = {
    "title": "foxglove.Vector3",
    "type": "object",
    "properties": {"x": _NUMBER, "y": _NUMBER, "z": _NUMBER},
}
_QUATERNION = {
    "title": "foxglove.Quaternion",
    "type": "object",
    "properties": {"x": _NUMBER, "y": _NUMBER, "z": _NUMBER, "w": _NUMBER},
}
_POSE = {
    "title": "foxglove.Pose",
    "type": "object",
    "properties": {"position": _VECTOR3, "orientation": _QUATERNION},
}
_COLOR = {
    "title": "foxglove.Color",
    "type": "object",
    "properties": {"r": _NUMBER, "g": _NUMBER, "b": _NUMBER, "a": _NUMBER},
}
_SIZED = {
    "type": "object",
    "properties": {"pose": _POSE, "size": _VECTOR3, "color": _COLOR},
}
FRAME_TRANSFORMS_SCHEMA = {
    "title": "foxglove.FrameTransforms",
    "description": "An array of FrameTransform messages",
    "type": "object",
    "properties": {
        "transforms": {
            "type": "array",
            "items": {
                "title": "foxglove.FrameTransform",
                "type": "object",
                "properties": {
                    "timestamp": _TIME,
                    "parent_frame_id": _STRING,
                    "child_frame_id": _STRING,
                    "translation": _VECTOR3,
                    "rotation": _QUATERNION,
                },
            },
        }
    },
}
SCENE_UPDATE_SCHEMA = {
    "title": "foxglove.SceneUpdate",
    "description": "An update to the entities displayed in a 3D scene",
    "type": "object",
    "properties": {
        "deletions": {
            "type": "array",
            "items": {
                "title": "foxglove.SceneEntityDeletion",
                "type": "object",
                "properties": {"timestamp": _TIME, "type": _INTEGER, "id": _STRING},
            },
        },
        "entities": {
            "type": "array",
            "items": {
                "title": "foxglove.SceneEntity",
                "type": "object",
                "properties": {
                    "timestamp": _TIME,
                    "frame_id": _STRING,
                    "id": _STRING,
                    "lifetime": _DURATION,
                    "frame_locked": {"type": "boolean"},
                    "metadata": {
                        "type": "array",
                        "items": {
                            "title": "foxglove.KeyValuePair",
                            "type": "object",
                            "properties": {"key": _STRING, "value": _STRING},
                        },
                    },
                    "cubes": {
                        "type": "array",
                        "items": {"title": "foxglove.CubePrimitive", **_SIZED},
                    },
                    "spheres": {
                        "type": "array",
                        "items": {"title": "foxglove.SpherePrimitive", **_SIZED},
                    },
                    "lines": {
                        "type": "array",
                        "items": {
                            "title": "foxglove.LinePrimitive",
                            "type": "object",
                            "properties": {
                                "type": _INTEGER,
                                "pose": _POSE,
                                "thickness": _NUMBER,
                                "scale_invariant": {"type": "boolean"},
                                "points": {"type": "array", "items": _VECTOR3},
                                "color": _COLOR,
                                "indices": {"type": "array", "items": _INTEGER},
                            },
                        },
                    },
                },
            },
        },
    },
}
LINE_STRIP = 0  # foxglove.LineType


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------


def epoch_ns(manifest: dict[str, Any] | None) -> int:
    """Nanoseconds since the Unix epoch of `manifest["started"]` (ISO 8601), else 0."""
    started = (manifest or {}).get("started")
    if not isinstance(started, str):
        return 0
    try:
        when = datetime.fromisoformat(started)
    except ValueError:
        return 0
    if when.tzinfo is None:
        when = when.replace(tzinfo=UTC)
    delta = when - datetime(1970, 1, 1, tzinfo=UTC)
    ns = (delta.days * 86_400 + delta.seconds) * 1_000_000_000 + delta.microseconds * 1_000
    return max(ns, 0)


def _stamp(ns: int) -> dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _json(obj: Any) -> bytes:
    """Compact JSON; NaN and ±inf become null (the fast path assumes all values finite)."""
    try:
        text = json.dumps(obj, separators=(",", ":"), allow_nan=False)
    except ValueError:
        text = json.dumps(finite_or_none(obj), separators=(",", ":"), allow_nan=False)
    return text.encode("utf-8")


MAX_NS = 2**64 - 1


def _log_time(epoch: int, t: Any) -> int:
    """Log time in ns of motion time `t` (s), clamped to [epoch, 2**64 - 1]; NaN → epoch."""
    ns = float(t) * 1e9
    if not ns > 0:  # NaN, negative
        return min(epoch, MAX_NS)
    return min(epoch + round(min(ns, float(MAX_NS))), MAX_NS)


def _named_values(names: tuple[str, ...], values: Any) -> dict[str, float | None]:
    out: dict[str, float | None] = {}
    for name, v in zip(names, values, strict=True):
        out[name] = None if v is None or (isinstance(v, float) and math.isnan(v)) else float(v)
    return out


def _quat_z(angle: float) -> dict[str, float]:
    """Rotation by `angle` about z as a quaternion."""
    return {"x": 0.0, "y": 0.0, "z": math.sin(angle / 2), "w": math.cos(angle / 2)}


def _vec3(x: float, y: float, z: float = 0.0) -> dict[str, float]:
    return {"x": float(x), "y": float(y), "z": float(z)}


def _color(r: float, g: float, b: float, a: float = 1.0) -> dict[str, float]:
    return {"r": r, "g": g, "b": b, "a": a}


_IDENTITY = {"position": _vec3(0, 0), "orientation": _quat_z(0.0)}


class _Log:
    """Registers JSON channels and writes messages with non-decreasing log times."""

    def __init__(self, writer: Writer) -> None:
        self.writer = writer
        self.channels: dict[str, int] = {}
        self.sequence: dict[str, int] = {}
        self.last = 0

    def channel(self, topic: str, schema: dict) -> None:
        schema_id = self.writer.register_schema(
            name=schema["title"], encoding="jsonschema", data=_json(schema)
        )
        self.channels[topic] = self.writer.register_channel(
            topic=topic, message_encoding="json", schema_id=schema_id
        )
        self.sequence[topic] = 0

    def write(self, topic: str, log_time: int, message: dict) -> None:
        if log_time < self.last:  # pragma: no cover - guarded by construction
            raise ValueError(f"log time went back on {topic}: {log_time} < {self.last}")
        self.last = log_time
        self.writer.add_message(
            channel_id=self.channels[topic],
            log_time=log_time,
            data=_json(message),
            publish_time=log_time,
            sequence=self.sequence[topic],
        )
        self.sequence[topic] += 1


# --------------------------------------------------------------------------------------------
# Manipulator frames and geometry
# --------------------------------------------------------------------------------------------


def _link_frames(plan: SequencePlan) -> list[tuple[str, str]]:
    """(frame, parent) of every link: each arm is a chain from the base."""
    robot = plan.system.robot
    out, j = [], 0
    for arm in robot.arms:
        parent = "base"
        for _ in arm.links:
            out.append((f"link{j + 1}", parent))
            parent = f"link{j + 1}"
            j += 1
    return out


def _transforms(geo: dict[str, np.ndarray], frames: list[tuple[str, str]], i: int, ns: int):
    stamp = _stamp(ns)
    centre, theta = geo["base_center"][i], float(geo["theta"][i])
    out = [
        {
            "timestamp": stamp,
            "parent_frame_id": "world",
            "child_frame_id": "base",
            "translation": _vec3(centre[0], centre[1]),
            "rotation": _quat_z(theta),
        }
    ]
    origin, angle = geo["base_proximal"][i], geo["link_angle"][i]  # base frame
    index = {name: j for j, (name, _) in enumerate(frames)}
    for j, (name, parent) in enumerate(frames):
        if parent == "base":
            offset, rel = origin[j], float(angle[j])
        else:
            p = index[parent]
            d = origin[j] - origin[p]
            c, s = math.cos(angle[p]), math.sin(angle[p])
            offset = (c * d[0] + s * d[1], -s * d[0] + c * d[1])  # R(−β_parent) d
            rel = float(angle[j] - angle[p])
        out.append(
            {
                "timestamp": stamp,
                "parent_frame_id": parent,
                "child_frame_id": name,
                "translation": _vec3(offset[0], offset[1]),
                "rotation": _quat_z(rel),
            }
        )
    return {"transforms": out}


def _scene(plan: SequencePlan, geo: dict[str, np.ndarray], ns: int) -> dict:
    robot = plan.system.robot
    hx, hy = base_extent(robot)
    lengths = [link.length for link in robot.links]
    scale = max([*lengths, 2 * hx, 2 * hy])
    width = 0.06 * scale
    stamp = _stamp(ns)
    zero = {"sec": 0, "nsec": 0}

    def entity(frame: str, name: str, locked: bool = True, **primitives) -> dict:
        return {
            "timestamp": stamp,
            "frame_id": frame,
            "id": name,
            "lifetime": zero,
            "frame_locked": locked,
            "metadata": [],
            **primitives,
        }

    entities = [
        entity(
            "base",
            "base",
            cubes=[
                {
                    "pose": _IDENTITY,
                    "size": _vec3(2 * hx, 2 * hy, 0.3 * min(2 * hx, 2 * hy)),
                    "color": _color(0.60, 0.65, 0.70, 0.9),
                }
            ],
        )
    ]
    for j, (name, _) in enumerate(_link_frames(plan)):
        length = lengths[j]
        entities.append(
            entity(
                name,
                name,
                cubes=[
                    {
                        "pose": {"position": _vec3(length / 2, 0.0), "orientation": _quat_z(0)},
                        "size": _vec3(length, width, width),
                        "color": _color(0.10, 0.22, 0.50),
                    }
                ],
                spheres=[
                    {
                        "pose": _IDENTITY,
                        "size": _vec3(1.6 * width, 1.6 * width, 1.6 * width),
                        "color": _color(0.83, 0.33, 0.0),
                    }
                ],
            )
        )
    arm = geo["arm_of_link"]
    for a in range(int(arm.max()) + 1):
        tip = int(np.flatnonzero(arm == a)[-1])
        path = geo["distal"][:, tip]
        entities.append(
            entity(
                "world",
                f"path{a + 1}",
                locked=False,
                lines=[
                    {
                        "type": LINE_STRIP,
                        "pose": _IDENTITY,
                        "thickness": 2.0,
                        "scale_invariant": True,
                        "points": [_vec3(x, y) for x, y in path],
                        "color": _color(0.83, 0.33, 0.0, 0.8),
                        "indices": [],
                    }
                ],
            )
        )
    return {"deletions": [], "entities": entities}


# --------------------------------------------------------------------------------------------
# The file
# --------------------------------------------------------------------------------------------


def mcap_bytes(
    plan: SequencePlan,
    traj: Trajectory,
    result_doc: dict[str, Any],
    manifest: dict[str, Any] | None,
    scenario_text: str,
    scenario_name: str,
) -> bytes:
    """The run as an MCAP file (bytes), ready for `write_run`.

    Parameters
    ----------
    plan : the planned sequence; `traj` : its samples (`trajectory.sample(plan)`).
    result_doc : `result_document(plan, ...)`, the source of the leg, switch and summary fields.
    manifest : `manifest.json`'s content: stored as the metadata record "manifest"; its
        `started` time (ISO 8601) is the epoch of the log times.
    scenario_text, scenario_name : the scenario file, attached as `scenario.toml`.
    """
    system = plan.system
    states, inputs = tuple(system.states), tuple(system.inputs)
    epoch = epoch_ns(manifest)

    def at(t: float) -> int:
        return _log_time(epoch, t)

    buf = io.BytesIO()
    writer = Writer(buf)
    writer.start(profile="", library=f"stratplan {__version__}; mcap {mcap.__version__}")
    log = _Log(writer)
    for topic, schema in _own_schemas(states, inputs).items():
        log.channel(topic, schema)
    manipulator = (
        system.robot is not None and system.n == system.robot.n_joints + 1 and traj.size > 0
    )
    if manipulator:
        log.channel("/tf", FRAME_TRANSFORMS_SCHEMA)
        log.channel("/scene", SCENE_UPDATE_SCHEMA)
        geo = world_geometry(system.robot, traj.q)
        frames = _link_frames(plan)

    writer.add_metadata(
        "manifest",
        {
            str(k): v if isinstance(v, str) else _json(v).decode("utf-8")
            for k, v in (manifest or {}).items()
        },
    )
    writer.add_attachment(
        create_time=epoch,
        log_time=epoch,
        name="scenario.toml",
        media_type="application/toml",
        data=scenario_text.encode("utf-8"),
    )

    t_first = float(traj.t[0]) if traj.size else 0.0
    if manipulator and traj.size:
        log.write("/scene", at(t_first), _scene(plan, geo, at(t_first)))
    legs_doc = result_doc.get("legs", [])
    switches = {sw["after_leg"]: sw for sw in result_doc.get("switches", [])}
    for k, leg in enumerate(plan.legs):
        doc = legs_doc[k]
        piece = doc["pieces"][0] if doc.get("pieces") else {"coefficients": {}}
        log.write(
            "/legs",
            at(leg.t0),
            {
                "kind": "leg",
                "leg": k,
                **{key: doc[key] for key in _LEG_KEYS if key in doc},
                "start": _named_values(states, doc["start"]),
                "goal": _named_values(states, doc["goal"]),
                "end": _named_values(states, doc["end"]),
                "coefficients": piece["coefficients"],
            },
        )
        s = traj.leg_slice(k)
        for i in range(s.start, s.stop):
            ns = at(traj.t[i])
            head = {"t": float(traj.t[i]), "leg": k, "stratum": leg.stratum}
            log.write("/state", ns, {**head, "q": _named_values(states, traj.q[i])})
            log.write(
                "/controls",
                ns,
                {
                    **head,
                    "u": _named_values(inputs, traj.u[i]),
                    "du": _named_values(inputs, traj.du[i]),
                },
            )
            if manipulator:
                log.write("/tf", ns, _transforms(geo, frames, i, ns))
        if leg.index in switches:
            sw = switches[leg.index]
            jumps = [abs(v) for v in sw["jump"].values()]
            log.write(
                "/legs",
                at(max(sw["time"], float(traj.t[s.stop - 1]))),
                {
                    "kind": "switch",
                    "time": sw["time"],
                    "after_leg": sw["after_leg"],
                    "jump": sw["jump"],
                    "jump_derivative": sw["jump_derivative"],
                    "max_jump": max(jumps, default=0.0),
                },
            )
    all_jumps = [abs(v) for sw in result_doc.get("switches", []) for v in sw["jump"].values()]
    log.write(
        "/summary",
        max(log.last, at(traj.t[-1] if traj.size else 0.0)),
        {
            **{key: result_doc.get(key) for key in _SUMMARY_KEYS},
            "scenario": result_doc.get("scenario", scenario_name),
            "legs": len(plan.legs),
            "switches": len(plan.switches),
            "max_switch_jump": max(all_jumps, default=0.0),
            "start": _named_values(states, result_doc["start"]),
            "goal": _named_values(states, result_doc["goal"]),
            "end": _named_values(states, result_doc["end"] or [None] * len(states)),
        },
    )
    writer.finish()
    return buf.getvalue()


_LEG_KEYS = (
    "stratum",
    "method",
    "evaluator",
    "active_inputs",
    "locked",
    "t0",
    "duration",
    "error",
    "converged",
    "iterations",
    "attempts",
    "free_coefficients",
    "energy",
)
_SUMMARY_KEYS = (
    "model",
    "status",
    "message",
    "total_energy",
    "reference_energy",
    "duration",
    "continuity",
    "soft_start",
    "full_stop",
    "tolerance",
)
