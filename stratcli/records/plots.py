"""PNG plots and an animated GIF of a planned motion, returned as bytes.

* `configuration.png`: every coordinate against time.
* `controls.png`: every input against time; an input that is off on a leg is drawn at zero
  there and labelled "off".
* `stroboscope.png` (manipulators): the robot drawn at regular instants of each leg, fading
  from light to dark, one panel per leg (as the paper's Fig. 7).
* `motion.gif` (manipulators): the same motion, animated.

In the time plots every leg is shaded and labelled with its stratum, and switch instants are
dashed lines. Work is bounded for long plans: with more than `MAX_LABELLED_LEGS` legs the time
plots are shaded but not labelled leg by leg (the title says so), each coordinate is one line
instead of one per leg, and the stroboscope shows at most `MAX_PANELS` evenly spaced legs
(named in its title). A plot that cannot be drawn (non-finite samples of a failed plan) is left
out of the record rather than failing it. Only matplotlib's object-oriented API is used
(`Figure` + the Agg canvas), so the global pyplot state is never touched and no display is
needed. This module draws the time plots and assembles the record (`render_plots`); the
stroboscope and the GIF are drawn by `robot_figures`.
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.transforms import blended_transform_factory

from ..sequence import SequencePlan
from .robot_figures import DPI, locked_names, motion_gif, stroboscope_figure
from .trajectory import Trajectory

__all__ = ["configuration_figure", "controls_figure", "render_plots"]

SHADES = ("#e8eef8", "#f8efe2")  # alternate leg backgrounds
SWITCH = {"color": "0.35", "linestyle": "--", "linewidth": 0.9}
GOAL_COLOR = "#c0392b"
MAX_LABELLED_LEGS = 20  # more legs: no per-leg labels, goals or "off" marks


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------


def _png(fig: Figure) -> bytes:
    buf = io.BytesIO()
    FigureCanvasAgg(fig)
    fig.savefig(buf, format="png", dpi=DPI)
    return buf.getvalue()


def _is_manipulator(plan: SequencePlan) -> bool:
    robot = plan.system.robot
    return robot is not None and plan.system.n == robot.n_joints + 1


def _leg_label(plan: SequencePlan, k: int) -> str:
    locked = locked_names(plan, k)
    head = f"leg {k + 1}: {plan.legs[k].stratum}"
    if not locked:
        return head
    return f"{head}\n{', '.join(locked)} locked"


def _decorate_time_axes(axes: list[Any], plan: SequencePlan) -> None:
    """Shade the legs, label them with their stratum at the top, dash the switches."""
    total = plan.duration if plan.legs else 1.0
    labelled = len(plan.legs) <= MAX_LABELLED_LEGS
    for k, leg in enumerate(plan.legs):
        for ax in axes:
            ax.axvspan(leg.t0, leg.t0 + leg.duration, color=SHADES[k % 2], zorder=0, lw=0)
        if not labelled:
            continue
        top = axes[0]
        trans = blended_transform_factory(top.transData, top.transAxes)
        top.text(
            leg.t0 + leg.duration / 2,
            1.04,
            _leg_label(plan, k),
            transform=trans,
            ha="center",
            va="bottom",
            fontsize=8.5,
            color="0.15",
        )
    for sw in plan.switches:
        for ax in axes:
            ax.axvline(sw.time, **SWITCH, zorder=1)
    for ax in axes:
        ax.set_xlim(0.0, total)
        ax.grid(True, axis="y", color="0.85", linewidth=0.6)
        ax.tick_params(labelsize=8)
    axes[-1].set_xlabel("time [s]")


def _time_series(
    plan: SequencePlan,
    traj: Trajectory,
    values: np.ndarray,
    names: tuple[str, ...],
    unit: str | None,
    title: str,
    kind: str,
) -> Figure:
    rows = len(names)
    fig = Figure(figsize=(9.0, 1.05 + 1.25 * rows), layout="constrained")
    axes = list(np.atleast_1d(fig.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]))
    colors = [f"C{i % 10}" for i in range(rows)]
    labelled = len(plan.legs) <= MAX_LABELLED_LEGS
    for i, (ax, name) in enumerate(zip(axes, names, strict=True)):
        if labelled:
            for k in range(len(plan.legs)):
                s = traj.leg_slice(k)
                ax.plot(traj.t[s], values[s, i], color=colors[i], linewidth=1.6, zorder=3)
        else:  # one line; a switch instant is sampled twice, so jumps still show
            ax.plot(traj.t, values[:, i], color=colors[i], linewidth=1.2, zorder=3)
        ax.set_ylabel(f"{name} [{unit}]" if unit else name, fontsize=9)
    _decorate_time_axes(axes, plan)
    if not labelled:
        title = f"{title} ({len(plan.legs)} legs; leg labels omitted above {MAX_LABELLED_LEGS})"
    elif kind == "configuration":
        _mark_goals(plan, axes)
    else:
        _mark_off_inputs(plan, axes)
    fig.suptitle(title, fontsize=11, fontweight="bold")
    return fig


def _mark_goals(plan: SequencePlan, axes: list[Any]) -> None:
    """The value each leg was asked to reach, at the leg's end time."""
    shown = False
    for leg in plan.legs:
        for i in leg.targets:
            if np.isnan(leg.goal[i]):
                continue
            axes[i].plot(
                leg.t0 + leg.duration,
                leg.goal[i],
                marker="o",
                markersize=6,
                markerfacecolor="none",
                markeredgecolor=GOAL_COLOR,
                markeredgewidth=1.3,
                linestyle="none",
                zorder=4,
            )
            shown = True
    if shown:
        axes[0].figure.text(
            0.995, 0.995, "○ goal of the leg", color=GOAL_COLOR, ha="right", va="top", fontsize=8
        )


def _mark_off_inputs(plan: SequencePlan, axes: list[Any]) -> None:
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


# --------------------------------------------------------------------------------------------
# Time plots
# --------------------------------------------------------------------------------------------


def configuration_figure(plan: SequencePlan, traj: Trajectory, title: str = "") -> Figure:
    """Every coordinate against time (rad for manipulators)."""
    unit = "rad" if _is_manipulator(plan) else None
    head = f"{title}: configuration" if title else "configuration"
    return _time_series(
        plan, traj, traj.q, plan.system.states, unit, head + " vs time", "configuration"
    )


def controls_figure(plan: SequencePlan, traj: Trajectory, title: str = "") -> Figure:
    """Every input against time (rad/s for manipulators: u_i is the speed of joint i)."""
    unit = "rad/s" if _is_manipulator(plan) else None
    head = f"{title}: controls" if title else "controls"
    return _time_series(plan, traj, traj.u, plan.system.inputs, unit, head + " vs time", "controls")


# --------------------------------------------------------------------------------------------
# Everything at once
# --------------------------------------------------------------------------------------------


def render_plots(
    plan: SequencePlan, traj: Trajectory, title: str = "", animation: bool = True
) -> dict[str, bytes]:
    """All plots of a run as {file name: bytes}.

    `configuration.png` and `controls.png` always; `stroboscope.png` and (when `animation`)
    `motion.gif` for manipulator models. A plan without legs gives no files, and a plot that
    cannot be drawn (e.g. NaN samples of a failed plan) is left out.
    """
    if not plan.legs or traj.size == 0:
        return {}
    makers = {
        "configuration.png": lambda: _png(configuration_figure(plan, traj, title)),
        "controls.png": lambda: _png(controls_figure(plan, traj, title)),
    }
    if _is_manipulator(plan):
        makers["stroboscope.png"] = lambda: _png(stroboscope_figure(plan, traj, title))
        if animation:
            makers["motion.gif"] = lambda: motion_gif(plan, traj, title)
    files = {}
    for name, make in makers.items():
        try:
            with np.errstate(all="ignore"):
                files[name] = make()
        except (ValueError, ArithmeticError):  # non-finite or absurd samples: no such plot
            continue
    return files
