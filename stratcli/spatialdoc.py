"""The `attitude` section of a spatial plan's result.json, and its conservation audit (no I/O).

Every start, goal and end attitude is given as a unit quaternion `(w, x, y, z)` (w ≥ 0) and
as a rotation vector (rad, world frame: `R = exp([φ]×)` maps base to world axes); a goal
attitude left free (`"*"`) is null. Each leg reports its goal error on the group,
`|log(R_goalᵀ R(T))|` (rad), and an audit of the motion re-integrated on the group with fine
Magnus steps: the largest total momentum `|h(t)|` (Pinocchio's centroidal map applied to the
joint rates and the base twist the connection gives), the CoM drift (the base position
integrated from its linear velocity against `−R c(q)`, which keeps the CoM at the origin)
and `max ‖RᵀR − I‖`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import so3
from .magnus import MagnusEndpoint

__all__ = ["attitude_document", "audit_leg", "group_error"]

AUDIT_STEPS = 400  # at least this many Magnus steps per leg (or piece) in the audit, and
# twice the planner's (the CoM drift is integrated by Simpson's rule on them)
AUDIT_POINTS = 40  # where the momentum is evaluated along a leg


def _pose(phi: np.ndarray) -> dict[str, Any] | None:
    phi = np.asarray(phi, dtype=float)
    if not np.all(np.isfinite(phi)):
        return None
    q = so3.quaternion_from_matrix(so3.exp(phi))
    return {"quaternion": q.tolist(), "rotation_vector": so3.log(so3.exp(phi)).tolist()}


def group_error(goal: np.ndarray, end: np.ndarray) -> float | None:
    """`|log(R_goalᵀ R_end)|` (rad) between two rotation vectors; where the goal is partly
    free ("*" components), the norm of the given components' differences (as the planner
    compares them, `magnus.residual_on_group`); None if it is free (or the end not finite)."""
    goal, end = np.asarray(goal, dtype=float), np.asarray(end, dtype=float)
    given = np.isfinite(goal)
    if not given.any() or not np.all(np.isfinite(end)):
        return None
    if not given.all():
        return float(np.linalg.norm(end[given] - goal[given]))
    return float(np.linalg.norm(so3.log(so3.exp(goal).T @ so3.exp(end))))


def audit_leg(system, leg) -> dict[str, float]:
    """Momentum, CoM drift and orthogonality along a leg re-integrated on the group."""
    cs = system.compiled(leg.stratum)
    robot, k = system.spatial, cs.k
    q = np.asarray(leg.start, dtype=float)
    momentum = drift = ortho = 0.0
    for piece in leg.pieces:
        ep = MagnusEndpoint(cs, q, leg.basis, piece.duration)
        lam = np.asarray(piece.coefficients, dtype=float).ravel()
        L = lam.reshape(ep.m, ep.size)
        steps = 2 * max(AUDIT_STEPS // 2, ep.steps(L))  # even: Simpson's rule below
        ep.steps_override = steps
        R = ep.attitudes(lam)  # (N + 1, 3, 3) at the step boundaries
        t = np.linspace(0.0, piece.duration, steps + 1)
        joints = q[:k] + leg.basis.integrals(t) @ (L.T @ cs.C_explicit.T)
        rates = leg.basis.values(t) @ (L.T @ cs.C_explicit.T)
        S, _ = robot.connection(joints)
        v_world = (R @ (S[:, :3] @ rates[:, :, None]))[:, :, 0]  # base linear velocity
        p = robot.base_position(joints[:1], R[:1])[0] + _cumulative_simpson(v_world, t)
        expected = robot.base_position(joints, R)
        drift = max(drift, float(np.abs(p - expected)[::2].max()))
        ortho = max(ortho, so3.orthogonality_error(R))
        for i in np.linspace(0, steps, AUDIT_POINTS // max(len(leg.pieces), 1) + 1):
            i = int(i)
            h = robot.momentum(joints[i], R[i], rates[i])
            momentum = max(momentum, float(np.linalg.norm(h)))
        q = np.concatenate([joints[-1], so3.log(R[-1])])
    return {"max_momentum": momentum, "com_drift": drift, "orthogonality": ortho}


def _cumulative_simpson(f: np.ndarray, t: np.ndarray) -> np.ndarray:
    """∫_0^{t_i} f at the even nodes by Simpson's rule (odd nodes: trapezoid, not used)."""
    out = np.zeros_like(f)
    h = t[1] - t[0]
    panels = (f[0:-2:2] + 4 * f[1:-1:2] + f[2::2]) * h / 3
    out[2::2] = np.cumsum(panels, axis=0)
    out[1::2] = out[0:-1:2] + (f[0:-1:2] + f[1::2]) * h / 2
    return out


def attitude_document(plan) -> dict[str, Any]:
    """The `attitude` section of a spatial plan's result.json."""
    system = plan.system
    att = system.attitude
    legs = []
    for leg in plan.legs:
        entry = {
            "start": _pose(leg.start[att]),
            "goal": _pose(leg.goal[att]),
            "end": _pose(leg.end[att]),
            "goal_error": group_error(leg.goal[att], leg.end[att]),
        }
        finite = np.all(np.isfinite(leg.end)) and leg.pieces
        entry["audit"] = audit_leg(system, leg) if finite else None
        legs.append(entry)
    return {
        "convention": (
            "R maps base to world axes; rotation_vector = log(R) (rad, world frame); "
            "quaternion (w, x, y, z), w >= 0; goal_error = |log(R_goal^T R_end)| (rad), "
            "where the goal is partly free the norm of its given rotation-vector components' "
            "differences, null where it is free"
        ),
        "start": _pose(plan.start[att]),
        "goal": _pose(plan.goal[att]),
        "end": _pose(plan.end[att]) if plan.legs else None,
        "legs": legs,
    }
