"""`/scene` of a spatial (URDF) plan: the robot as primitives on its link frames (no I/O).

The URDFs a planner needs carry masses and inertias only (the shipped ones have no `<visual>`),
so Foxglove's drawing of `/robot_description` shows bare frames. `spatial_scene` is the one
`foxglove.SceneUpdate` that draws a robot anyway, like the planar one (`mcap_scene`): every
entity but the paths is attached to a link frame of `/tf` (`frame_id` = the URDF link's name,
`frame_locked`, a zero `lifetime`: it lives for the whole log), so `/tf` moves it.

| entity `id` | `frame_id` | primitives |
|---|---|---|
| the base link's name | base link | a box, and a cylinder to each child joint's origin |
| another link's name | that link | a sphere at its joint, a cylinder to each child joint's origin |
| `path/<leaf>` | `world` | the line of a leaf link's tip over the samples (not frame-locked) |

A link's cylinders run from its frame's origin to its child joints' origins, which Pinocchio
parsed from the URDF's joint `<origin>`s (the child's origin in the parent's frame does not
depend on the revolute joint's angle). A leaf link has no child joint: its cylinder runs to
twice its centre of mass (the URDF's `<inertial><origin>`), the far end of a uniform rod
hinged at the joint, and that end is its tip, whose path is drawn (a leaf without an offset
centre of mass, a tool frame, is its own tip; a leaf fixed to the base, a camera on the bus,
has none). Cylinders are 6 % of the longest segment or
base edge thick, as the planar links are.

The base is the box of the base body's mass and principal moments of inertia
(`SpatialRobot.base_box`: a uniform box of mass m and edges a, b, c has I = m(b² + c²)/12
about its a axis), centred at its centre of mass along its principal axes: the same box as
`stroboscope.png`'s, sized by the only shape data a planning URDF is sure to hold. The
extents of the links would say nothing of the base (a bus is much wider than the joint it
carries); an edge is at least the cylinders' thickness, so a point-mass base still shows.

A link whose `<visual>`s are all boxes, cylinders or spheres is left to Foxglove's rendering of
the URDF (it needs no file), so it is not drawn twice; a link with a `<mesh>` is drawn here
too, as a mesh's `package://` or file path is not in the record that may be moved.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import Any

import numpy as np

from .. import so3

__all__ = ["PRIMITIVE_VISUALS", "link_segments", "spatial_scene", "visual_links"]

PRIMITIVE_VISUALS = ("box", "cylinder", "sphere")  # URDF geometries Foxglove draws without files
LINE_STRIP = 0  # foxglove.LineType
THICKNESS = 0.06  # the cylinders' diameter over the scene's largest segment or base edge

_BASE, _LINK, _JOINT, _PATH = (
    {"r": 0.60, "g": 0.65, "b": 0.70, "a": 0.9},
    {"r": 0.10, "g": 0.22, "b": 0.50, "a": 1.0},
    {"r": 0.83, "g": 0.33, "b": 0.0, "a": 1.0},
    {"r": 0.83, "g": 0.33, "b": 0.0, "a": 0.8},
)


def _vec3(p) -> dict[str, float]:
    return {"x": float(p[0]), "y": float(p[1]), "z": float(p[2])}


def _quat(R: np.ndarray) -> dict[str, float]:
    w, x, y, z = so3.quaternion_from_matrix(R).tolist()
    return {"x": x, "y": y, "z": z, "w": w}


_ORIGIN = {"position": _vec3((0, 0, 0)), "orientation": _quat(np.eye(3))}


def _z_onto(d: np.ndarray) -> dict[str, float]:
    """The shortest rotation taking +z onto the unit vector `d`, as a quaternion."""
    w, x, y = 1.0 + d[2], 0.0 - d[1], d[0] + 0.0  # (no -0.0)
    if w < 1e-12:  # d = -z: a half turn about x
        return {"x": 1.0, "y": 0.0, "z": 0.0, "w": 0.0}
    n = float(np.sqrt(w * w + x * x + y * y))
    return {"x": float(x / n), "y": float(y / n), "z": 0.0, "w": float(w / n)}


def visual_links(text: str) -> tuple[frozenset[str], dict[str, np.ndarray]]:
    """What the URDF says of each link's drawing: the links whose `<visual>`s are all
    `PRIMITIVE_VISUALS` (Foxglove draws them from the URDF) and each link's centre of mass
    in its frame (`<inertial><origin xyz>`, absent links: none given).

    Parameters
    ----------
    text : the URDF's text (already validated by `models.urdf.read_urdf`).

    Returns
    -------
    tuple
        (names of the links Foxglove draws, {link name: centre of mass (3,)}).
    """
    drawn, coms = set(), {}
    for link in ET.fromstring(text).findall("link"):
        name = link.get("name", "")
        shapes = [g[0].tag for g in link.findall("visual/geometry") if len(g)]
        if shapes and all(tag in PRIMITIVE_VISUALS for tag in shapes):
            drawn.add(name)
        origin = link.find("inertial/origin")
        try:
            xyz = np.array((origin.get("xyz") or "0 0 0").split(), dtype=float)
        except (AttributeError, ValueError):  # no <origin>, or not numbers: none given
            continue
        if xyz.shape == (3,) and np.all(np.isfinite(xyz)):
            coms[name] = xyz
    return frozenset(drawn), coms


def link_segments(robot, coms: dict[str, np.ndarray] | None = None) -> dict[str, list[np.ndarray]]:
    """The far end, in each link's frame, of every segment drawn from the link's origin.

    Parameters
    ----------
    robot : a `models.spatial.SpatialRobot`.
    coms : its links' centres of mass (`visual_links`); default: read from its URDF.

    Returns
    -------
    dict
        {link name: [end (3,), ...]} for every link of `link_poses`, in Pinocchio's order: its
        child joints' origins, and for a leaf link twice its centre of mass (none if that is
        the origin). Zero-length segments (a child joint at the link's origin) are left out.
    """
    k = robot.n_joints
    poses = robot.link_poses(np.zeros(k), np.eye(3))  # any configuration: offsets are fixed
    parents = {j.child: j.parent for j in robot.summary.joints}
    coms = visual_links(robot.text)[1] if coms is None else coms
    ends: dict[str, list[np.ndarray]] = {name: [] for name in poses}
    for name, (p, _) in poses.items():
        parent = parents.get(name)
        if name != robot.base and parent in poses:
            pp, Rp = poses[parent]
            ends[parent].append(Rp.T @ (p - pp))
    for name, out in ends.items():
        if not out and name != robot.base:
            out.append(2.0 * coms.get(name, np.zeros(3)))
        ends[name] = [e for e in out if np.linalg.norm(e) > 1e-9]
    return ends


def _tips(robot, ends: dict[str, list[np.ndarray]]) -> dict[str, np.ndarray]:
    """Each leaf link's tip in its frame: its one segment's end, else its origin; not of a
    leaf fixed to the base (a camera on the bus: its path would only trace the base's)."""
    children = {j.parent for j in robot.summary.joints}
    joint_to = {j.child: j for j in robot.summary.joints}

    def moves(name: str) -> bool:  # a revolute joint between it and the base
        joint = joint_to.get(name)
        return joint is not None and (joint.type == "revolute" or moves(joint.parent))

    return {
        name: (segments[0] if segments else np.zeros(3))
        for name, segments in ends.items()
        if name not in children and name != robot.base and moves(name)
    }


def _paths(robot, q: np.ndarray, tips: dict[str, np.ndarray]) -> dict[str, list[dict]]:
    """World points of every leaf's tip at the finite samples `q` (K, n)."""
    k = robot.n_joints
    out: dict[str, list[dict]] = {name: [] for name in tips}
    for qi in q:
        if not np.all(np.isfinite(qi)):
            continue
        poses = robot.link_poses(qi[:k], so3.exp(qi[k:]))
        for name, tip in tips.items():
            p, R = poses[name]
            out[name].append(_vec3(p + R @ tip))
    return out


def spatial_scene(plan, q: np.ndarray, ns: int) -> dict[str, Any]:
    """The `foxglove.SceneUpdate` that draws a URDF robot on its `/tf` frames.

    Parameters
    ----------
    plan : a plan of a URDF robot (`plan.system.spatial`).
    q : the samples' configurations (K, n): joints, then the attitude's rotation vector; the
        end-effector paths go through the finite ones.
    ns : the message's log time (ns), the entities' timestamp.

    Returns
    -------
    dict
        `{"deletions": [], "entities": [...]}`, the entities of the module's table.
    """
    robot = plan.system.spatial
    foxglove_draws, coms = visual_links(robot.text)  # (the URDF parsed once)
    ends = link_segments(robot, coms)
    centre, axes, edges = robot.base_box()
    lengths = [float(np.linalg.norm(e)) for out in ends.values() for e in out]
    width = THICKNESS * max([*lengths, *edges.tolist(), 1e-3])
    if np.linalg.det(axes) < 0:  # eigenvectors: make them a rotation
        axes = axes * np.array([1.0, 1.0, -1.0])
    stamp = {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}
    zero = {"sec": 0, "nsec": 0}

    def entity(frame: str, name: str, locked: bool = True, **primitives) -> dict:
        return {"timestamp": stamp, "frame_id": frame, "id": name, "lifetime": zero,
                "frame_locked": locked, "metadata": [], **primitives}  # fmt: skip

    def cylinder(end: np.ndarray) -> dict:
        length = float(np.linalg.norm(end))
        pose = {"position": _vec3(end / 2), "orientation": _z_onto(end / length)}
        return {"pose": pose, "size": _vec3((width, width, length)), "bottom_scale": 1.0,
                "top_scale": 1.0, "color": _LINK}  # fmt: skip

    entities = []
    for name, segments in ends.items():
        if name in foxglove_draws:
            continue
        shapes: dict[str, list[dict]] = {"cylinders": [cylinder(e) for e in segments]}
        if name == robot.base:
            pose = {"position": _vec3(centre), "orientation": _quat(axes)}
            size = _vec3(np.maximum(edges, width))
            shapes["cubes"] = [{"pose": pose, "size": size, "color": _BASE}]
        else:
            ball = _vec3((1.6 * width,) * 3)
            shapes["spheres"] = [{"pose": _ORIGIN, "size": ball, "color": _JOINT}]
        entities.append(entity(name, name, **shapes))
    for name, points in _paths(robot, q, _tips(robot, ends)).items():
        line = {"type": LINE_STRIP, "pose": _ORIGIN, "thickness": 2.0, "scale_invariant": True,
                "points": points, "color": _PATH, "indices": []}  # fmt: skip
        entities.append(entity("world", f"path/{name}", locked=False, lines=[line]))
    return {"deletions": [], "entities": entities}
