"""Angles that look like degrees written as plain numbers (no I/O).

Joint limits, joint angles and a planar base's θ are radians, and angles written as strings
may carry their unit (`"150deg"`). A limit of 150 is then 150 rad, some 24 turns: a revolute
joint's hardware stop is rarely past a full turn either way, so such a limit is most likely
degrees, in the [constraints] table or in the URDF; a joint goal of 45 (7 turns) likewise.
They stay what was written (multi-turn joints exist); `degree_like_limits` and
`degree_like_configurations` word the warnings.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["angle_coordinates", "degree_like_configurations", "degree_like_limits"]

FULL_TURN = 2.0 * math.pi


def angle_coordinates(system: Any) -> int:
    """How many leading coordinates are angles: every one of a planar robot (joints, θ), a
    URDF robot's joints (its attitude is a rotation vector, noted elsewhere), none of a
    custom model's (they may be lengths)."""
    if getattr(system, "spatial", None) is not None:
        return system.spatial.n_joints
    return len(system.states) if getattr(system, "robot", None) is not None else 0


def degree_like_limits(constraints: Any, system: Any) -> list[str]:
    """One sentence per distinct pair of joint limits with a bound past a full turn, on a
    model whose coordinates are angles (planar and URDF robots): the [constraints] table's,
    and a URDF robot's own (enforced under [constraints], noted without); none without such
    limits."""
    pairs: dict[tuple[float, float], list[str]] = {}
    urdf: dict[tuple[float, float], list[str]] = {}
    if constraints is not None and angle_coordinates(system):
        for j, (lo, hi) in enumerate(zip(constraints.lower, constraints.upper, strict=True)):
            if j not in constraints.from_urdf and _past_a_turn(lo, hi):
                pairs.setdefault((float(lo), float(hi)), []).append(system.states[j])
    if (robot := getattr(system, "spatial", None)) is not None:
        for j in range(robot.n_joints):
            lo, hi = robot.lower[j], robot.upper[j]
            overridden = constraints is not None and j not in constraints.from_urdf
            if not overridden and _past_a_turn(lo, hi):
                urdf.setdefault((float(lo), float(hi)), []).append(system.states[j])
    out = [
        f"constraints.joint_limits: {', '.join(names)} within [{lo:g}, {hi:g}] rad, "
        f"{(hi - lo) / FULL_TURN:.3g} turns; if degrees were meant, write "
        f'["{lo:g}deg", "{hi:g}deg"]'
        for (lo, hi), names in pairs.items()
    ]
    out += [
        f"model.path: the URDF limits {', '.join(names)} to [{lo:g}, {hi:g}] rad, "
        f"{(hi - lo) / FULL_TURN:.3g} turns; a URDF's angles are radians: if degrees were "
        f"meant, convert them in the URDF (or set constraints.joint_limits)"
        for (lo, hi), names in urdf.items()
    ]
    return out


def _past_a_turn(lo: float, hi: float) -> bool:
    finite = math.isfinite(lo) and math.isfinite(hi)
    return finite and max(abs(lo), abs(hi)) > FULL_TURN


def degree_like_configurations(task: Any) -> list[str]:
    """One sentence per start, via or goal with an angle past a full turn (a joint's, a
    planar base's θ) on a planar or URDF robot: 45 for a joint is 7 turns, most likely 45°."""
    k = angle_coordinates(task.system)
    places = [("task.start", task.start)]
    places += [(f"legs[{i}].goal", leg.goal) for i, leg in enumerate(task.legs[:-1])]
    places += [("task.goal", task.goal)]
    out = []
    for where, q in places:
        values = np.asarray(q, dtype=float)[:k]
        far = [j for j, v in enumerate(values) if math.isfinite(v) and abs(v) > FULL_TURN]
        if not far:
            continue
        given = ", ".join(f"{task.system.states[j]} {values[j]:g}" for j in far)
        written = ", ".join(f'"{values[j]:g}deg"' for j in far)
        turns = "a full turn" if len(far) == 1 else "full turns"
        out.append(f"{where}: {given} rad, past {turns}; if degrees were meant, write {written}")
    return out
