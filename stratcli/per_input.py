"""Rate and acceleration limits of a [constraints] table, resolved per input (no I/O): one
number for every input, a list of one per input, or a table by name, an input's or the joint
it drives, where the inputs not named have no limit."""

from __future__ import annotations

from difflib import get_close_matches

import numpy as np

from .errors import Problem

__all__ = ["per_input"]


def per_input(value, system, path: str, problems: list[Problem]) -> np.ndarray | None:
    """Per input: one number for all, one per input, or by name (an input's or the joint it
    drives: `{ elbow = 1.0 }`, the others unlimited)."""
    if value is None:
        return None
    count = system.m
    if isinstance(value, dict):
        return _by_name(value, system, path, problems)
    values = [value] * count if isinstance(value, float | int) else list(value)
    if len(values) != count:
        problems.append(Problem(path, f"give one number or {count} (one per input)"))
        return None
    return np.asarray(values, dtype=float)


def _by_name(value: dict, system, path: str, problems: list[Problem]) -> np.ndarray | None:
    """`per_input`'s table by name: an input (`u2`) or, on a robot, the joint it drives (input i
    drives joint i: `q2`, a URDF's `elbow`); inputs not named have no limit."""
    inputs = list(system.inputs)
    driven = _driven_joints(system)
    out = np.full(len(inputs), np.inf)
    if not value:
        problems.append(Problem(path, "empty: name at least one input or joint"))
        return None
    named: dict[int, str] = {}  # input index: the key that named it
    for name, limit in value.items():
        k = inputs.index(name) if name in inputs else driven.index(name) if name in driven else -1
        if k >= 0 and k in named:  # `{ q2 = 0.5, u2 = 1 }`: the last one won, silently
            problems.append(
                Problem(
                    path,
                    f"{named[k]} and {name} name the same input ({inputs[k]}): give one limit",
                )
            )
        elif k >= 0:
            named[k] = name
            out[k] = limit
        else:
            names = ", ".join(driven + inputs)
            near = get_close_matches(name, driven + inputs, n=1)
            meant = f"did you mean {near[0]!r}? " if near else ""
            problems.append(Problem(f"{path}.{name}", f"not an input or joint ({meant}{names})"))
    return out


def _driven_joints(system) -> list[str]:
    """The joint input i drives, by input, on a planar or URDF robot; none on a custom model
    (its inputs drive whatever its fields say)."""
    if getattr(system, "spatial", None) is not None:
        return list(system.spatial.joint_names)
    robot = getattr(system, "robot", None)
    return list(system.states[: robot.n_joints]) if robot is not None else []
