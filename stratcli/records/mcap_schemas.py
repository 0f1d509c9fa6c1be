"""JSON Schemas of the channels of `run.mcap` (no I/O).

Every channel of the MCAP log is JSON-encoded and registered with a JSON Schema. This module
holds them: `SCHEMA_NAMES` (topic → schema name), `own_schemas` for stratplan's own channels
(`/state`, `/controls`, `/legs`, `/summary`, whose properties are named after the model's
coordinates and inputs) and the subsets of Foxglove's well-known `FrameTransforms` and
`SceneUpdate` schemas that `/tf` and `/scene` use, and the `std_msgs/String` shape of a URDF
robot's `/robot_description`. The writer is `mcap_log`.

Every field has exactly one JSON type (`"type": "number"`, never `["number", "null"]`, and an
`enum` always with its `type`): Foxglove's JSON Schema reader turns a channel schema into
datatypes field by field and rejects a type list or a missing type, which would leave the whole
channel undecodable. A value that is not there (a goal coordinate that is not prescribed, a NaN
of a failed plan) is therefore left out of its message, never written as `null`.
"""

from __future__ import annotations

from ..constraints import MARGIN_KINDS

__all__ = [
    "FRAME_TRANSFORMS_SCHEMA",
    "ROBOT_DESCRIPTION_SCHEMA",
    "SCENE_UPDATE_SCHEMA",
    "SCHEMA_NAMES",
    "own_schemas",
]

SCHEMA_NAMES = {
    "/state": "stratplan.State",
    "/controls": "stratplan.Controls",
    "/legs": "stratplan.Leg",
    "/summary": "stratplan.Summary",
    "/margins": "stratplan.Margins",
    "/tf": "foxglove.FrameTransforms",
    "/scene": "foxglove.SceneUpdate",
    "/robot_description": "std_msgs/String",
}

# --------------------------------------------------------------------------------------------
# JSON Schemas
# --------------------------------------------------------------------------------------------

_NUMBER = {"type": "number"}
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


def own_schemas(states: tuple[str, ...], inputs: tuple[str, ...]) -> dict[str, dict]:
    sample = {
        "t": {"type": "number", "description": "time [s] on the motion's axis"},
        "leg": {"type": "integer", "description": "leg index (0-based, as in result.json)"},
        "stratum": _STRING,
    }
    leg_fields = {
        "kind": {"type": "string", "enum": ["leg", "switch"]},
        "leg": {"type": "integer", "description": "kind leg: its index (0-based)"},
        "stratum": _STRING,
        "method": _STRING,
        "evaluator": _STRING,
        "active_inputs": {"type": "array", "items": _STRING},
        "locked": {"type": "array", "items": _STRING},
        "t0": _NUMBER,
        "duration": _NUMBER,
        "start": _named(states, _NUMBER, "configuration at the leg's start"),
        "goal": _named(states, _NUMBER, "goal of the leg (a coordinate left out: not prescribed)"),
        "end": _named(states, _NUMBER, "configuration reached"),
        "error": _NUMBER,
        "converged": {"type": "boolean"},
        "iterations": _INTEGER,
        "attempts": _INTEGER,
        "free_coefficients": _INTEGER,
        "energy": _NUMBER,
        "strategy": {"type": "string", "description": "how the leg was planned (result.json)"},
        "margins": _named(
            MARGIN_KINDS,
            _NUMBER,
            "kind leg, plans with [constraints]: smallest room to each limit over the leg on "
            "2000 re-integrated samples (result.json's constraints.legs)",
        ),
        "coefficients": _named(
            inputs,
            {"type": "array", "items": _NUMBER},
            "the first piece's Fourier coefficients per active input (λ0, sines, cosines)",
        ),
        "pieces": {
            "type": "array",
            "description": "every piece of the leg's controls, as result.json's legs[].pieces "
            "(a Lie leg: one a step): t0 from the leg's start and duration [s], basis "
            "(harmonics, period [s]) and coefficients per active input",
            "items": {
                "type": "object",
                "properties": {
                    "t0": _NUMBER,
                    "duration": _NUMBER,
                    "basis": {
                        "type": "object",
                        "properties": {
                            "kind": _STRING,
                            "harmonics": _INTEGER,
                            "period": _NUMBER,
                        },
                    },
                    "coefficients": _named(
                        inputs, {"type": "array", "items": _NUMBER}, "per active input"
                    ),
                },
            },
        },
        "time": {"type": "number", "description": "kind switch: switch instant [s]"},
        "after_leg": {"type": "integer", "description": "kind switch: the leg it ends"},
        "jump": _named(inputs, _NUMBER, "u_next(0) − u_prev(T)"),
        "jump_derivative": _named(inputs, _NUMBER, "u'_next(0) − u'_prev(T)"),
        "max_jump": _NUMBER,
    }
    summary_fields = {
        "scenario": _STRING,
        "model": _STRING,
        "status": {"type": "string", "enum": ["ok", "failed"]},
        "message": _STRING,
        "total_energy": _NUMBER,
        "reference_energy": _NUMBER,
        "duration": _NUMBER,
        "legs": _INTEGER,
        "switches": _INTEGER,
        "max_switch_jump": _NUMBER,
        "continuity": _STRING,
        "soft_start": {"type": "boolean"},
        "full_stop": {"type": "boolean"},
        "tolerance": _NUMBER,
        "start": _named(states, _NUMBER, "start configuration"),
        "goal": _named(states, _NUMBER, "goal (a coordinate left out: not prescribed)"),
        "end": _named(states, _NUMBER, "configuration reached"),
        "objective": _STRING,
        "time_scale": {"type": "number", "description": "s of result.json: 1 unless rescaled"},
        "duration_set_by": {"type": "string", "description": "the limit that set the duration"},
        "violated": {"type": "string", "description": "the first limit broken, if any"},
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
# A URDF robot's URDF text, as ROS publishes it (`std_msgs/String`): Foxglove's 3-D panel draws
# the robot of a `/robot_description` topic from its `data` field.
ROBOT_DESCRIPTION_SCHEMA = {
    "title": "std_msgs/String",
    "description": "A URDF robot's URDF text",
    "type": "object",
    "properties": {"data": _STRING},
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
                    "cylinders": {
                        "type": "array",
                        "items": {
                            "title": "foxglove.CylinderPrimitive",
                            "type": "object",
                            "properties": {
                                "pose": _POSE,
                                "size": _VECTOR3,
                                "bottom_scale": _NUMBER,
                                "top_scale": _NUMBER,
                                "color": _COLOR,
                            },
                        },
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
