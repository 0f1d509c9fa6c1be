"""`run.mcap`: the planned motion as an MCAP log that opens in Foxglove.

Every channel is JSON-encoded with a JSON Schema:

| topic | schema | messages |
|---|---|---|
| `/state` | `stratplan.State` | one per sample: `t`, `leg`, `stratum`, `q` {coordinate: value} |
| `/controls` | `stratplan.Controls` | one per sample: `t`, `leg`, `stratum`, `u`, `du` |
| `/legs` | `stratplan.Leg` | `kind: "leg"` at each leg's start, `kind: "switch"` at each switch |
| `/summary` | `stratplan.Summary` | one, at the start: status, energies, end point, ... |
| `/margins` | `stratplan.Margins` | plans with [constraints]: per sample, the room to each limit |
| `/tf` | `foxglove.FrameTransforms` | manipulators, URDF robots: per sample, world → base → links |
| `/scene` | `foxglove.SceneUpdate` | manipulators, URDF robots: once, base, links, tip paths |
| `/robot_description` | `std_msgs/String` | URDF robots: once, the URDF's text (`data`) |

Samples are those of a `Trajectory` (both ends of every leg, so a switch instant appears twice).
Log times are nanoseconds: the run's start (`manifest["started"]`, else 0) plus the time on the
motion's own axis, and they never decrease along the file. The manifest is the metadata record
`"manifest"` (values that are not strings are JSON-encoded); the scenario text is the
attachment `scenario.toml` and the Foxglove layout (`foxglove_layout`) the attachment
`layout.json`.

A value that is not there is left out of its message, never written as `null`: a non-finite
number (NaN or ±inf in the samples of a failed plan) and a goal coordinate that is not
prescribed are absent keys (inside a list, where a key cannot be left out, it is `null`). Every
field of the schemas then has one JSON type, as Foxglove's JSON Schema reader requires (see
`mcap_schemas`). Log times are clamped to the range of an unsigned 64-bit nanosecond stamp (a
NaN time counts as the run's start), so a failed or extreme plan still gets a valid log.

The channels' JSON Schemas are in `mcap_schemas`; the frames of Foxglove's 3-D panel and the
`/tf` and `/scene` messages are built by `mcap_scene` (a URDF robot's by `mcap_spatial` and
`mcap_spatial_scene`). This module writes the file.
"""

from __future__ import annotations

import io
import json
import math
from collections.abc import Callable
from datetime import UTC, datetime
from typing import Any

import mcap
from mcap.writer import Writer

from .. import __version__
from ..sequence import SequencePlan
from .foxglove_layout import ROBOT_DESCRIPTION, run_layout, shows_robot
from .mcap_margins import MARGINS, MARGINS_SCHEMA, margin_message, margin_rows
from .mcap_scene import frame_transforms, link_frames, scene_update
from .mcap_schemas import (
    FRAME_TRANSFORMS_SCHEMA,
    ROBOT_DESCRIPTION_SCHEMA,
    SCENE_UPDATE_SCHEMA,
    own_schemas,
)
from .mcap_spatial import is_spatial, spatial_transforms, urdf_attachment
from .mcap_spatial_scene import spatial_scene
from .trajectory import Trajectory, world_geometry

__all__ = ["epoch_ns", "layout_bytes", "mcap_bytes", "mcap_log"]

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


def _present(obj: Any) -> Any:
    """`obj` without None and non-finite numbers: left out of mappings, `None` in lists."""
    if isinstance(obj, dict):
        out = {}
        for k, v in obj.items():
            v = _present(v)
            if v is not None:
                out[k] = v
        return out
    if isinstance(obj, list | tuple):
        return [_present(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def _json(obj: Any) -> bytes:
    """Compact JSON; a NaN or ±inf is left out (`_present`; the fast path assumes none)."""
    try:
        text = json.dumps(obj, separators=(",", ":"), allow_nan=False)
    except ValueError:
        text = json.dumps(_present(obj), separators=(",", ":"), allow_nan=False)
    return text.encode("utf-8")


def layout_bytes(layout: dict[str, Any]) -> bytes:
    """`layout.json`'s bytes, as `write_run` writes a dict (indented, a final newline).

    Parameters
    ----------
    layout : a Foxglove layout (`foxglove_layout.run_layout`).

    Returns
    -------
    bytes
        UTF-8 JSON, the content of the `layout.json` attachment and file.
    """
    return (json.dumps(layout, indent=2, allow_nan=False) + "\n").encode("utf-8")


MAX_NS = 2**64 - 1


def _log_time(epoch: int, t: Any) -> int:
    """Log time in ns of motion time `t` (s), clamped to [epoch, 2**64 - 1]; NaN → epoch."""
    ns = float(t) * 1e9
    if not ns > 0:  # NaN, negative
        return min(epoch, MAX_NS)
    return min(epoch + round(min(ns, float(MAX_NS))), MAX_NS)


def _named_values(names: tuple[str, ...], values: Any) -> dict[str, float]:
    """{name: value} of the finite values (None, NaN and ±inf are left out)."""
    out: dict[str, float] = {}
    for name, v in zip(names, values, strict=True):
        if v is not None and math.isfinite(v):
            out[name] = float(v)
    return out


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
# The file
# --------------------------------------------------------------------------------------------


def mcap_bytes(
    plan: SequencePlan,
    traj: Trajectory,
    result_doc: dict[str, Any],
    manifest: dict[str, Any] | None,
    scenario_text: str,
    scenario_name: str,
    layout: dict[str, Any] | None = None,
) -> bytes:
    """The run as an MCAP file (bytes), ready for `write_run`.

    Parameters
    ----------
    plan : the planned sequence; `traj` : its samples (`trajectory.sample(plan)`).
    result_doc : `result_document(plan, ...)`, the source of the leg, switch and summary fields.
    manifest : `manifest.json`'s content: stored as the metadata record "manifest"; its
        `started` time (ISO 8601) is the epoch of the log times.
    scenario_text, scenario_name : the scenario file, attached as `scenario.toml`.
    layout : the Foxglove layout attached as `layout.json` (default: `run_layout(plan, traj)`).
    """
    return mcap_log(plan, traj, result_doc, manifest, scenario_text, scenario_name, layout)(
        manifest
    )


def mcap_log(
    plan: SequencePlan,
    traj: Trajectory,
    result_doc: dict[str, Any],
    manifest: dict[str, Any] | None,
    scenario_text: str,
    scenario_name: str,
    layout: dict[str, Any] | None = None,
) -> Callable[[dict[str, Any] | None], bytes]:
    """`mcap_bytes` in two parts: the log but its manifest now, and a function that adds the
    manifest as it is then and gives the file's bytes. A record builds the log while its
    figures are drawn and adds the manifest once they are, with their time in it (`run`).
    `manifest` here gives the log's epoch (`started`) and a URDF robot's copy (`urdf`).
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
    for topic, schema in own_schemas(states, inputs).items():
        log.channel(topic, schema)
    kinds, margins = margin_rows(plan, traj)
    if kinds:
        log.channel(MARGINS, MARGINS_SCHEMA)
    manipulator = shows_robot(plan, traj)
    spatial = is_spatial(plan) and traj.size > 0  # a URDF robot: /tf after its links
    if manipulator or spatial:
        log.channel("/tf", FRAME_TRANSFORMS_SCHEMA)
    if spatial:
        log.channel(ROBOT_DESCRIPTION, ROBOT_DESCRIPTION_SCHEMA)
        log.channel("/scene", SCENE_UPDATE_SCHEMA)
    if manipulator:
        log.channel("/scene", SCENE_UPDATE_SCHEMA)
        geo = world_geometry(system.robot, traj.q)
        frames = link_frames(plan)

    writer.add_attachment(
        create_time=epoch,
        log_time=epoch,
        name="scenario.toml",
        media_type="application/toml",
        data=scenario_text.encode("utf-8"),
    )
    writer.add_attachment(
        create_time=epoch,
        log_time=epoch,
        name="layout.json",
        media_type="application/json",
        data=layout_bytes(run_layout(plan, traj) if layout is None else layout),
    )

    if spatial:
        name, data = urdf_attachment(plan, manifest)
        writer.add_attachment(
            create_time=epoch, log_time=epoch, name=name, media_type="application/xml", data=data
        )
    t_first = float(traj.t[0]) if traj.size else 0.0
    if manipulator and traj.size:
        log.write("/scene", at(t_first), scene_update(plan, geo, at(t_first)))
    if spatial:  # the robot the 3-D panel draws (layout.json), from the log itself
        log.write(ROBOT_DESCRIPTION, at(t_first), {"data": system.spatial.text})
        log.write("/scene", at(t_first), spatial_scene(plan, traj.q, at(t_first)))
    legs_doc = result_doc.get("legs", [])
    limits = result_doc.get("constraints") or {}
    all_jumps = [
        abs(v)
        for sw in result_doc.get("switches", [])
        for v in sw["jump"].values()
        if v is not None
    ]
    # the outcome at the run's start, so that Foxglove's status strip (`Indicator!status`)
    # shows it all along: at the end, a failed plan looked like any other until its last
    # instant
    log.write(
        "/summary",
        max(log.last, at(t_first)),
        _present(
            {
                **{key: result_doc.get(key) for key in _SUMMARY_KEYS},
                "scenario": result_doc.get("scenario", scenario_name),
                "legs": len(plan.legs),
                "switches": len(plan.switches),
                "max_switch_jump": max(all_jumps, default=0.0),
                "start": _named_values(states, result_doc["start"]),
                "goal": _named_values(states, result_doc["goal"]),
                "end": _named_values(states, result_doc["end"] or [None] * len(states)),
                "duration_set_by": limits.get("duration_set_by") or None,
                "violated": limits.get("violated") or None,
            }
        ),
    )

    leg_margins = limits.get("legs") or []
    switches = {sw["after_leg"]: sw for sw in result_doc.get("switches", [])}
    for k, leg in enumerate(plan.legs):
        doc = legs_doc[k]
        pieces = doc.get("pieces") or []  # (a Lie leg: one a step)
        first = pieces[0]["coefficients"] if pieces else {}
        log.write(
            "/legs",
            at(leg.t0),
            _present(
                {
                    "kind": "leg",
                    "leg": k,
                    **{key: doc[key] for key in _LEG_KEYS if key in doc},
                    "start": _named_values(states, doc["start"]),
                    "goal": _named_values(states, doc["goal"]),
                    "end": _named_values(states, doc["end"]),
                    "coefficients": first,
                    "pieces": pieces,  # (result.json's: t0, duration, basis, coefficients)
                    "margins": leg_margins[k] if k < len(leg_margins) else None,
                }
            ),
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
            if kinds:
                log.write(MARGINS, ns, margin_message(head, kinds, margins[i]))
            if manipulator:
                log.write("/tf", ns, frame_transforms(geo, frames, i, ns))
            elif spatial and (tf := spatial_transforms(plan, traj.q[i], ns)) is not None:
                log.write("/tf", ns, tf)
        if leg.index in switches:
            sw = switches[leg.index]
            jumps = [abs(v) for v in sw["jump"].values() if v is not None]  # null: no controls
            log.write(
                "/legs",
                at(max(sw["time"], float(traj.t[s.stop - 1]))),
                _present(
                    {
                        "kind": "switch",
                        "time": sw["time"],
                        "after_leg": sw["after_leg"],
                        "jump": sw["jump"],
                        "jump_derivative": sw["jump_derivative"],
                        "max_jump": max(jumps, default=None),  # (left out: none measured)
                    }
                ),
            )

    def finish(manifest: dict[str, Any] | None) -> bytes:
        writer.add_metadata(
            "manifest",
            {
                str(k): v if isinstance(v, str) else _json(v).decode("utf-8")
                for k, v in (manifest or {}).items()
            },
        )
        writer.finish()
        return buf.getvalue()

    return finish


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
    "strategy",
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
    "objective",
    "time_scale",
)
