"""`/tf` of a spatial (URDF) plan: world → base → links, frames named after the URDF links.

Foxglove's 3-D panel draws a URDF itself and moves its links from `FrameTransforms` whose
`child_frame_id`s are the link names, the URDF's text being the one message of
`/robot_description`; the URDF is also attached, under the name of the record's copy. Each sample's
configuration is the re-integrated `(q, log R)`; the base sits at `−R c(q)` (the system CoM
is the world origin). Link poses come from Pinocchio's forward kinematics. A URDF made for
planning has no `<visual>` for Foxglove to draw: the `/scene` that draws the robot on these
frames (base box, link cylinders, tip paths) is built by `mcap_spatial_scene`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import so3

__all__ = ["is_spatial", "spatial_transforms", "urdf_attachment"]


def is_spatial(plan) -> bool:
    """Whether the plan's model is a URDF robot."""
    return getattr(plan.system, "spatial", None) is not None


def _vec(p: np.ndarray) -> dict[str, float]:
    return {"x": float(p[0]), "y": float(p[1]), "z": float(p[2])}


def spatial_transforms(plan, q: np.ndarray, ns: int) -> dict[str, Any] | None:
    """The `FrameTransforms` message of configuration `q` (None if it is not finite)."""
    if not np.all(np.isfinite(q)):
        return None
    robot = plan.system.spatial
    k = robot.n_joints
    poses = robot.link_poses(q[:k], so3.exp(q[k:]))
    parents = {j.child: j.parent for j in robot.summary.joints}
    stamp = {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}
    frames = []
    for name, (p, R) in poses.items():
        parent = parents.get(name, "world") if name != robot.base else "world"
        if parent != "world" and parent in poses:
            pp, Rp = poses[parent]
            p, R = Rp.T @ (p - pp), Rp.T @ R
        elif parent != "world":
            parent = "world"
        frames.append((parent, name, p, R))
    # every link's quaternion in one call (a call per link: a quarter of /tf's time)
    quaternions = so3.quaternion_from_matrix(np.array([R for *_, R in frames])).tolist()
    out = [
        {
            "timestamp": stamp,
            "parent_frame_id": parent,
            "child_frame_id": name,
            "translation": _vec(p),
            "rotation": {"x": x, "y": y, "z": z, "w": w},
        }
        for (parent, name, p, _), (w, x, y, z) in zip(frames, quaternions, strict=True)
    ]
    return {"transforms": out}


def urdf_attachment(plan, manifest: dict | None = None) -> tuple[str, bytes]:
    """(file name, bytes) of the robot's URDF: named as the record's copy of it
    (`manifest["urdf"]["file"]`, `model_files`), else after the robot."""
    robot = plan.system.spatial
    name = ((manifest or {}).get("urdf") or {}).get("file") or f"{robot.summary.name}.urdf"
    return name, robot.text.encode("utf-8")
