"""Drawings of a planar manipulator's motion: the stroboscope figure and the animated GIF.

`stroboscope_figure` draws the robot at regular instants of each leg, fading from light to
dark, one panel per leg (as the paper's Fig. 7; at most `MAX_PANELS` evenly spaced legs), and
`motion_gif` animates the same motion, returned as GIF bytes. Both draw poses in the inertial
frame with `poses.draw_poses` (base, links and joints as batched collections) from
`trajectory.world_geometry`. `render_plots` in `plots` puts them in a run record.

Positions are in metres: a robot (a preset, the paper's robots, or a `planar-manipulator`
model) is given in metres. The GIF plays in real time, or at a speed-up its title states.
"""

from __future__ import annotations

import io

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from ..sequence import SequencePlan
from .closest_marks import legend_handles, mark_closest
from .figure_common import (
    DPI,
    FAILED_COLOR,
    TICK_STEPS,
    fixed_margins,
    leg_method,
    locked_names,
    message_band,
    stamp_failed,
    title_lines,
)
from .obstacles import draw_obstacles, obstacle_points
from .poses import draw_poses, segments
from .trajectory import Trajectory, world_geometry

__all__ = ["DPI", "frame_schedule", "locked_names", "motion_gif", "stroboscope_figure"]

ARM_DARK = np.array([0.05, 0.16, 0.40])  # the last snapshot of a leg
ARM_LIGHT = np.array([0.72, 0.80, 0.92])  # the first one
BASE_FACE = "#9aa5b1"
MAX_PANELS = 12  # stroboscope panels
LEGEND_ENTRY_IN = 1.5  # inches a legend entry takes at most: more wrap to a second row


def _limits(
    geo: dict[str, np.ndarray], margin: float = 0.25, extra: np.ndarray | None = None
) -> tuple[tuple, tuple]:
    """The axes' limits around the robot's every pose and the `extra` points (obstacles)."""
    pts = np.concatenate(
        [
            geo["base_corners"].reshape(-1, 2),
            geo["proximal"].reshape(-1, 2),
            geo["distal"].reshape(-1, 2),
            np.zeros((0, 2)) if extra is None else extra,
        ]
    )
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if not pts.size:
        raise ValueError("no finite configuration to draw")
    lo, hi = pts.min(axis=0) - margin, pts.max(axis=0) + margin
    return (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1]))


def _tips(geo: dict[str, np.ndarray]) -> np.ndarray:
    """End-effector position of each arm, (N, n_arms, 2)."""
    arm = geo["arm_of_link"]
    last = [int(np.flatnonzero(arm == a)[-1]) for a in range(int(arm.max()) + 1)]
    return geo["distal"][:, last]


def _instants(leg, t: np.ndarray, s: slice, snapshots: int) -> np.ndarray:
    """Sample indices of a leg's stroboscope poses: evenly spaced, but a leg of several
    pieces (a Lie leg's steps) at the middle of evenly chosen pieces, between its start and
    end: its loops close at the step boundaries, where evenly spaced poses landed, and the
    leg looked still while its joints swung by radians."""
    if len(leg.pieces) <= 1:
        return np.unique(np.linspace(s.start, s.stop - 1, snapshots).round().astype(int))
    picked = np.unique(np.linspace(0, len(leg.pieces) - 1, snapshots - 2).round().astype(int))
    mids = [leg.t0 + leg.pieces[k].t0 + 0.5 * leg.pieces[k].duration for k in picked]
    inner = s.start + np.clip(np.searchsorted(t[s], mids), 0, s.stop - s.start - 1)
    return np.unique([s.start, *inner, s.stop - 1])


def stroboscope_figure(
    plan: SequencePlan, traj: Trajectory, title: str = "", snapshots: int = 10
) -> Figure:
    """The manipulator at `snapshots` instants of each leg, light to dark, one panel per leg.

    With more than `MAX_PANELS` legs, only `MAX_PANELS` evenly spaced legs (the first and the
    last among them) get a panel; the title names how many are shown.
    """
    robot = plan.system.robot
    geo = world_geometry(robot, traj.q)
    xlim, ylim = _limits(geo, extra=obstacle_points(plan))
    shown = np.unique(np.linspace(0, len(plan.legs) - 1, MAX_PANELS).round().astype(int))
    if len(plan.legs) <= MAX_PANELS:
        shown = np.arange(len(plan.legs))
    legs = len(shown)
    cols = min(legs, 4)
    rows = -(-legs // cols)
    span = max(xlim[1] - xlim[0], 1e-9) / max(ylim[1] - ylim[0], 1e-9)
    panel_w = min(4.0, 11.0 / cols) if span < 1.6 else min(5.5, 11.0 / cols)
    panel_h = float(np.clip(panel_w / span, 2.0, 4.5))
    handles = [
        Line2D([], [], color="0.3", lw=1.7, ls="--", marker="o", ms=3, label="start of leg"),
        Line2D([], [], color=tuple(ARM_DARK), lw=2.4, marker="o", ms=4, label="end of leg"),
        Line2D([], [], color="#d35400", lw=1.2, ls=":", label="end-effector path"),
        Line2D([], [], color="k", marker="+", ls="none", label="system CM (fixed)"),
    ]
    handles += legend_handles(plan)
    margins = {"left": 0.7, "right": 0.2, "top": 0.85, "bottom": 0.85}  # in; titles, legend
    gaps = {"hspace": 0.75, "wspace": 0.2}  # in; the next row's panel titles, shared y
    width = panel_w * cols + margins["left"] + margins["right"] + gaps["wspace"] * (cols - 1)
    per_row = int(max(width, 7.5) // LEGEND_ENTRY_IN)
    legend_rows = -(-len(handles) // per_row)
    margins["bottom"] += 0.2 * (legend_rows - 1)
    band = message_band(plan, max(width, 7.5))  # a failed plan's message, under the legend
    margins["bottom"] += band  # (boxed over the panels' middle, it hid the poses)
    head = f"{title}: stroboscope" if title else "stroboscope"
    if legs < len(plan.legs):
        head += f", {legs} of {len(plan.legs)} legs"
    head = title_lines(
        f"{head} ({snapshots} instants per leg, light to dark; inertial frame)"
        + ("" if plan.ok else " — FAILED"),
        max(width, 7.5),
    )
    margins["top"] += 0.2 * head.count("\n")  # (a wrapped title's lines)
    height = panel_h * rows + margins["top"] + margins["bottom"] + gaps["hspace"] * (rows - 1)
    fig = Figure(figsize=(max(width, 7.5), height), dpi=DPI)
    axes = fig.subplots(rows, cols, squeeze=False, sharex=True, sharey=True)
    fixed_margins(fig, **margins, **gaps)
    tips = _tips(geo)
    for panel in range(rows * cols):
        ax = axes[panel // cols, panel % cols]
        if panel >= legs:
            ax.set_visible(False)
            continue
        k = int(shown[panel])
        leg = plan.legs[k]
        s = traj.leg_slice(k)
        idx = _instants(leg, traj.t, s, snapshots)
        w = np.linspace(0.0, 1.0, len(idx))[1:-1]
        fading = [tuple((1 - x) * ARM_LIGHT + x * ARM_DARK) for x in w]
        draw_poses(ax, geo, idx[1:-1], fading, lw=1.2, zorder=2, edge_alpha=0.55)
        draw_poses(ax, geo, idx[:1], ["0.3"], lw=1.7, zorder=4, linestyle="--")
        draw_poses(ax, geo, idx[-1:], [tuple(ARM_DARK)], lw=2.4, zorder=5, face=BASE_FACE)
        for a in range(tips.shape[1]):
            ax.plot(tips[s, a, 0], tips[s, a, 1], ":", color="#d35400", lw=1.2, zorder=6)
        ax.plot(0, 0, "+", color="k", markersize=7, zorder=7)
        draw_obstacles(ax, plan)
        mark_closest(ax, plan, traj, geo, k)
        ax.set_xlim(*xlim)
        ax.set_ylim(*ylim)
        ax.set_aspect("equal")
        ax.tick_params(labelsize=7.5)
        for axis in (ax.xaxis, ax.yaxis):  # a few round ticks: a tick costs ~1 ms to draw
            axis.set_major_locator(MaxNLocator(nbins=5, steps=TICK_STEPS))
        ax.grid(True, color="0.9", linewidth=0.5)
        locked = ", ".join(locked_names(plan, k))
        ax.set_title(
            f"leg {k + 1}: {leg_method(plan, k)}"
            + (f" ({locked} locked)" if locked else "")
            + f"\nt = {leg.t0:.4g} to {leg.t0 + leg.duration:.4g} s",
            fontsize=9,
        )
        if panel % cols == 0:
            ax.set_ylabel("y [m]", fontsize=9)
        if panel // cols == rows - 1 or panel + cols >= legs:
            ax.set_xlabel("x [m]", fontsize=9)
    fig.legend(
        handles=handles,
        loc="lower center",
        bbox_to_anchor=(0.5, band / height),
        ncols=-(-len(handles) // legend_rows),
        fontsize=8,
        frameon=False,
        handlelength=3.2,
    )
    fig.suptitle(
        head,
        fontsize=11,
        fontweight="bold",
        color="k" if plan.ok else FAILED_COLOR,
    )
    stamp_failed(fig, plan, band_at=0.12 if band else None)
    return fig


SPEEDS = (1, 2, 4, 5, 10, 20, 25, 50, 100, 200, 250, 500, 1000)  # of a GIF too long for real time
HOLD_MS = 1000  # the final pose stays this long before the loop restarts


def frame_schedule(
    t0: float, t1: float, max_frames: int = 120, frame_ms: int = 50
) -> tuple[np.ndarray, list[int], int]:
    """Plan times of the GIF's frames, their durations (ms) and the speed-up.

    Frames are `frame_ms` apart on the screen and `speed × frame_ms` apart in plan time, with
    the smallest speed-up of `SPEEDS` that fits `max_frames` (1: real time). GIF durations are
    whole centiseconds and browsers show a frame under 20 ms for 100 ms, so the last, shorter
    interval is kept only when it lasts ≥ 20 ms (otherwise the last frame moves to the end,
    < 20 ms early). The final frame is held `HOLD_MS`.
    """
    total = max(t1 - t0, 0.0)
    speed = next((s for s in SPEEDS if total / (s * frame_ms / 1000) + 2 <= max_frames), 0)
    speed = speed or int(np.ceil(total / (frame_ms / 1000) / (max_frames - 2)))
    step = speed * frame_ms / 1000
    times = t0 + step * np.arange(int(np.floor(total / step + 1e-9)) + 1)
    durations = [frame_ms] * len(times)
    rest_ms = round((t1 - times[-1]) / speed * 1000, -1)
    if rest_ms >= 20:
        times = np.append(times, t1)
        durations[-1] = int(rest_ms)
        durations.append(HOLD_MS)
    else:
        times[-1] = t1
        durations[-1] = HOLD_MS
    if len(times) == 1:  # a plan of zero duration: still an animation of two frames
        times, durations = np.array([t0, t1]), [frame_ms, HOLD_MS]
    return times, durations, speed


def motion_gif(
    plan: SequencePlan,
    traj: Trajectory,
    title: str = "",
    max_frames: int = 120,
    frame_ms: int = 50,
) -> bytes:
    """An animated GIF of the motion, looping: real time, or a speed-up its title states.

    Frames are `frame_ms` apart (at most `max_frames`; see `frame_schedule`); text is at
    least 9 pt at 100 dpi (12 px). The static parts (axes, start and goal ghosts) are drawn
    once and every frame only redraws the moving artists over that background (blitting),
    then Pillow (matplotlib's own image dependency) encodes the frames with one shared
    palette. matplotlib's `PillowWriter` would redraw and re-lay-out the whole figure for
    every frame (about 0.2 s each here, 15 s for a 3-leg run); this takes well under a second.
    """
    from PIL import Image  # a dependency of matplotlib

    robot = plan.system.robot
    geo = world_geometry(robot, traj.q)
    xlim, ylim = _limits(geo, extra=obstacle_points(plan))
    times, durations, speed = frame_schedule(traj.t[0], traj.t[-1], max_frames, frame_ms)
    # the sample at (or just after) each frame time; a switch instant shows the later leg
    index = np.minimum(np.searchsorted(traj.t, times, side="left"), traj.size - 1)

    span = max(xlim[1] - xlim[0], 1e-9) / max(ylim[1] - ylim[0], 1e-9)
    fig = Figure(figsize=(5.0, float(np.clip(4.2 / span, 2.6, 6.0)) + 1.3), dpi=100)
    fig.set_layout_engine("constrained")
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.set_xlim(*xlim)
    ax.set_ylim(*ylim)
    ax.set_aspect("equal")
    ax.tick_params(labelsize=9)
    ax.set_xlabel("x [m]", fontsize=9, labelpad=1)
    ax.set_ylabel("y [m]", fontsize=9, labelpad=1)
    ax.grid(True, color="0.9", linewidth=0.5)
    draw_obstacles(ax, plan)
    draw_poses(ax, geo, np.array([0]), ["0.7"], lw=1.3, zorder=1, linestyle="--")
    draw_poses(ax, geo, np.array([traj.size - 1]), ["#7fb3d5"], lw=1.3, zorder=1, linestyle=":")
    (centre,) = ax.plot(0, 0, "+", color="k", markersize=7, zorder=7)
    tips = _tips(geo)
    trails = [
        ax.plot([], [], "-", color="#d35400", lw=1.0, alpha=0.8, zorder=2)[0]
        for _ in range(tips.shape[1])
    ]
    base = PolyCollection(
        [geo["base_corners"][0]], facecolors=BASE_FACE, edgecolors=tuple(ARM_DARK), zorder=3
    )
    ax.add_collection(base)
    links = LineCollection(
        segments(geo, np.array([0])), colors=tuple(ARM_DARK), linewidths=2.8, zorder=4
    )
    ax.add_collection(links)
    (joints,) = ax.plot([], [], "o", color=tuple(ARM_DARK), markersize=4.5, zorder=5)
    legs = len(plan.legs)
    pace = "real time" if speed == 1 else f"played ×{speed}"
    status = "" if plan.ok else " — FAILED"
    fig.suptitle(
        f"{title + ': ' if title else ''}{pace}{status}",
        fontsize=11,
        fontweight="bold",
        color="k" if plan.ok else FAILED_COLOR,
    )
    widest = max((leg_method(plan, k) for k in range(legs)), key=len)
    heading = ax.set_title(f"leg {legs}/{legs}: {widest}", fontsize=10, loc="left")
    clock = ax.set_title("t = 00.00 s", fontsize=10, loc="right")
    fig.legend(
        handles=[
            Line2D([], [], color="0.7", ls="--", label="start"),
            Line2D([], [], color="#7fb3d5", ls=":", label="goal" if plan.ok else "end (failed)"),
            Line2D([], [], color="#d35400", label="end effector"),
        ],
        loc="outside lower center",  # the constrained layout keeps "x [m]" clear of it
        ncols=3,
        fontsize=9,
        frameon=False,
    )
    moving = [*trails, base, links, joints, centre, clock]
    for artist in [*moving, heading]:
        artist.set_animated(True)
    canvas.draw()  # lays the figure out once (room for the longest heading), draws the rest
    fig.set_layout_engine("none")
    clean = canvas.copy_from_bbox(fig.bbox)
    backgrounds = []  # per leg: the static figure with that leg's heading
    for k in range(legs):
        canvas.restore_region(clean)
        heading.set_text(f"leg {k + 1}/{legs}: {leg_method(plan, k)}")
        fig.draw_artist(heading)
        backgrounds.append(canvas.copy_from_bbox(fig.bbox))

    size = canvas.get_width_height()
    images = []
    for t, i in zip(times, index, strict=True):
        base.set_verts([geo["base_corners"][i]])
        links.set_segments(segments(geo, np.array([i])))
        joints.set_data(geo["proximal"][i, :, 0], geo["proximal"][i, :, 1])
        for a, line in enumerate(trails):
            line.set_data(tips[: i + 1, a, 0], tips[: i + 1, a, 1])
        clock.set_text(f"t = {t:.2f} s")
        canvas.restore_region(backgrounds[int(traj.leg[i])])
        for artist in moving:
            fig.draw_artist(artist)
        rgba = Image.frombuffer("RGBA", size, canvas.buffer_rgba(), "raw", "RGBA", 0, 1)
        images.append(rgba.convert("RGB"))
    # one palette for all frames, taken from the last one (it has every colour: trail, arm)
    palette = images[-1].quantize(colors=64, method=Image.Quantize.MEDIANCUT)
    frames_p = [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in images]
    buf = io.BytesIO()
    frames_p[0].save(
        buf,
        format="GIF",
        save_all=True,
        append_images=frames_p[1:],
        duration=durations,
        loop=0,
        optimize=False,
    )
    return buf.getvalue()
