"""Foxglove `/tf` and `/scene` messages of a planar manipulator for `run.mcap` (no I/O).

Frames for Foxglove's 3-D panel: `world` is the inertial frame with its origin at the fixed
system CM; `base` sits at the base CM rotated by θ about z; each arm is a chain
`base → link1 → link2 ...` whose frames sit at the link's proximal joint with x along the link.
`link_frames` names those frames, `frame_transforms` is one `foxglove.FrameTransforms` message
(one sample) and `scene_update` the one `foxglove.SceneUpdate` with the geometry (base, links
in link-local coordinates, end-effector paths), which then moves with the transforms.
"""

from __future__ import annotations

import math

import numpy as np

from ..constraints import resolved_constraints
from ..sequence import SequencePlan
from .trajectory import base_extent

__all__ = ["frame_transforms", "link_frames", "scene_update"]

LINE_STRIP = 0  # foxglove.LineType


def _stamp(ns: int) -> dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _quat_z(angle: float) -> dict[str, float]:
    """Rotation by `angle` about z as a quaternion."""
    return {"x": 0.0, "y": 0.0, "z": math.sin(angle / 2), "w": math.cos(angle / 2)}


def _vec3(x: float, y: float, z: float = 0.0) -> dict[str, float]:
    return {"x": float(x), "y": float(y), "z": float(z)}


def _color(r: float, g: float, b: float, a: float = 1.0) -> dict[str, float]:
    return {"r": r, "g": g, "b": b, "a": a}


_IDENTITY = {"position": _vec3(0, 0), "orientation": _quat_z(0.0)}


def link_frames(plan: SequencePlan) -> list[tuple[str, str]]:
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


def frame_transforms(geo: dict[str, np.ndarray], frames: list[tuple[str, str]], i: int, ns: int):
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


def scene_update(plan: SequencePlan, geo: dict[str, np.ndarray], ns: int) -> dict:
    robot = plan.system.robot
    hx, hy = base_extent(robot)
    lengths = [link.length for link in robot.links]
    scale = max([*lengths, 2 * hx, 2 * hy])
    width = 0.06 * scale
    joint = 1.6 * width
    if plan.constraints is not None and (limits := resolved_constraints(plan)).geometric:
        # the capsules [constraints] measures (radius link_radius), not thinner: a link
        # 0.06 thick left a gap of 0.06 in Foxglove at a closest approach of 5e-4
        width = joint = 2.0 * limits.link_radius
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
    for j, (name, _) in enumerate(link_frames(plan)):
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
                        "size": _vec3(joint, joint, joint),
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
    entities.extend(_obstacles(plan, entity, 0.3 * min(2 * hx, 2 * hy)))
    return {"deletions": [], "entities": entities}


def _obstacles(plan: SequencePlan, entity, height: float) -> list[dict]:
    """The obstacles of [constraints] in the world frame, as tall as the base: circles as
    cylinders, boxes as cubes (turned by their rotation)."""
    spec = plan.constraints.spec if plan.constraints is not None else {}
    out = []
    color = _color(0.91, 0.30, 0.24, 0.5)
    for i, o in enumerate(spec.get("obstacles") or []):
        x, y = o["centre"]
        if o["shape"] == "circle":
            d = 2.0 * o["radius"]
            shape = {"cylinders": [{"pose": {"position": _vec3(x, y), "orientation": _quat_z(0)},
                                     "size": _vec3(d, d, height), "bottom_scale": 1.0,
                                     "top_scale": 1.0, "color": color}]}  # fmt: skip
        else:
            pose = {"position": _vec3(x, y), "orientation": _quat_z(o.get("rotation", 0.0))}
            shape = {"cubes": [{"pose": pose, "size": _vec3(*o["size"], height), "color": color}]}
        out.append(entity("world", f"obstacle{i}", locked=False, **shape))
    return out
