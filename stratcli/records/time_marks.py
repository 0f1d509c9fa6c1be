"""What the time plots mark on their axes (`plots`): each leg's goal, the inputs that are off,
the limits of [constraints] shaded with each curve's closest approach, and the small keys in
the figure's corners that say what the marks mean."""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.transforms import blended_transform_factory

from ..sequence import SequencePlan
from .figure_common import FAILED_COLOR
from .obstacles import resolved_constraints
from .trajectory import Trajectory

__all__ = ["corner_key", "mark_goals", "mark_off_inputs", "shade_limits"]

GOAL_COLOR = "#c0392b"


def mark_goals(plan: SequencePlan, axes: list[Any]) -> None:
    """The value each leg was asked to reach, at the leg's end time (never clipped)."""
    ends = [[] for _ in axes]
    for leg in plan.legs:
        for i in leg.targets:
            if not np.isnan(leg.goal[i]):
                ends[i].append((leg.t0 + leg.duration, leg.goal[i]))
    for ax, points in zip(axes, ends, strict=True):
        if not points:
            continue
        t, q = np.array(points).T
        ax.plot(
            t,
            q,
            marker="o",
            markersize=6,
            markerfacecolor="none",
            markeredgecolor=GOAL_COLOR,
            markeredgewidth=1.3,
            linestyle="none",
            zorder=4,
            clip_on=False,  # the last leg's goal sits on the right edge
        )
    if any(ends):
        corner_key(axes[0].figure, "○ goal of the leg", "top right", GOAL_COLOR)


KEY_INSET = 0.015  # a corner key's distance from the figure's edges (fraction of the figure)


def corner_key(fig, text: str, corner: str, color) -> None:
    """A small key in a corner of the time plots ("top left", "top right", "bottom left"),
    inset from the edges so that it is not cut by them."""
    vertical, horizontal = corner.split()
    x = KEY_INSET if horizontal == "left" else 1.0 - KEY_INSET
    y = KEY_INSET if vertical == "bottom" else 1.0 - 1.5 * KEY_INSET
    fig.text(x, y, text, color=color, ha=horizontal, va=vertical, fontsize=8)


def shade_limits(plan: SequencePlan, traj: Trajectory, axes: list[Any], kind: str) -> None:
    """Limits of [constraints] (joint limits on the configuration, rate limits ±max_rate on
    the controls): a dashed line at each limit near the data, the region beyond it shaded,
    and each limited curve's closest approach marked ×."""
    limits = resolved_constraints(plan)
    if kind == "configuration":
        lower, upper, values, what = limits.lower, limits.upper, traj.q, "joint limit"
    elif kind == "controls" and limits.max_rate is not None:
        lower, upper, values, what = -limits.max_rate, limits.max_rate, traj.u, "rate limit"
    elif kind == "accelerations" and limits.max_acceleration is not None:
        bound = limits.max_acceleration
        lower, upper, values, what = -bound, bound, traj.du, "acceleration limit"
    else:
        return
    shown = False
    for i, ax in enumerate(axes):
        lo, hi = lower[i], upper[i]
        if not (np.isfinite(lo) or np.isfinite(hi)):
            continue
        y0, y1 = ax.get_ylim()
        span = y1 - y0
        near = [v for v in (lo, hi) if np.isfinite(v) and y0 - span <= v <= y1 + span]
        if near:  # a limit far from the data would squash the curve: leave it out
            top, bottom = (
                max([y1, *[v + 0.12 * span for v in near]]),
                min([y0, *[v - 0.12 * span for v in near]]),
            )
            for v in near:
                ax.axhline(v, color=FAILED_COLOR, lw=0.9, ls="--", zorder=2)
                band = (v, top) if v == hi else (bottom, v)
                ax.axhspan(*band, color=FAILED_COLOR, alpha=0.12, lw=0, zorder=1)
            ax.set_ylim(bottom, top)
            shown = True
        far = [f"{v:g}" for v in (lo, hi) if np.isfinite(v) and v not in near]
        if far:  # said, not drawn: a limit with no mark read as no limit
            # at the edge it lies beyond, unless that one is drawn: at the top, it hid the
            # upper limit's line where only the lower one was far
            low = np.isfinite(lo) and lo not in near and not (np.isfinite(hi) and hi not in near)
            y, va = (0.04, "bottom") if low and hi in near else (0.96, "top")
            ax.text(
                0.995, y, f"{what} {' and '.join(far)} (off the axis)", transform=ax.transAxes,
                ha="right", va=va, fontsize=7, color=FAILED_COLOR, zorder=6,
                bbox={"facecolor": "white", "alpha": 0.7, "edgecolor": "none", "pad": 1},
            )  # fmt: skip
        room = np.minimum(values[:, i] - lo, hi - values[:, i])
        if np.isfinite(room).any():
            k = int(np.nanargmin(room))
            ax.plot(traj.t[k], values[k, i], "x", color=FAILED_COLOR, ms=6, mew=1.4, zorder=5)
            shown = True
    if shown:
        key = f"- - {what} (shaded beyond it); × closest approach"
        corner_key(axes[0].figure, key, "bottom left", FAILED_COLOR)


def mark_off_inputs(plan: SequencePlan, axes: list[Any]) -> None:
    """Write "off" over the legs on which an input is not active (it is zero there)."""
    for i, ax in enumerate(axes):
        ax.axhline(0.0, color="0.55", linewidth=0.7, zorder=2)
        lo, hi = ax.get_ylim()
        zero = (0.0 - lo) / (hi - lo) if hi > lo else 0.5
        height = 0.8 if zero < 0.5 else 0.2  # away from the zero line the input sits on
        trans = blended_transform_factory(ax.transData, ax.transAxes)
        for leg in plan.legs:
            if i in leg.active:
                continue
            ax.text(
                leg.t0 + leg.duration / 2,
                height,
                "off (u = 0)",
                transform=trans,
                ha="center",
                va="center",
                fontsize=8,
                style="italic",
                color="0.35",
            )
