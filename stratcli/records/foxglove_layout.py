"""`layout.json`: a Foxglove layout that opens `run.mcap` arranged (no I/O).

A layout is the JSON that Foxglove's "Import from file…" of the layout menu reads (the format
of an exported layout): `configById` maps panel ids (`"Plot!controls"`: panel type, `!`, a
name unique in the layout) to their settings, and `layout` is the tree of splits that places
them (`{"direction", "first", "second", "splitPercentage"}`; a leaf is a panel id). The panels:

| panel | id | shows |
|---|---|---|
| 3-D | `3D!motion` | `/tf` and `/scene` from above, following `world` (or `base`) |
| Plot | `Plot!controls` | `/controls.u.<input>` for every input |
| Plot | `Plot!configuration` | `/state.q.<coordinate>` for every coordinate |
| Plot | `Plot!margins` | plans with [constraints]: `/margins.<kind>`, the room to each limit |
| State Transitions | `StateTransitions!stratum` | `/state.stratum` and `/state.leg` |
| Indicator | `Indicator!status` | `/summary.status`: ok (green) or FAILED (red), all along |

A URDF robot's 3-D panel draws the robot from `run.mcap`'s `/robot_description` topic (the
URDF's text, a `std_msgs/String`-shaped `{"data": ...}` message that Foxglove's 3-D panel draws by
itself) and its `/scene` (primitives on the link frames, for the links without `<visual>`s
Foxglove draws: `mcap_spatial_scene`), in perspective: no path outside the record, which may be
moved or shared.
The 3-D panel is left out when the log has no `/tf` (a model without a robot drawing). Message
paths are `topic.field.field` in the field names of `mcap_schemas`; every time axis is the log
time, so the plots and the 3-D view move together with Foxglove's playback bar. Built as plain
JSON: `foxglove-sdk`'s `foxglove.layouts` writes a different document (`{"version": 1,
"content": ...}`) and would bring a 50 MB native dependency for four dictionaries.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np

from ..sequence import SequencePlan
from .mcap_margins import logged_kinds
from .trajectory import Trajectory, world_geometry

__all__ = [
    "LAYOUT_PANELS",
    "ROBOT_DESCRIPTION",
    "foxglove_layout",
    "message_paths",
    "run_layout",
    "shows_robot",
]

STATUS, THREE_D, CONTROLS, CONFIGURATION, MARGINS, STRATUM = (
    "Indicator!status",
    "3D!motion",
    "Plot!controls",
    "Plot!configuration",
    "Plot!margins",
    "StateTransitions!stratum",
)
LAYOUT_PANELS = (STATUS, THREE_D, CONTROLS, CONFIGURATION, MARGINS, STRATUM)
# The status strip: `/summary.status` (logged at the run's start, so it shows all along): a
# failed plan looked like any other in Foxglove, its status only in the last message
_STATUS_PANEL = {
    "foxglovePanelTitle": "Status (/summary: message, energy, violated limit)",
    "path": "/summary.status",
    "style": "background",
    "fallbackColor": "#a0a0a0",
    "fallbackLabel": "no status",
    "rules": [
        {"operator": "=", "rawValue": "ok", "color": "#2e8b57", "label": "plan ok"},
        {
            "operator": "=",
            "rawValue": "failed",
            "color": "#c0392b",
            "label": "plan FAILED (/summary.message says why)",
        },
    ],
}


def shows_robot(plan: SequencePlan, traj: Trajectory) -> bool:
    """Whether a planar plan's `run.mcap` has the `/tf` and `/scene` channels of
    `mcap_scene` (and the layout a 3-D panel); URDF plans have their own (`run_layout`).

    Parameters
    ----------
    plan : the planned sequence; `traj` : its samples.

    Returns
    -------
    bool
        True for a planar manipulator (coordinates: joints, then θ) with at least one sample.
    """
    system = plan.system
    return system.robot is not None and system.n == system.robot.n_joints + 1 and traj.size > 0


def _series(path: str, label: str) -> dict[str, Any]:
    return {"value": path, "label": label, "enabled": True, "timestampMethod": "receiveTime"}


def _plot(title: str, series: list[dict[str, Any]]) -> dict[str, Any]:
    return {
        "foxglovePanelTitle": title,
        "paths": series,
        "xAxisVal": "timestamp",
        "showXAxisLabels": True,
        "showYAxisLabels": True,
        "showLegend": True,
        "legendDisplay": "floating",
        "showPlotValuesInLegend": True,
        "isSynced": True,
        "sidebarDimension": 240,
    }


ROBOT_DESCRIPTION = "/robot_description"  # a URDF robot's URDF text, in run.mcap


def _three_d(follow: Literal["world", "base"], distance: float, urdf: bool = False) -> dict:
    panel = _three_d_panel(follow, distance)
    if urdf:  # a URDF robot: Foxglove draws it from the log, moved by /tf (frames = its links)
        panel["cameraState"].update(perspective=True, phi=60, thetaOffset=45)
        panel["topics"][ROBOT_DESCRIPTION] = {"visible": True}
    return panel


def _three_d_panel(follow: Literal["world", "base"], distance: float) -> dict[str, Any]:
    return {
        "foxglovePanelTitle": "Motion (world frame at the system CM)",
        "followTf": follow,
        # following the base: its position only, so the view does not spin with the base
        "followMode": "follow-pose" if follow == "world" else "follow-position",
        "cameraState": {
            "perspective": False,  # a planar robot, seen from above (+z)
            "distance": distance,
            "phi": 0,
            "thetaOffset": 0,
            "target": [0, 0, 0],
            "targetOffset": [0, 0, 0],
            "targetOrientation": [0, 0, 0, 1],
            "fovy": 45,
            "near": 0.01,
            "far": 5000,
        },
        "scene": {"transforms": {"showLabel": True, "axisScale": distance / 20}},
        "transforms": {},
        "topics": {"/tf": {"visible": True}, "/scene": {"visible": True}},
        "layers": {
            "grid": {
                "visible": True,
                "label": "Grid",
                "instanceId": "grid",
                "layerId": "foxglove.Grid",
                "frameId": "world",
                "size": round(2 * distance, 3),
                "divisions": 10,
                "order": 1,
            }
        },
    }


def _split(
    direction: Literal["row", "column"], first: Any, second: Any, percent: float
) -> dict[str, Any]:
    return {"direction": direction, "first": first, "second": second, "splitPercentage": percent}


def foxglove_layout(
    states: tuple[str, ...],
    inputs: tuple[str, ...],
    robot: bool,
    follow: Literal["world", "base"] = "world",
    distance: float = 5.0,
    urdf: bool = False,
    margins: tuple[str, ...] = (),
) -> dict[str, Any]:
    """The Foxglove layout of a run (a JSON-ready dict).

    Parameters
    ----------
    states, inputs : names of the model's coordinates and inputs (the fields of `/state.q`
        and `/controls.u`).
    robot : whether the log has `/tf` and `/scene` (`shows_robot`); without, no 3-D panel.
    follow : the frame the 3-D view follows: `"world"` (fixed view) or `"base"` (its position).
    distance : the 3-D camera's distance (zoom), in the model's length unit.
    urdf : a URDF robot: the 3-D panel draws it from the log's `/robot_description` topic
        (perspective view).
    margins : the fields of the log's `/margins` (`constraints.margin_kinds`); none: no
        margins panel.

    Returns
    -------
    dict
        `configById`, `globalVariables`, `userNodes`, `linkedGlobalVariables`,
        `playbackConfig` and the split tree `layout`.
    """
    config: dict[str, Any] = {
        CONTROLS: _plot("Controls u", [_series(f"/controls.u.{u}", u) for u in inputs]),
        CONFIGURATION: _plot("Configuration q", [_series(f"/state.q.{q}", q) for q in states]),
        STRATUM: {
            "foxglovePanelTitle": "Stratum and leg",
            "paths": [
                {"value": "/state.stratum", "label": "stratum", "timestampMethod": "receiveTime"},
                {
                    "value": "/state.leg",
                    "label": "leg, from 0 (the figures' leg 1 is 0)",
                    "timestampMethod": "receiveTime",
                },
            ],
            "isSynced": True,
        },
    }
    lower: Any = STRATUM
    if margins:
        title = "Margins to the limits (< 0: broken)"
        config[MARGINS] = _plot(title, [_series(f"/margins.{k}", k) for k in margins])
        lower = _split("column", MARGINS, STRATUM, 70)
    charts = _split(
        "column", CONTROLS, _split("column", CONFIGURATION, lower, 55 if margins else 70), 38
    )
    tree: Any = charts
    if robot:
        config[THREE_D] = _three_d(follow, distance, urdf)
        tree = _split("row", THREE_D, charts, 55)
    config[STATUS] = dict(_STATUS_PANEL)
    tree = _split("column", STATUS, tree, 6)
    return {
        "configById": config,
        "globalVariables": {},
        "userNodes": {},
        "linkedGlobalVariables": [],
        "playbackConfig": {"speed": 1.0},
        "layout": tree,
    }


def run_layout(
    plan: SequencePlan, traj: Trajectory, follow: Literal["world", "base"] = "world"
) -> dict[str, Any]:
    """`foxglove_layout` of a planned run; the 3-D camera frames the robot's first pose.

    Parameters
    ----------
    plan : the planned sequence; `traj` : its samples, as written to `run.mcap`.
    follow : the frame the 3-D view follows (`"world"` or `"base"`).

    Returns
    -------
    dict
        The layout, written as `layout.json` and attached to `run.mcap`.
    """
    system = plan.system
    robot = shows_robot(plan, traj)
    margins = logged_kinds(plan, traj)
    if getattr(system, "spatial", None) is not None and traj.size:  # a URDF robot
        from .spatial_figures import reach

        distance = round(4.0 * max(reach(plan, traj.q[0]), 0.25), 3)
        states, inputs = tuple(system.states), tuple(system.inputs)
        return foxglove_layout(states, inputs, True, follow, distance, True, margins)
    distance = 5.0
    if robot:
        geo = world_geometry(system.robot, traj.q[:1])
        points = np.concatenate([geo["base_corners"][0], geo["distal"][0], geo["proximal"][0]])
        reach = float(np.nanmax(np.abs(points))) if np.isfinite(points).any() else math.nan
        if math.isfinite(reach) and reach > 0:
            distance = round(4.0 * reach, 3)
    states, inputs = tuple(system.states), tuple(system.inputs)
    return foxglove_layout(states, inputs, robot, follow, distance, margins=margins)


def message_paths(layout: dict[str, Any]) -> dict[str, list[str]]:
    """The message paths (`/topic.field...`) and topics each panel of `layout` names.

    Parameters
    ----------
    layout : a layout of `foxglove_layout`.

    Returns
    -------
    dict
        Panel id → its plotted paths, then the topics of its `topics` setting (3-D panel).
    """
    out: dict[str, list[str]] = {}
    for panel, config in layout["configById"].items():
        paths = [p["value"] for p in config.get("paths", [])]
        paths += [config["path"]] if "path" in config else []  # (an indicator's one)
        out[panel] = paths + list(config.get("topics", {}))
    return out
