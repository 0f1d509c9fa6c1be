"""`run.mcap`'s `/margins`: the room left to each limit of a plan's [constraints], sample by
sample (no I/O), so that Foxglove plots the closest approaches against time beside the motion.

One message a sample of the log's `Trajectory` (`t`, `leg`, `stratum` as on `/state`), with
the smallest room at that instant to each kind of limit the constraints ask for, by
result.json's margin names: `joint_limit` (rad, over the limited coordinates), `rate`
(rad/s) and `acceleration` (rad/s², over the inputs), `self_clearance` and
`obstacle_clearance` (surface distance less the clearance, the model's length unit); negative
where a limit is broken (`constraints.rooms`). result.json's per-leg margins come from a denser
re-integration (2000 samples a leg), so a leg's smallest value here is at least that margin.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..constraints import Constraints, resolved_constraints, rooms
from ..sequence import SequencePlan
from .trajectory import Trajectory

__all__ = [
    "MARGINS",
    "MARGINS_SCHEMA",
    "logged_kinds",
    "margin_kinds",
    "margin_message",
    "margin_rows",
]

MARGINS = "/margins"
_KINDS = {  # result.json's margin names, with their descriptions and units
    "joint_limit": "room to the nearest joint limit [rad]",
    "rate": "room to the nearest rate limit [rad/s]",
    "acceleration": "room to the nearest acceleration limit [rad/s²]",
    "self_clearance": "smallest distance between the robot's own bodies less the clearance",
    "obstacle_clearance": "smallest distance from the robot to an obstacle less the clearance",
}
MARGINS_SCHEMA = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "stratplan.Margins",
    "description": "room left to each limit of [constraints] at one instant (< 0: broken)",
    "type": "object",
    "properties": {
        "t": {"type": "number", "description": "time [s] on the motion's axis"},
        "leg": {"type": "integer", "description": "leg index (0-based, as in result.json)"},
        "stratum": {"type": "string"},
        **{key: {"type": "number", "description": text} for key, text in _KINDS.items()},
    },
}


def margin_kinds(c: Constraints, system) -> tuple[str, ...]:
    """The margins `c` asks for, in `_KINDS`' order (the fields `/margins` has)."""
    asked = {
        "joint_limit": bool((np.isfinite(c.lower) | np.isfinite(c.upper)).any()),
        "rate": c.max_rate is not None,
        "acceleration": c.max_acceleration is not None,
        "self_clearance": c.geometric and c.self_collision,
        "obstacle_clearance": c.geometric and bool(c.circles or c.boxes),
    }
    robot = getattr(system, "robot", None)
    geometric = ("self_clearance", "obstacle_clearance")
    return tuple(k for k, on in asked.items() if on and (robot is not None or k not in geometric))


def logged_kinds(plan: SequencePlan, traj: Trajectory) -> tuple[str, ...]:
    """The fields of the log's `/margins` (none: a plan without [constraints] or samples)."""
    if plan.constraints is None or not traj.size:
        return ()
    return margin_kinds(resolved_constraints(plan), plan.system)


def margin_rows(plan: SequencePlan, traj: Trajectory) -> tuple[tuple[str, ...], np.ndarray]:
    """The kinds of margin (`logged_kinds`) and their values (N, kinds) at `traj`'s samples."""
    kinds = logged_kinds(plan, traj)
    if not kinds:
        return (), np.zeros((traj.size, 0))
    found = rooms(plan.system, resolved_constraints(plan), traj.q, traj.u, traj.du)
    with np.errstate(invalid="ignore"):  # (a failed plan's NaN samples stay NaN)
        return kinds, np.stack([found[k].min(axis=1) for k in kinds], axis=1)


def margin_message(head: dict[str, Any], kinds: tuple[str, ...], values: np.ndarray) -> dict:
    """One `/margins` message: `head` (t, leg, stratum) and the finite values by kind."""
    return {**head, **{k: float(v) for k, v in zip(kinds, values, strict=True) if np.isfinite(v)}}
