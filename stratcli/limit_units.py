"""Joint limits that look like degrees written as plain numbers (no I/O).

`[constraints] joint_limits` are radians, and angles written as strings may carry their unit
(`"150deg"`). A limit of 150 is then 150 rad, some 24 turns: a revolute joint's hardware stop
is rarely past a full turn either way, so such a limit is most likely degrees. It stays what
was written (a multi-turn joint is possible); `degree_like_limits` words the warning.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["degree_like_limits"]

FULL_TURN = 2.0 * math.pi


def degree_like_limits(constraints: Any, system: Any) -> list[str]:
    """One sentence per distinct pair of joint limits from the [constraints] table with a
    bound past a full turn, on a model whose coordinates are angles (planar and URDF robots;
    a custom model's coordinates may be lengths); none without such limits."""
    if constraints is None:
        return []
    if getattr(system, "robot", None) is None and getattr(system, "spatial", None) is None:
        return []
    pairs: dict[tuple[float, float], list[str]] = {}
    for j, (lo, hi) in enumerate(zip(constraints.lower, constraints.upper, strict=True)):
        if j in constraints.from_urdf or not (math.isfinite(lo) and math.isfinite(hi)):
            continue
        if max(abs(lo), abs(hi)) > FULL_TURN:
            pairs.setdefault((float(lo), float(hi)), []).append(system.states[j])
    return [
        f"constraints.joint_limits: {', '.join(names)} within [{lo:g}, {hi:g}] rad, "
        f"{(hi - lo) / FULL_TURN:.3g} turns; if degrees were meant, write "
        f'["{lo:g}deg", "{hi:g}deg"]'
        for (lo, hi), names in pairs.items()
    ]
