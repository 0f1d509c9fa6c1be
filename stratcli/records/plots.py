"""Plots (PNG, SVG or PDF) and an animated GIF of a planned motion, returned as bytes.

* `configuration.png`: every coordinate against time.
* `controls.png`: every input against time; an input that is off on a leg is drawn at zero
  there and labelled "off".
* `stroboscope.png` (manipulators): the robot drawn at regular instants of each leg, fading
  from light to dark, one panel per leg (as the paper's Fig. 7); a URDF robot on the two
  principal planes of its motion (`spatial_figures`).
* `motion.gif` (manipulators): the same motion, animated in real time (or at a stated speed-up).

In the time plots every leg is shaded and labelled with its stratum and method ("leg 2: S1 ·
lie (8 steps)"; a leg too narrow for its label gets "L2" and the full label in a footnote),
switch instants are dashed lines and the steps of a Lie leg thin lines. Axes carry units
(time in s; rad and rad/s for manipulators; a custom model's own units are not known, so its
coordinates are unlabelled and the title says so). A failed plan's figures are stamped FAILED
with the plan's message. Goal markers are not clipped at the axes' edges.

Work is bounded for long plans: with more than `MAX_LABELLED_LEGS` legs the time plots are
shaded but not labelled leg by leg (the title says so), each coordinate is one line instead of
one per leg, and the stroboscope shows at most `MAX_PANELS` evenly spaced legs (named in its
title). A plot that cannot be drawn (non-finite samples of a failed plan) is left
out of the record rather than failing it. Only matplotlib's object-oriented API is used
(`Figure` + the Agg canvas), so the global pyplot state is never touched and no display is
needed. This module draws the time plots and assembles the record (`render_plots`); the
stroboscope and the GIF are drawn by `robot_figures`.
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator, NullLocator
from matplotlib.transforms import blended_transform_factory

from ..sequence import SequencePlan
from .figure_common import (
    FAILED_COLOR,
    FORMATS,
    TICK_STEPS,
    fixed_margins,
    leg_method,
    locked_names,
    message_band,
    save_figure,
    stamp_failed,
    title_lines,
)
from .obstacles import resolved_constraints
from .robot_figures import motion_gif, stroboscope_figure
from .time_marks import corner_key, mark_goals, mark_off_inputs, shade_limits
from .trajectory import Trajectory

__all__ = [
    "FORMATS",
    "accelerations_figure",
    "configuration_figure",
    "controls_figure",
    "draw",
    "plot_makers",
    "render_plots",
    "save_figure",
]

SHADES = ("#e8eef8", "#f8efe2")  # alternate leg backgrounds
SWITCH = {"color": "0.35", "linestyle": "--", "linewidth": 0.9}
LIE_STEP = {"color": "0.55", "linestyle": "-", "linewidth": 0.5}
MAX_LABELLED_LEGS = 20  # more legs: no per-leg labels, goals or "off" marks
WIDTH = 9.0  # in, of the time plots
CORNER_KEY_WIDTH = 1.3  # in, kept clear of the title each side (`time_marks.corner_key`)
LABEL_SIZE = 8.5  # pt, of the leg labels


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------


def _is_manipulator(plan: SequencePlan) -> bool:
    robot = plan.system.robot
    return robot is not None and plan.system.n == robot.n_joints + 1


def _is_spatial(plan: SequencePlan) -> bool:
    """A URDF robot: joints and the attitude's rotation vector (rx, ry, rz) in rad."""
    return getattr(plan.system, "spatial", None) is not None


def _leg_label(plan: SequencePlan, k: int) -> str:
    """ "leg 2: S1 · lie (8 steps)", and the locked coordinates on a second line."""
    locked = locked_names(plan, k)
    head = f"leg {k + 1}: {leg_method(plan, k)}"
    return f"{head}\n{', '.join(locked)} locked" if locked else head


def _fits(text: str, duration: float, total: float) -> bool:
    """Whether a leg label fits over its leg (DejaVu Sans: about 0.6 em per character)."""
    width = max(len(line) for line in text.split("\n")) * LABEL_SIZE * 0.6 / 72
    return width <= duration / total * (WIDTH - 1.1)


def _label_legs(fig: Figure, top: Any, plan: SequencePlan) -> int:
    """Each leg's label above it; too narrow a leg gets "L<k>" and a footnote.

    Returns the number of footnote lines (the bottom margin grows with them)."""
    total = plan.duration or 1.0
    trans = blended_transform_factory(top.transData, top.transAxes)
    notes = []
    for k, leg in enumerate(plan.legs):
        label = _leg_label(plan, k)
        if not _fits(label, leg.duration, total):
            notes.append(f"L{k + 1} = {label.replace(chr(10), ', ')}")
            label = f"L{k + 1}"
        top.text(
            leg.t0 + leg.duration / 2,
            1.04,
            label,
            transform=trans,
            ha="center",
            va="bottom",
            fontsize=LABEL_SIZE,
            color="0.15",
        )
    lines = textwrap.wrap("; ".join(notes), 150)
    if lines:
        fig.text(0.5, 0.01, "\n".join(lines), ha="center", va="bottom", fontsize=8, color="0.25")
    return len(lines)


def _decorate_time_axes(axes: list[Any], plan: SequencePlan) -> int:
    """Shade the legs, label them with stratum and method, dash switches, mark Lie steps.

    Returns the number of footnote lines under the figure."""
    total = plan.duration if plan.legs else 1.0
    steps = [leg.t0 + p.t0 for leg in plan.legs for p in leg.pieces[1:]]
    switches = [sw.time for sw in plan.switches]
    for ax in axes:
        for k, leg in enumerate(plan.legs):
            ax.axvspan(leg.t0, leg.t0 + leg.duration, color=SHADES[k % 2], zorder=0, lw=0)
        x_axis = ax.get_xaxis_transform()
        if steps:
            ax.vlines(steps, 0, 1, transform=x_axis, zorder=1, **LIE_STEP)
        if switches:
            ax.vlines(switches, 0, 1, transform=x_axis, zorder=1, **SWITCH)
        ax.set_xlim(0.0, total)
        # a few round ticks: each tick is three lines and two texts to build and draw, and
        # matplotlib's default (up to ten per axis) was a fifth of a figure's drawing time;
        # time ticks only on the bottom panel, which alone labels them
        bottom = ax is axes[-1]
        ax.xaxis.set_major_locator(
            MaxNLocator(nbins=6, steps=TICK_STEPS) if bottom else NullLocator()
        )
        ax.yaxis.set_major_locator(MaxNLocator(nbins=4, steps=TICK_STEPS))
        ax.grid(True, axis="y", color="0.85", linewidth=0.6)
        ax.tick_params(labelsize=8)
    notes = 0
    if len(plan.legs) <= MAX_LABELLED_LEGS:
        notes = _label_legs(axes[0].figure, axes[0], plan)
    axes[-1].set_xlabel("time [s]")
    keys = (["- - switch"] if switches else []) + (["│ Lie step"] if steps else [])
    if keys:
        corner_key(axes[0].figure, "   ".join(keys), "top left", "0.3")
    return notes


PANEL_HEIGHT = 1.25  # in, a time series' panel (its gaps included)


def _y_label(name: str, unit: str | None, height: float) -> tuple[str, float]:
    """A panel's y label and its font size: on one line where it fits the panel's height,
    else the name over its unit, smaller where a line still does not fit (a URDF's joint
    names, `u_shoulder_pitch [rad/s]`, ran into the next panel's label)."""
    label = f"{name} [{unit}]" if unit else name
    fits = height * 72.0 / (9 * 0.62)  # characters of 9 pt along the panel, roughly
    if len(label) <= fits:
        return label, 9.0
    lines = [name, f"[{unit}]"] if unit else [name]
    longest = max(len(line) for line in lines)
    return "\n".join(lines), max(6.0, min(9.0, 9.0 * fits / longest))


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
    fig = Figure(figsize=(WIDTH, 1.05 + PANEL_HEIGHT * rows))
    axes = list(np.atleast_1d(fig.subplots(rows, 1, squeeze=False)[:, 0]))
    colors = [f"C{i % 10}" for i in range(rows)]
    labelled = len(plan.legs) <= MAX_LABELLED_LEGS
    for i, (ax, name) in enumerate(zip(axes, names, strict=True)):
        if labelled:
            for k in range(len(plan.legs)):
                s = traj.leg_slice(k)
                ax.plot(traj.t[s], values[s, i], color=colors[i], linewidth=1.6, zorder=3)
        else:  # one line; a switch instant is sampled twice, so jumps still show
            ax.plot(traj.t, values[:, i], color=colors[i], linewidth=1.2, zorder=3)
        text, size = _y_label(name, unit, PANEL_HEIGHT)
        ax.set_ylabel(text, fontsize=size)
    notes = _decorate_time_axes(axes, plan)
    two_line = labelled and any(plan.legs[k].locked for k in range(len(plan.legs)))
    band = message_band(plan, WIDTH)  # a failed plan's message, under the plots
    if unit is None:
        title += " (custom model: values in its own units)"
    if not labelled:
        title = f"{title} ({len(plan.legs)} legs; leg labels omitted above {MAX_LABELLED_LEGS})"
    if not plan.ok:
        title += " — FAILED"
    # between the corner keys ("- - switch", "○ goal of the leg"), which a long scenario's
    # name and "— FAILED" ran over
    title = title_lines(title, WIDTH - 2 * CORNER_KEY_WIDTH)
    extra = 0.2 * title.count("\n")
    fig.set_figheight(
        fig.get_figheight() + 0.15 * notes + (0.15 if two_line else 0.0) + band + extra
    )
    fixed_margins(
        fig,
        left=0.85,
        right=0.2,  # the last goal marker sits on the right edge
        top=0.75 + (0.15 if two_line else 0.0) + extra,  # title, key line, leg labels
        bottom=0.5 + 0.15 * notes + band,
        hspace=0.12,
    )
    if labelled and kind == "configuration":
        mark_goals(plan, axes)
    elif labelled:
        mark_off_inputs(plan, axes)
    if plan.constraints is not None:
        shade_limits(plan, traj, axes, kind)
    _widen_flat(axes, values)
    fig.suptitle(title, fontsize=11, fontweight="bold", color="k" if plan.ok else FAILED_COLOR)
    stamp_failed(fig, plan, band_at=0.15 * max(notes, 1) + 0.16 if band else None)
    return fig


FLAT = 1e-9  # a curve whose values differ by less than this (relative) is drawn as flat


def _widen_flat(axes: list[Any], values: np.ndarray) -> None:
    """A curve constant but for rounding (q1 of a leg that locks it: 1e-14) on an axis wide
    enough to show it flat: matplotlib fits the axis to the noise and draws ±2e-14 as a
    full-height swing, its scale only in a small offset label."""
    for i, ax in enumerate(axes):
        finite = values[:, i][np.isfinite(values[:, i])]
        if not finite.size:
            continue
        low, high = float(finite.min()), float(finite.max())
        centre = 0.5 * (low + high)
        if high - low > FLAT * max(1.0, abs(centre)):
            continue
        half = max(0.1 * abs(centre), 1.0)  # whole ticks: nothing moves here
        bottom, top = ax.get_ylim()
        ax.set_ylim(min(bottom, centre - half), max(top, centre + half))
        ax.ticklabel_format(axis="y", useOffset=False)


# --------------------------------------------------------------------------------------------
# Time plots
# --------------------------------------------------------------------------------------------


def configuration_figure(plan: SequencePlan, traj: Trajectory, title: str = "") -> Figure:
    """Every coordinate against time (rad for manipulators)."""
    unit = "rad" if _is_manipulator(plan) or _is_spatial(plan) else None
    head = f"{title}: configuration" if title else "configuration"
    return _time_series(
        plan, traj, traj.q, plan.system.states, unit, head + " vs time", "configuration"
    )


def controls_figure(plan: SequencePlan, traj: Trajectory, title: str = "") -> Figure:
    """Every input against time (rad/s for manipulators: u_i is the speed of joint i)."""
    unit = "rad/s" if _is_manipulator(plan) or _is_spatial(plan) else None
    head = f"{title}: controls" if title else "controls"
    return _time_series(plan, traj, traj.u, plan.system.inputs, unit, head + " vs time", "controls")


def accelerations_figure(plan: SequencePlan, traj: Trajectory, title: str = "") -> Figure:
    """Every input's rate of change against time (rad/s² for manipulators), its
    `max_acceleration` of [constraints] shaded: drawn for plans that have one."""
    unit = "rad/s²" if _is_manipulator(plan) or _is_spatial(plan) else None
    head = f"{title}: accelerations" if title else "accelerations"
    names = tuple(f"du{name.removeprefix('u')}/dt" if name.startswith("u") else f"d{name}/dt"
                  for name in plan.system.inputs)  # fmt: skip
    return _time_series(plan, traj, traj.du, names, unit, head + " vs time", "accelerations")


# --------------------------------------------------------------------------------------------
# Everything at once
# --------------------------------------------------------------------------------------------


def render_plots(
    plan: SequencePlan,
    traj: Trajectory,
    title: str = "",
    animation: bool = True,
    fmt: str = "png",
) -> dict[str, bytes]:
    """All plots of a run as {file name: bytes}.

    `configuration.<fmt>` and `controls.<fmt>` always; `stroboscope.<fmt>` and (when
    `animation`) `motion.gif` for manipulator models. `fmt` is png, svg or pdf (the animation
    is a GIF whatever it is). A plan without legs gives no files, and a plot that cannot be
    drawn (e.g. NaN samples of a failed plan) is left out.
    """
    return draw(plot_makers(plan, traj, title, animation, fmt))


def plot_makers(
    plan: SequencePlan, traj: Trajectory, title: str, animation: bool, fmt: str
) -> dict[str, Callable[[], bytes]]:
    """{file name: a function drawing it} of `render_plots` (`drawing` shares them out)."""
    if fmt not in FORMATS:
        raise ValueError(f"figure format must be one of {', '.join(FORMATS)}, not {fmt!r}")
    if not plan.legs or traj.size == 0:
        return {}
    makers = {
        f"configuration.{fmt}": lambda: save_figure(configuration_figure(plan, traj, title), fmt),
        f"controls.{fmt}": lambda: save_figure(controls_figure(plan, traj, title), fmt),
    }
    if plan.constraints is not None and resolved_constraints(plan).max_acceleration is not None:
        makers[f"accelerations.{fmt}"] = lambda: save_figure(
            accelerations_figure(plan, traj, title), fmt
        )
    if _is_manipulator(plan):
        makers[f"stroboscope.{fmt}"] = lambda: save_figure(
            stroboscope_figure(plan, traj, title), fmt
        )
        if animation:
            makers["motion.gif"] = lambda: motion_gif(plan, traj, title)
    elif _is_spatial(plan):  # a URDF robot: on the principal planes of its motion
        from .spatial_figures import spatial_stroboscope_figure

        makers[f"stroboscope.{fmt}"] = lambda: save_figure(
            spatial_stroboscope_figure(plan, traj, title), fmt
        )
    return makers


def draw(makers: dict[str, Callable[[], bytes]]) -> dict[str, bytes]:
    """Run `makers`; a plot that cannot be drawn (non-finite or absurd samples) is left out."""
    files = {}
    for name, make in makers.items():
        try:
            with np.errstate(all="ignore"):
                files[name] = make()
        except (ValueError, ArithmeticError):  # non-finite or absurd samples: no such plot
            continue
    return files
