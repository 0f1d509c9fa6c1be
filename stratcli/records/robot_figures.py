"""Drawings of a planar manipulator's motion: the stroboscope figure and the animated GIF.

`stroboscope_figure` draws the robot at regular instants of each leg, fading from light to
dark, one panel per leg (as the paper's Fig. 7; at most `MAX_PANELS` evenly spaced legs), and
`motion_gif` animates the same motion, returned as GIF bytes. Both draw poses in the inertial
frame with `_draw_poses` (base, links and joints as batched collections) from
`trajectory.world_geometry`. `render_plots` in `plots` puts them in a run record.
"""

from __future__ import annotations

import io

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.colors import to_rgb, to_rgba
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from ..sequence import SequencePlan
from .trajectory import Trajectory, world_geometry

__all__ = ["DPI", "locked_names", "motion_gif", "stroboscope_figure"]

DPI = 110
ARM_DARK = np.array([0.05, 0.16, 0.40])  # the last snapshot of a leg
ARM_LIGHT = np.array([0.72, 0.80, 0.92])  # the first one
BASE_FACE = "#9aa5b1"
MAX_PANELS = 12  # stroboscope panels


def locked_names(plan: SequencePlan, k: int) -> list[str]:
    """Names of the coordinates locked on leg `k`."""
    return [plan.system.states[i] for i in plan.legs[k].locked]


def _limits(geo: dict[str, np.ndarray], margin: float = 0.25) -> tuple[tuple, tuple]:
    pts = np.concatenate(
        [
            geo["base_corners"].reshape(-1, 2),
            geo["proximal"].reshape(-1, 2),
            geo["distal"].reshape(-1, 2),
        ]
    )
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if not pts.size:
        raise ValueError("no finite configuration to draw")
    lo, hi = pts.min(axis=0) - margin, pts.max(axis=0) + margin
    return (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1]))


def _segments(geo: dict[str, np.ndarray], idx: np.ndarray) -> np.ndarray:
    """Link segments of the samples idx, shape (len(idx) * k, 2, 2)."""
    seg = np.stack((geo["proximal"][idx], geo["distal"][idx]), axis=-2)
    return seg.reshape(-1, 2, 2)


def _tips(geo: dict[str, np.ndarray]) -> np.ndarray:
    """End-effector position of each arm, (N, n_arms, 2)."""
    arm = geo["arm_of_link"]
    last = [int(np.flatnonzero(arm == a)[-1]) for a in range(int(arm.max()) + 1)]
    return geo["distal"][:, last]


def _draw_poses(
    ax,
    geo: dict[str, np.ndarray],
    idx: np.ndarray,
    colors: list,
    lw: float,
    zorder: float,
    linestyle: str = "-",
    face: str | None = None,
    face_alpha: float = 0.5,
    edge_alpha: float = 1.0,
) -> None:
    """Draw the poses of samples `idx` (one colour each) as three batched collections."""
    idx = np.atleast_1d(idx)
    k = geo["proximal"].shape[1]
    faces = "none" if face is None else [(*to_rgb(face), face_alpha)] * idx.size
    ax.add_collection(
        PolyCollection(
            geo["base_corners"][idx],
            facecolors=faces,
            edgecolors=[(*to_rgb(c), edge_alpha) for c in colors],
            linewidths=lw * 0.6,
            linestyles=linestyle,
            zorder=zorder,
        )
    )
    ax.add_collection(
        LineCollection(
            _segments(geo, idx),
            colors=np.repeat(np.asarray([to_rgba(c) for c in colors]), k, axis=0),
            linewidths=lw,
            linestyles=linestyle,
            zorder=zorder + 0.1,
            capstyle="round",
        )
    )
    joints = geo["proximal"][idx].reshape(-1, 2)
    ax.scatter(
        joints[:, 0],
        joints[:, 1],
        s=(lw + 1.2) ** 2,
        c=np.repeat(np.asarray([to_rgba(c) for c in colors]), k, axis=0),
        zorder=zorder + 0.2,
        linewidths=0,
    )


def stroboscope_figure(
    plan: SequencePlan, traj: Trajectory, title: str = "", snapshots: int = 10
) -> Figure:
    """The manipulator at `snapshots` instants of each leg, light to dark, one panel per leg.

    With more than `MAX_PANELS` legs, only `MAX_PANELS` evenly spaced legs (the first and the
    last among them) get a panel; the title names how many are shown.
    """
    robot = plan.system.robot
    geo = world_geometry(robot, traj.q)
    xlim, ylim = _limits(geo)
    shown = np.unique(np.linspace(0, len(plan.legs) - 1, MAX_PANELS).round().astype(int))
    if len(plan.legs) <= MAX_PANELS:
        shown = np.arange(len(plan.legs))
    legs = len(shown)
    cols = min(legs, 4)
    rows = -(-legs // cols)
    span = max(xlim[1] - xlim[0], 1e-9) / max(ylim[1] - ylim[0], 1e-9)
    panel_w = min(4.0, 11.0 / cols) if span < 1.6 else min(5.5, 11.0 / cols)
    panel_h = float(np.clip(panel_w / span, 2.0, 4.5))
    fig = Figure(
        figsize=(panel_w * cols + 0.4, panel_h * rows + 1.4), layout="constrained", dpi=DPI
    )
    axes = fig.subplots(rows, cols, squeeze=False, sharex=True, sharey=True)
    tips = _tips(geo)
    for panel in range(rows * cols):
        ax = axes[panel // cols, panel % cols]
        if panel >= legs:
            ax.set_visible(False)
            continue
        k = int(shown[panel])
        leg = plan.legs[k]
        s = traj.leg_slice(k)
        idx = np.unique(np.linspace(s.start, s.stop - 1, snapshots).round().astype(int))
        w = np.linspace(0.0, 1.0, len(idx))[1:-1]
        fading = [tuple((1 - x) * ARM_LIGHT + x * ARM_DARK) for x in w]
        _draw_poses(ax, geo, idx[1:-1], fading, lw=1.2, zorder=2, edge_alpha=0.55)
        _draw_poses(ax, geo, idx[:1], ["0.3"], lw=1.7, zorder=4, linestyle="--")
        _draw_poses(ax, geo, idx[-1:], [tuple(ARM_DARK)], lw=2.4, zorder=5, face=BASE_FACE)
        for a in range(tips.shape[1]):
            ax.plot(tips[s, a, 0], tips[s, a, 1], ":", color="#d35400", lw=1.2, zorder=6)
        ax.plot(0, 0, "+", color="k", markersize=7, zorder=7)
        ax.set_xlim(*xlim)
        ax.set_ylim(*ylim)
        ax.set_aspect("equal")
        ax.tick_params(labelsize=7.5)
        ax.grid(True, color="0.9", linewidth=0.5)
        locked = ", ".join(locked_names(plan, k))
        ax.set_title(
            f"leg {k + 1}: {leg.stratum}"
            + (f" ({locked} locked)" if locked else "")
            + f"\nt = {leg.t0:g} to {leg.t0 + leg.duration:g} s",
            fontsize=9,
        )
        if panel % cols == 0:
            ax.set_ylabel("y", fontsize=9)
        if panel // cols == rows - 1 or panel + cols >= legs:
            ax.set_xlabel("x", fontsize=9)
    handles = [
        Line2D([], [], color="0.3", lw=1.7, ls="--", marker="o", ms=3, label="start of leg"),
        Line2D([], [], color=tuple(ARM_DARK), lw=2.4, marker="o", ms=4, label="end of leg"),
        Line2D([], [], color="#d35400", lw=1.2, ls=":", label="end-effector path"),
        Line2D([], [], color="k", marker="+", ls="none", label="system CM (fixed)"),
    ]
    fig.legend(
        handles=handles,
        loc="outside lower center",
        ncols=4,
        fontsize=8,
        frameon=False,
        handlelength=3.2,
    )
    head = f"{title}: stroboscope" if title else "stroboscope"
    if legs < len(plan.legs):
        head += f", {legs} of {len(plan.legs)} legs"
    fig.suptitle(
        f"{head} ({snapshots} instants per leg, light to dark; inertial frame)",
        fontsize=11,
        fontweight="bold",
    )
    return fig


def motion_gif(
    plan: SequencePlan, traj: Trajectory, title: str = "", max_frames: int = 120, fps: int = 25
) -> bytes:
    """An animated GIF of the motion: at most `max_frames` frames at `fps`, looping.

    The static parts (axes, start and goal ghosts) are drawn once and every frame only redraws
    the moving artists over that background (blitting), then Pillow (matplotlib's own image
    dependency) encodes the frames with one shared palette. matplotlib's `PillowWriter` would
    redraw and re-lay-out the whole figure for every frame (about 0.2 s each here, 15 s for a
    3-leg run); this takes well under a second.
    """
    from PIL import Image  # a dependency of matplotlib

    robot = plan.system.robot
    geo = world_geometry(robot, traj.q)
    xlim, ylim = _limits(geo)
    total = float(traj.t[-1] - traj.t[0])
    hold = 8  # frames showing the final pose before the loop restarts
    frames = int(np.clip(round(fps * total), 2, max_frames - hold))
    times = np.linspace(traj.t[0], traj.t[-1], frames)
    # the sample at (or just after) each frame time; a switch instant shows the later leg
    index = np.minimum(np.searchsorted(traj.t, times, side="left"), traj.size - 1)
    index = np.concatenate([index, np.full(hold, traj.size - 1)])
    times = np.concatenate([times, np.full(hold, traj.t[-1])])

    span = max(xlim[1] - xlim[0], 1e-9) / max(ylim[1] - ylim[0], 1e-9)
    fig = Figure(figsize=(4.4, 4.4 / span + 0.8), dpi=80, layout="constrained")
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.set_xlim(*xlim)
    ax.set_ylim(*ylim)
    ax.set_aspect("equal")
    ax.tick_params(labelsize=7)
    ax.grid(True, color="0.9", linewidth=0.5)
    _draw_poses(ax, geo, np.array([0]), ["0.7"], lw=1.3, zorder=1, linestyle="--")
    _draw_poses(ax, geo, np.array([traj.size - 1]), ["#7fb3d5"], lw=1.3, zorder=1, linestyle=":")
    (centre,) = ax.plot(0, 0, "+", color="k", markersize=6, zorder=7)
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
        _segments(geo, np.array([0])), colors=tuple(ARM_DARK), linewidths=2.6, zorder=4
    )
    ax.add_collection(links)
    (joints,) = ax.plot([], [], "o", color=tuple(ARM_DARK), markersize=4, zorder=5)
    legs = len(plan.legs)
    if title:
        fig.suptitle(title, fontsize=9, fontweight="bold")
    widest = max((leg.stratum for leg in plan.legs), key=len)
    heading = ax.set_title(f"leg {legs}/{legs} on {widest}", fontsize=9, loc="left")
    clock = ax.set_title("t = 00.00 s", fontsize=9, loc="right")
    fig.legend(
        handles=[
            Line2D([], [], color="0.7", ls="--", label="start"),
            Line2D([], [], color="#7fb3d5", ls=":", label="goal"),
            Line2D([], [], color="#d35400", label="end effector"),
        ],
        loc="outside lower center",
        ncols=3,
        fontsize=7,
        frameon=False,
    )
    moving = [*trails, base, links, joints, centre, clock]
    for artist in [*moving, heading]:
        artist.set_animated(True)
    canvas.draw()  # lays the figure out once (room for the longest heading), draws the rest
    fig.set_layout_engine("none")
    clean = canvas.copy_from_bbox(fig.bbox)
    backgrounds = []  # per leg: the static figure with that leg's heading
    for k, leg in enumerate(plan.legs):
        canvas.restore_region(clean)
        heading.set_text(f"leg {k + 1}/{legs} on {leg.stratum}")
        fig.draw_artist(heading)
        backgrounds.append(canvas.copy_from_bbox(fig.bbox))

    size = canvas.get_width_height()
    images = []
    for t, i in zip(times, index, strict=True):
        base.set_verts([geo["base_corners"][i]])
        links.set_segments(_segments(geo, np.array([i])))
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
        duration=round(1000 / fps),
        loop=0,
        optimize=False,
    )
    return buf.getvalue()
