"""`run.mcap`'s `/margins`: the room left to each limit of a plan's [constraints], sample by
sample (no I/O), so that Foxglove plots the closest approaches against time beside the motion.

One message a sample of the log's `Trajectory` (`t`, `leg`, `stratum` as on `/state`), with
the smallest room at that instant to each kind of limit the constraints ask for, by
result.json's margin names: `joint_limit` (rad, over the limited coordinates), `rate`
(rad/s) and `acceleration` (rad/s², over the inputs), `self_clearance` and
`obstacle_clearance` (surface distance less the clearance, the model's length unit); negative
where a limit is broken (`constraints.rooms`). result.json's per-leg margins come from a denser
re-integration (2000 samples a leg, at other instants), so a leg's smallest value here is near
that margin, above or below it by what the curve does between the two sets of samples.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..constraints import MARGIN_KINDS, margin_kinds, resolved_constraints, rooms
from ..sequence import SequencePlan
from .trajectory import Trajectory

__all__ = [
    "MARGINS",
    "MARGINS_SCHEMA",
    "logged_kinds",
    "margin_message",
    "margin_rows",
]

MARGINS = "/margins"
_DESCRIBED = {  # result.json's margin names (`MARGIN_KINDS`), with their descriptions
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
        **{key: {"type": "number", "description": _DESCRIBED[key]} for key in MARGIN_KINDS},
    },
}


def logged_kinds(plan: SequencePlan, traj: Trajectory) -> tuple[str, ...]:
    """The fields of the log's `/margins` (none: a plan without [constraints] or samples)."""
    if plan.constraints is None or not traj.size:
        return ()
    return margin_kinds(plan.system, resolved_constraints(plan))


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
