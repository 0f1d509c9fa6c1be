"""Plots of a sweep's rows, as image bytes (matplotlib's object-oriented API, no pyplot).

* 2-D grid: `energy_map.png`, the energy of each task over the two coordinates (log colour
  scale; a task that did not reach its goal is a grey cell with a cross), and, when the tasks
  chose their sequence (auto and compare modes), `sequence_map.png`, the chosen sequence of
  strata as categorical colours.
* 1-D grid: `energy.png`, energy against the coordinate (failed tasks marked).
* random tasks (and explicit ones): `energy_hist.png`, a histogram of the energy ratios (to
  the base scenario's reference energy where the tasks keep it, else to the median) with the
  success rate and the counts by status in the title.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from matplotlib.colors import ListedColormap, LogNorm
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from ..wording import counted
from .figure_common import LOG_RATIO, fixed_margins, plain_log_labels, save_figure

FAILED = "0.8"
NO_TASK_OK = "no task ok: sweep.json's failures say why"  # on a plot with no energy to draw
PALETTE = (
    "#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3",
    "#937860", "#da8bc3", "#17becf", "#ccb974", "#64b5cd",
)  # fmt: skip


def _energy(row: dict[str, Any]) -> float:
    e = row.get("energy")
    return float(e) if row.get("status") == "ok" and e is not None else math.nan


def _title(spec: dict[str, Any], rows: dict[int, dict]) -> str:
    done = len(rows)
    ok = sum(r["status"] == "ok" for r in rows.values())
    rate = f"{100 * ok / done:.0f} %" if done else "–"
    # ok: reached every goal, within the [constraints] if any (a failed task may have
    # reached its goals and broken a limit)
    return f"{spec['name']} ({spec['mode']} mode): {ok} of {counted(done, 'task')} ok ({rate})"


def _grid(spec: dict[str, Any], rows: dict[int, dict], value) -> np.ndarray:
    """value(row) of each task as an array (rows: the second axis, columns: the first)."""
    nx, ny = (len(a) for a in spec["axes"])
    out = np.full((ny, nx), np.nan)
    for k, row in rows.items():
        i, j = divmod(k, ny)  # the first axis is the slowest
        out[j, i] = value(row)
    return out


def _log_axis(values: list[float]) -> bool:
    """Whether a map's axis is logarithmic: positive values spanning LOG_RATIO or more (a
    tolerance's 1e-3 and 1e-4 had cells of unequal size reaching below 0 on a linear axis;
    a grid's values a decade apart are log already, where a colour scale asks for more)."""
    v = np.asarray(values, dtype=float)
    return len(v) > 1 and bool(np.all(v > 0)) and v.max() >= LOG_RATIO * v.min()


def _edges(values: list[float]) -> np.ndarray:
    """The cells' edges about `values`: halfway between neighbours (in log on a log axis)."""
    v = np.asarray(values, dtype=float)
    return np.exp(_halfway(np.log(v))) if _log_axis(values) else _halfway(v)


def _halfway(v: np.ndarray) -> np.ndarray:
    """Edges halfway between neighbours, the outer ones as far out (±0.5 about one value)."""
    if len(v) == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5])
    mid = (v[1:] + v[:-1]) / 2
    return np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])


def _failed_marks(ax, spec, rows) -> None:
    xs, ys = spec["axes"]
    ny = len(ys)
    pts = [(xs[k // ny], ys[k % ny]) for k, r in rows.items() if r["status"] != "ok"]
    if pts:
        px, py = zip(*pts, strict=True)
        ax.scatter(px, py, marker="x", s=14, color="0.3", linewidths=0.8, label="not ok")
        ax.legend(loc="upper right", fontsize=7, framealpha=0.8)


def _energy_label(spec: dict[str, Any]) -> str:
    """The energy axis' label, with its unit where the sweep knows it (spec.json's
    `energy_unit`: rad²/s for robots with joints, as the ranking figure says)."""
    unit = spec.get("energy_unit")  # (absent from older sweeps' spec.json)
    return "energy ∫|u|² dt" + (f" [{unit}]" if unit else "")


def _whole(ax_axis, values) -> None:
    """Ticks at whole numbers only, on an axis whose values all are (harmonics, a seed):
    a sweep of planner.basis.harmonics over 2..5 had ticks at 2.5 and 3.5."""
    if len(values) and all(float(v).is_integer() for v in values):
        ax_axis.set_major_locator(MaxNLocator(integer=True))


def _label(spec: dict[str, Any], i: int) -> str:
    """Axis `i`'s key with its unit where the sweep knows it: "goal.q1 (rad)"."""
    units = spec.get("units") or []  # (spec.json of older sweeps has none)
    unit = units[i] if i < len(units) else ""
    return f"{spec['keys'][i]} ({unit})" if unit else spec["keys"][i]


def _finish_map(ax, spec: dict[str, Any], rows: dict[int, dict]) -> None:
    """What both 2-D maps end with: failed tasks marked, axes named (log where `_log_axis`),
    the sweep's title."""
    xs, ys = spec["axes"]
    if _log_axis(xs):
        ax.set_xscale("log")
    if _log_axis(ys):
        ax.set_yscale("log")
    _failed_marks(ax, spec, rows)
    ax.set_xlabel(_label(spec, 0))
    ax.set_ylabel(_label(spec, 1))
    ax.set_title(_title(spec, rows), fontsize=9)


def energy_map(spec: dict[str, Any], rows: dict[int, dict]) -> Figure:
    """Heat map of the energy over a 2-D grid."""
    xs, ys = spec["axes"]
    grid = _grid(spec, rows, _energy)
    fig = Figure(figsize=(7.0, 5.6), layout="constrained")
    ax = fig.add_subplot()
    ax.set_facecolor(FAILED)
    finite = grid[np.isfinite(grid)]
    norm = None  # log where the energies span a decade or more: else one labelled tick (10²)
    if finite.size and finite.min() > 0 and finite.max() >= 10 * finite.min():
        norm = LogNorm(finite.min(), finite.max())
    mesh = ax.pcolormesh(_edges(xs), _edges(ys), np.ma.masked_invalid(grid), norm=norm,
                         cmap="viridis", shading="flat")  # fmt: skip
    fig.colorbar(mesh, ax=ax, label=_energy_label(spec))
    _finish_map(ax, spec, rows)
    return fig


def sequence_map(spec: dict[str, Any], rows: dict[int, dict]) -> Figure:
    """The chosen sequence of strata over a 2-D grid, one colour per sequence."""
    xs, ys = spec["axes"]
    ok = {k: r for k, r in rows.items() if r["status"] == "ok" and r.get("sequence")}
    names = sorted({r["sequence"] for r in ok.values()})
    ny = len(ys)
    codes = np.full((ny, len(xs)), np.nan)
    for k, r in ok.items():
        codes[k % ny, k // ny] = names.index(r["sequence"])
    fig = Figure(figsize=(7.0, 5.6), layout="constrained")
    ax = fig.add_subplot()
    ax.set_facecolor(FAILED)
    colours = [PALETTE[i % len(PALETTE)] for i in range(max(1, len(names)))]
    cmap = ListedColormap(colours)
    ax.pcolormesh(_edges(xs), _edges(ys), np.ma.masked_invalid(codes), cmap=cmap,
                  vmin=-0.5, vmax=len(colours) - 0.5, shading="flat")  # fmt: skip
    counts = {n: sum(r["sequence"] == n for r in ok.values()) for n in names}
    for i, name in enumerate(names):
        ax.scatter([], [], marker="s", s=60, color=colours[i], label=f"({name}): {counts[name]}")
    if names:
        fig.legend(loc="outside right center", fontsize=8, title="best sequence", title_fontsize=8)
    _finish_map(ax, spec, rows)
    return fig


def energy_line(spec: dict[str, Any], rows: dict[int, dict]) -> Figure:
    """Energy against the one coordinate of a 1-D grid."""
    xs = spec["axes"][0]
    fig = Figure(figsize=(7.0, 4.2))
    ax = fig.add_subplot()
    fixed_margins(fig, left=0.85, right=0.25, top=0.45, bottom=0.55)  # one-line title
    e = [(_energy(rows[k]) if k in rows else math.nan) for k in range(len(xs))]
    ax.plot(xs, e, "o-", ms=3)
    bad = [xs[k] for k, r in rows.items() if r["status"] != "ok"]
    for x in bad:
        ax.axvline(x, color="0.6", lw=0.7, ls=":")
    # a log axis only where the energies span more than LOG_RATIO (its labels 10^k, the
    # minor ones unlabelled): a narrow span on a log axis was labelled at its minor ticks
    # (1.05×10²), so wide that the axis' own label fell off the figure
    positive = [v for v in e if v == v and v > 0]
    if positive and max(positive) > LOG_RATIO * min(positive):
        ax.set_yscale("log")
    if not any(v == v for v in e):  # an empty plot otherwise, its y-axis ±0.04
        _no_task_ok(ax, ax.set_yticks)
    ax.set_xlabel(_label(spec, 0))
    _whole(ax.xaxis, xs)
    ax.set_ylabel(_energy_label(spec))
    ax.set_title(_title(spec, rows), fontsize=9)
    return fig


def _no_task_ok(ax, clear_ticks) -> None:
    """A plot with no energy to draw says so (`NO_TASK_OK`), its energy axis unticked."""
    clear_ticks([])
    ax.text(0.5, 0.5, NO_TASK_OK, transform=ax.transAxes, ha="center", va="center",
            fontsize=9, color="0.3")  # fmt: skip


def energy_hist(spec: dict[str, Any], rows: dict[int, dict]) -> Figure:
    """Histogram of energy ratios (to the reference energy, else the median) and success."""
    e = np.array([_energy(r) for r in rows.values()])
    e = e[np.isfinite(e)]
    ref = spec.get("reference_energy")
    label = "reference energy" if ref else "median energy"
    ref = ref or (float(np.median(e)) if e.size else 1.0)
    fig = Figure(figsize=(7.0, 4.2))
    ax = fig.add_subplot()
    # fixed margins (two-line title): a constrained layout measured every text on the draw,
    # and was half of what a sweep's parent process spends after its last task
    fixed_margins(fig, left=0.75, right=0.25, top=0.6, bottom=0.55)
    if e.size:
        ratios = e / ref
        bins = 30
        # a log axis when the ratios span more than LOG_RATIO (as ranking.png), said in the label
        log = ratios.min() > 0 and ratios.max() > LOG_RATIO * ratios.min()
        if log:
            bins = np.geomspace(ratios.min(), ratios.max(), 30)
            ax.set_xscale("log")
            plain_log_labels(ax.xaxis, pattern="{:g}")
        spread = None  # numpy's own range, except for ratios equal but for rounding:
        if not log and np.ptp(ratios) <= 1e-9 * max(1.0, float(np.abs(ratios).max())):
            spread = (ratios.min() - 0.5, ratios.max() + 0.5)  # (it refuses 30 bins there)
        ax.hist(ratios, bins=bins, range=spread, color=PALETTE[0])
        ax.axvline(1.0, color="0.3", ls="--", lw=0.8)
    counts: dict[str, int] = {}
    for r in rows.values():
        counts[r["status"]] = counts.get(r["status"], 0) + 1
    scale = " — log scale" if e.size and log else ""
    if e.size:
        ax.set_xlabel(f"energy / {label} ({ref:.4g}){scale}")
    else:  # no energy to divide: no ratio, no median of 1
        ax.set_xlabel(f"energy / {label}")
        _no_task_ok(ax, ax.set_xticks)
    ax.set_ylabel("tasks")
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))  # counts are whole tasks
    detail = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
    ax.set_title(f"{_title(spec, rows)}\n{detail}", fontsize=9)
    return fig


def sweep_figures(spec: dict[str, Any], rows: dict[int, dict], fmt: str = "png") -> dict:
    """File name -> image bytes of every plot that fits the sweep (see the module)."""
    out: dict[str, bytes] = {}
    if not rows:
        return out
    if spec["kind"] == "grid" and len(spec["axes"]) == 2:
        out[f"energy_map.{fmt}"] = save_figure(energy_map(spec, rows), fmt)
        if spec["mode"] != "legs":
            out[f"sequence_map.{fmt}"] = save_figure(sequence_map(spec, rows), fmt)
    elif spec["kind"] == "grid" and len(spec["axes"]) == 1:
        out[f"energy.{fmt}"] = save_figure(energy_line(spec, rows), fmt)
    else:
        out[f"energy_hist.{fmt}"] = save_figure(energy_hist(spec, rows), fmt)
    return out
