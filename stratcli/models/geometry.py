"""Geometry of planar manipulators in the inertial frame (no I/O).

`world_geometry` turns configurations of a planar manipulator (joints, then the base angle θ)
into inertial-frame points: base rectangle, joints and links. The inertial origin is the
fixed system CM; a base-frame point x is at `R(θ) (x − p_c)` (docs/planar_model.md §1, §6).
Records draw with it, and `constraints` measures clearances with it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .planar import PlanarManipulator, kinematics, link_geometry, structure

__all__ = ["base_extent", "world_bodies", "world_geometry"]


# --------------------------------------------------------------------------------------------
# Geometry of planar manipulators in the inertial frame
# --------------------------------------------------------------------------------------------


def base_extent(robot: PlanarManipulator) -> tuple[float, float]:
    """Half-extents (hx, hy) of the base rectangle along the base x and y axes.

    The base is `a × b` (docs/planar_model.md §2, §6) but which side lies along the base x
    axis is not part of the model. Choose the orientation that puts the arm mount points on
    the rectangle's boundary: model 1 (a = 1, b = 0.6, mount at 0.3 on x) gives (0.3, 0.5).
    Without a size, a square just reaching the farthest mount point is used.
    """
    mounts = np.array([arm.mount for arm in robot.arms], dtype=float)
    reach = float(np.max(np.abs(mounts))) if mounts.size else 0.0
    size = None
    if robot.base.a is not None and robot.base.b is not None:
        size = (robot.base.a, robot.base.b)
    if not size or min(size) <= 0:
        h = reach if reach > 0 else 0.25
        return h, h

    def misfit(hx: float, hy: float) -> float:
        # distance of each mount from the rectangle's boundary, in units of the rectangle
        r = np.maximum(np.abs(mounts[:, 0]) / hx, np.abs(mounts[:, 1]) / hy)
        return float(np.abs(r - 1.0).sum())

    a, b = size[0] / 2, size[1] / 2
    return (a, b) if misfit(a, b) <= misfit(b, a) else (b, a)


def _rotate(theta: np.ndarray, x: np.ndarray) -> np.ndarray:
    """R(θ) x for θ (N,) and x (N, ..., 2)."""
    c, s = np.cos(theta), np.sin(theta)
    shape = (-1,) + (1,) * (x.ndim - 2)
    c, s = c.reshape(shape), s.reshape(shape)
    return np.stack((c * x[..., 0] - s * x[..., 1], s * x[..., 0] + c * x[..., 1]), axis=-1)


def world_geometry(robot: PlanarManipulator, q: Any) -> dict[str, np.ndarray]:
    """Inertial-frame geometry of a planar manipulator at configurations q (N, k + 1).

    q holds the k joint angles then the base angle θ. Returns arrays over the N samples:

    * `theta` (N,), `base_center` (N, 2): base CM, `base_corners` (N, 4, 2).
    * `proximal`, `distal` (N, k, 2): the ends of each link (joint j is link j's proximal end).
    * `mount` (N, n_arms, 2), `arm_of_link` (k,).
    * base-frame quantities for the MCAP transforms: `base_proximal` (N, k, 2),
      `link_angle` (N, k) (link orientation relative to the base), `system_com` (N, 2).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    k = robot.n_joints
    if q.shape[-1] != k + 1:
        raise ValueError(f"q must have shape (N, {k + 1}) (joints, then theta), got {q.shape}")
    theta = q[:, k]
    geo = link_geometry(robot, q[:, :k])
    pc = geo["system_com"]  # (N, 2)
    hx, hy = base_extent(robot)
    corners = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])

    def world(x: np.ndarray) -> np.ndarray:
        return _rotate(theta, x - pc.reshape(pc.shape[0], *([1] * (x.ndim - 2)), 2))

    n = q.shape[0]
    mounts = np.broadcast_to(geo["mount"], (n, *geo["mount"].shape))
    return {
        "theta": theta,
        "base_center": world(np.zeros((n, 1, 2)))[:, 0],
        "base_corners": world(np.broadcast_to(corners, (n, 4, 2))),
        "proximal": world(geo["proximal"]),
        "distal": world(geo["distal"]),
        "mount": world(mounts),
        "arm_of_link": geo["arm_of_link"],
        "base_proximal": geo["proximal"],
        "link_angle": geo["angle"],
        "system_com": pc,
    }


def world_bodies(robot: PlanarManipulator, q: Any) -> tuple[np.ndarray, np.ndarray]:
    """The base's corners (N, 4, 2) and the links' ends (N, k, 2, 2: proximal, distal) in the
    inertial frame at configurations q (N, k + 1), as `world_geometry` places them (the same
    arithmetic), without its other keys: clearances are measured on these alone, and the
    constrained search (`node_margins`) measures them hundreds of times a plan."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    k = robot.n_joints
    st = structure(robot)
    _, (ux, uy), (ox, oy), (px, py) = kinematics(st, np.ascontiguousarray(q[:, :k].T))
    pcx, pcy = (st.m @ px) / st.M, (st.m @ py) / st.M  # (N,): p_c
    theta = q[:, k]
    c, s = np.cos(theta), np.sin(theta)

    def world(x: np.ndarray, y: np.ndarray) -> np.ndarray:  # (k, N) base frame -> (N, k, 2)
        dx, dy = (x - pcx).T, (y - pcy).T
        return np.stack((c[:, None] * dx - s[:, None] * dy, s[:, None] * dx + c[:, None] * dy), -1)

    links = np.stack((world(ox, oy), world(ox + st.length * ux, oy + st.length * uy)), axis=2)
    hx, hy = base_extent(robot)
    corners = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
    return world(corners[:, 0, None], corners[:, 1, None]), links
