"""`stroboscope.png` of a URDF robot: the robot at regular instants, projected on the two
principal planes of its motion.

The robot is drawn as its kinematic tree (a line from each link's origin to its children's)
and its base, at each leg's first and last instant, as the box of the base body's mass and
inertia (`SpatialRobot.base_box`; a URDF gives the planner no shape), with the system CoM,
fixed at the origin, marked. The planes are those of the two largest principal axes of the
link origins over the whole motion (PCA) and of the first and third: the view in which the
motion spreads most, and the one across it. Instants fade from light to dark along the
motion; each leg has its own colour.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from .. import so3
from .figure_common import FAILED_COLOR, message_band, stamp_failed

__all__ = ["reach", "spatial_stroboscope_figure"]

INSTANTS_PER_LEG = 6
COLORS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b")


# the 8 corners of a box numbered by their sign bits (x, y, z), and its 12 edges
BOX_SIGNS = np.array([[(c >> b & 1) - 0.5 for b in range(3)] for c in range(8)])
BOX_EDGES = [(a, a | bit) for bit in (1, 2, 4) for a in range(8) if not a & bit]


def _box_corners(box, p: np.ndarray, R: np.ndarray) -> np.ndarray:
    """The 8 world corners of the base's box (`SpatialRobot.base_box`) with the base at
    position p, rotation R."""
    centre, axes, edges = box
    return p + (centre + (BOX_SIGNS * edges) @ axes.T) @ R.T


def _poses(plan, traj, indices):
    """Per instant: the link origins, the tree's segments and the base box's edges."""
    robot = plan.system.spatial
    k = robot.n_joints
    parents = {j.child: j.parent for j in robot.summary.joints}
    box = robot.base_box()
    drawn = []
    for i in indices:
        q = traj.q[i]
        poses = robot.link_poses(q[:k], so3.exp(q[k:]))
        segments = [
            (poses[parents[name]][0], p)
            for name, (p, _) in poses.items()
            if parents.get(name) in poses
        ]
        corners = _box_corners(box, *poses[robot.base])
        base = [(corners[a], corners[b]) for a, b in BOX_EDGES]
        drawn.append((np.array([p for p, _ in poses.values()]), segments, base))
    return drawn


def _tip_paths(plan, traj) -> list[np.ndarray]:
    """Each leg's end-effector path (the link farthest down the tree from the base: the
    last link of the longest chain) at every sample, (samples, 3)."""
    robot = plan.system.spatial
    k = robot.n_joints
    parents = {j.child: j.parent for j in robot.summary.joints}

    def depth(name: str) -> int:
        return 0 if name not in parents else 1 + depth(parents[name])

    tip = max(parents, key=depth, default=robot.base)
    paths = []
    for leg in range(len(plan.legs)):
        s = traj.leg_slice(leg)
        q = traj.q[s.start : s.stop]
        paths.append(
            np.array([robot.link_poses(x[:k], so3.exp(x[k:]))[tip][0] for x in q])
            if len(q)
            else np.zeros((0, 3))
        )
    return paths


def reach(plan, q) -> float:
    """The largest distance of a link origin from the system CoM at configuration q (m)."""
    robot = plan.system.spatial
    k = robot.n_joints
    if not np.all(np.isfinite(q)):
        return 0.0
    poses = robot.link_poses(np.asarray(q)[:k], so3.exp(np.asarray(q)[k:]))
    return float(max(np.linalg.norm(p) for p, _ in poses.values()))


def _axis_label(v: np.ndarray, index: int) -> str:
    """A principal axis named by its world direction, "principal axis 1: 0.98x - 0.17z [m]"
    (the components of at least 0.1; "principal axis 1" alone said nothing of where it
    points); its largest component is positive (the figure's axes are so chosen)."""
    terms = [(c, name) for c, name in zip(v, "xyz", strict=True) if abs(c) >= 0.1]
    text = "".join(
        f"{'−' if c < 0 else '+' if k else ''}{abs(c):.2g}{name}"
        for k, (c, name) in enumerate(terms)
    )
    return f"principal axis {index + 1}: {text}, from the CoM [m]"


def spatial_stroboscope_figure(plan, traj, title: str = "") -> Figure:
    """The stroboscope of a URDF robot's motion on its two principal planes."""
    picks = []
    for k in range(len(plan.legs)):
        s = traj.leg_slice(k)
        if s.stop > s.start:
            picks += [(k, int(i)) for i in np.linspace(s.start, s.stop - 1, INSTANTS_PER_LEG)]
    drawn = _poses(plan, traj, [i for _, i in picks])
    tips = _tip_paths(plan, traj)  # per leg: (samples, 3), as the planar figure draws them
    points = np.concatenate([p for p, *_ in drawn])
    if not np.all(np.isfinite(points)):
        raise ValueError("non-finite samples")
    centre = points.mean(axis=0)
    _, _, Vt = np.linalg.svd(points - centre, full_matrices=False)
    Vt = Vt * np.sign(Vt[np.arange(len(Vt)), np.abs(Vt).argmax(axis=1)])[:, None]  # (labels)
    planes = ((0, 1), (0, 2))
    band = message_band(plan, 10.0)  # a failed plan's message, under the panels
    fig = Figure(figsize=(10, 5 + band))
    axes = fig.subplots(1, 2)
    fig.subplots_adjust(bottom=(0.55 + band) / (5 + band), top=1 - 0.5 / (5 + band))
    for ax, (a, b) in zip(axes, planes, strict=True):
        for n, ((leg, _), (_, segments, base)) in enumerate(zip(picks, drawn, strict=True)):
            position = (n % INSTANTS_PER_LEG + 1) / INSTANTS_PER_LEG
            color = COLORS[leg % len(COLORS)]
            alpha = 0.15 + 0.85 * position
            first, last = n % INSTANTS_PER_LEG == 0, n % INSTANTS_PER_LEG == INSTANTS_PER_LEG - 1
            style = "--" if first else "-"  # a leg's start dashed, its end solid and wider
            arm = 2.4 if last else 1.7 if first else 1.2
            for lines, c, width in (
                ((base if first or last else []), "0.45", 0.7),
                (segments, color, arm),
            ):
                if not lines:
                    continue
                x = np.array(lines)  # (segments, 2 ends, 3), from the CoM (the origin)
                xy = x @ Vt[[a, b]].T
                ax.plot(xy[:, :, 0].T, xy[:, :, 1].T, color=c, alpha=alpha, lw=width, ls=style)
        for leg, path in enumerate(tips):
            xy = path @ Vt[[a, b]].T
            ax.plot(*xy.T, color=COLORS[leg % len(COLORS)], lw=1.0, ls=":", alpha=0.9)
        ax.plot(0.0, 0.0, marker="+", color="k", ms=10, label="system CoM (fixed)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(_axis_label(Vt[a], a))
        ax.set_ylabel(_axis_label(Vt[b], b))
        ax.grid(alpha=0.3)
    for k, leg in enumerate(plan.legs):
        axes[0].plot([], [], color=COLORS[k % len(COLORS)], label=f"leg {k + 1} ({leg.stratum})")
    axes[0].plot([], [], color="0.3", lw=1.7, ls="--", label="start of leg")
    axes[0].plot([], [], color="0.3", lw=2.4, label="end of leg")
    axes[0].plot([], [], color="0.3", lw=1.0, ls=":", label="end-effector path")
    axes[0].plot([], [], color="0.45", lw=0.6, label="base (box of its inertia)")
    axes[0].legend(loc="best", fontsize=8)
    fig.suptitle(
        f"{title or plan.scenario}: stroboscope on the principal planes (light to dark in time)"
        + ("" if plan.ok else " — FAILED"),
        fontsize=11,
        color="k" if plan.ok else FAILED_COLOR,
    )
    stamp_failed(fig, plan, band_at=0.12 if band else None)  # (a failed plan's looked ok)
    return fig
