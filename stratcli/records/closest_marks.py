"""Each leg's closest approaches as the stroboscope marks them, from the drawn samples: to an
obstacle (that pose dash-dotted, × at the robot's point nearest it) and, under
`self_collision`, between the robot's own bodies (that pose in purple, a short segment
between the two bodies' nearest points), each with the leg's margin and its time in the
panel's corner, one line above the other.

The margins are `body_clearances`'s (surface distance less the clearance, as result.json's);
the pair of bodies is the one closest at that sample, and its nearest points are found
among 101 points along each link's core and each edge of the base (`obstacles.ALONG`),
moved out to the capsules' surfaces."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from matplotlib.collections import PolyCollection
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from ..body_clearances import self_pairs
from ..sequence import SequencePlan
from .figure_common import FAILED_COLOR
from .obstacles import ALONG, OBSTACLE_STYLE, closest_approach, has_obstacles, resolved_constraints
from .poses import draw_poses
from .trajectory import Trajectory, world_geometry

__all__ = [
    "SELF_COLOR",
    "SelfApproach",
    "body_name",
    "draw_capsules",
    "has_self_collision",
    "legend_handles",
    "mark_closest",
    "self_approach",
]

SELF_COLOR = "#7d3c98"  # the self-collision mark (the obstacle one is FAILED_COLOR)
LINE_PT = 11.0  # points between the corner texts' rows (7.5 pt text)


def has_self_collision(plan: SequencePlan) -> bool:
    return plan.constraints is not None and bool(plan.constraints.spec.get("self_collision"))


def body_name(body: int) -> str:
    """A body as `self_pairs` numbers it (links from 0, the base -1): "link 2", "base"."""
    return "base" if body < 0 else f"link {body + 1}"


@dataclass(frozen=True)
class SelfApproach:
    """A leg's closest approach between the robot's own bodies among some samples.

    Attributes
    ----------
    index : the sample, within the configurations given.
    bodies : the pair, as `self_pairs` numbers them (links from 0, the base -1).
    points : (2, 2), the point of each body nearest the other (on the surface of a link's
        capsule, on the base's outline; on the cores where capsules overlap).
    margin : their surface distance less the clearance at that sample.
    """

    index: int
    bodies: tuple[int, int]
    points: np.ndarray
    margin: float

    @property
    def pair(self) -> str:
        """ "link 2 – base", "link 1 – link 3"."""
        return " – ".join(body_name(b) for b in self.bodies)


def _core(geo: dict, k: int, body: int, radius: float) -> tuple[np.ndarray, float]:
    """Points along a body's core at sample k (a link's segment, the base's outline), and
    the radius its surface is out from them."""
    if body < 0:
        corners = geo["base_corners"][k]
        ends, radius = [(corners[m], corners[(m + 1) % 4]) for m in range(4)], 0.0
    else:
        ends = [(geo["proximal"][k, body], geo["distal"][k, body])]
    return np.concatenate([a + ALONG[:, None] * (b - a) for a, b in ends]), radius


def self_approach(plan: SequencePlan, q: np.ndarray) -> SelfApproach | None:
    """Among configurations `q` (N, n) of a leg: the closest approach between two of the
    robot's bodies; None without `self_collision` or a finite configuration."""
    if not has_self_collision(plan) or not len(q):
        return None
    c = resolved_constraints(plan)
    geo = world_geometry(plan.system.robot, q)
    pairs = self_pairs(geo, c)
    if not pairs:
        return None
    d = np.stack([gap for *_, gap in pairs])  # (pairs, N)
    d = np.where(np.isnan(d), np.inf, d)  # a failed leg's diverged samples
    if not (d < np.inf).any():
        return None
    p, k = np.unravel_index(int(np.argmin(d)), d.shape)
    bodies = pairs[p][:2]
    (a, ra), (b, rb) = (_core(geo, int(k), body, c.link_radius) for body in bodies)
    gaps = np.linalg.norm(a[:, None] - b[None], axis=-1)
    m, n = np.unravel_index(int(np.argmin(gaps)), gaps.shape)
    points = np.array([a[m], b[n]])
    apart = float(gaps[m, n])
    if apart > ra + rb:  # out to the surfaces, along the line between the cores' points
        u = (points[1] - points[0]) / apart
        points = np.array([points[0] + ra * u, points[1] - rb * u])
    return SelfApproach(int(k), bodies, points, float(d[p, k] - c.clearance))


def mark_closest(ax, plan: SequencePlan, traj: Trajectory, geo: dict, leg: int) -> None:
    """Mark a leg's closest approaches (to an obstacle, and between its own bodies) among
    the drawn samples, each margin as result.json has it where that is smaller (from the
    denser samples of the verification: at most that close between the drawn ones)."""
    s = traj.leg_slice(leg)
    legs = plan.constraints.legs if plan.constraints is not None else ()
    report = legs[leg] if leg < len(legs) else None
    texts = []
    near = closest_approach(plan, traj.q[s])
    if near is not None:
        k, point, margin = near
        if report is not None and report.obstacle_clearance is not None:
            margin = min(margin, report.obstacle_clearance)
        draw_poses(ax, geo, np.array([s.start + k]), [FAILED_COLOR], lw=1.0, zorder=3,
                   linestyle="-.")  # fmt: skip
        draw_capsules(ax, geo, s.start + k, resolved_constraints(plan).link_radius, FAILED_COLOR)
        ax.plot(*point, "x", color=FAILED_COLOR, ms=9, mew=2.2, zorder=8)
        when = traj.t[s.start + k]
        texts.append((f"closest approach: margin {margin:.3g}, near t = {when:.4g} s",
                      FAILED_COLOR))  # fmt: skip
    own = self_approach(plan, traj.q[s])
    if own is not None:
        margin = own.margin
        if report is not None and report.self_clearance is not None:
            margin = min(margin, report.self_clearance)
        draw_poses(ax, geo, np.array([s.start + own.index]), [SELF_COLOR], lw=1.4, zorder=3.5)
        draw_capsules(ax, geo, s.start + own.index, resolved_constraints(plan).link_radius,
                      SELF_COLOR)  # fmt: skip
        x, y = own.points.T
        ax.plot(x, y, "-o", color=SELF_COLOR, lw=2.2, ms=4.5, zorder=8.5, solid_capstyle="butt")
        when = traj.t[s.start + own.index]
        texts.append((f"closest approach, {own.pair}:\nmargin {margin:.3g}, near t = {when:.4g} s",
                      SELF_COLOR))  # fmt: skip
    for row, (text, color) in enumerate(texts):  # one above the other, from the corner up
        ax.annotate(
            text, (0.02, 0.02), xycoords="axes fraction", xytext=(0, LINE_PT * row),
            textcoords="offset points", fontsize=7.5, color=color, va="bottom", zorder=9,
        )  # fmt: skip


def draw_capsules(ax, geo: dict, index: int, radius: float, color) -> None:
    """The links at sample `index` as the capsules the clearances are measured on (each link's
    segment thickened by `radius`, shaded): a drawn line alone hid how close they came."""
    turn = np.linspace(-np.pi / 2, np.pi / 2, 13)
    outlines = []
    for a, b in zip(geo["proximal"][index], geo["distal"][index], strict=True):
        d = b - a
        angle = float(np.arctan2(d[1], d[0])) if np.any(d) else 0.0
        ends = [(b, angle + turn), (a, angle + np.pi + turn)]  # a half circle round each end
        outlines.append(
            np.concatenate([p + radius * np.stack((np.cos(t), np.sin(t)), -1) for p, t in ends])
        )
    ax.add_collection(
        PolyCollection(outlines, facecolors=color, edgecolors=color, alpha=0.15, lw=0.5, zorder=2.9)
    )


def legend_handles(plan: SequencePlan) -> list:
    """The stroboscope legend's entries for the obstacles and the closest approaches."""
    handles = []
    if has_obstacles(plan):
        handles.append(Patch(label="obstacle", **OBSTACLE_STYLE))
        handles.append(
            Line2D([], [], color=FAILED_COLOR, lw=1.0, ls="-.", marker="x", ms=6, mew=2,
                   label="closest approach")
        )  # fmt: skip
    if has_self_collision(plan):
        handles.append(
            Line2D([], [], color=SELF_COLOR, lw=1.4, marker="o", ms=3.5,
                   label="closest approach (self)")
        )  # fmt: skip
    return handles
