"""`ranking.png` (or .svg/.pdf): the bar chart of a comparison, one bar per sequence.

Apart from `comparison` (the documents) so that planning never imports matplotlib: the bars
are drawn from `comparison.json` alone.
"""

from __future__ import annotations

import math
import textwrap
from typing import Any

from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from matplotlib.transforms import offset_copy

from ..comparison_values import CRITERION_LABELS
from .figure_common import LOG_RATIO, fixed_margins, plain_log_labels, save_figure

__all__ = ["ranking_figure", "ranking_png"]

REASON_CHARS = 100  # of a failed sequence's reason beside its row (the bars' width holds it)


def _short(x: float) -> str:
    return f"{x:,.0f}" if abs(x) >= 1000 else f"{x:.4g}"


BEST_COLOR = "#2e7d32"
OTHER_COLOR = "#4a6fa5"
FAILED_COLOR = "#c0392b"
LABEL_SIZE = 7.5  # pt, of the sequences' labels
VALUE_SIZE = 7.5  # pt, of the texts in the axes (`_room` measures those after the bars)
TITLE_SIZE = 10  # pt
RIGHT = 0.15  # inches right of the axes
TICK_SIZE = 10.0  # pt, the value axis's major labels (matplotlib's default)
MINOR_SIZE = 8.0  # pt, its minor labels (2 and 5 of each decade)
BOUNDED_COLOR = "#777777"
HOLLOW = dict(facecolor="none", edgecolor=BOUNDED_COLOR, linestyle="--", linewidth=0.8)
BAR_HEIGHT = 0.7  # of a row's 1
LABEL_GAP = 7.0  # pt between a label and the axes (where a tick's length and pad put it)
# units of the ranking quantities for the presets and physical planar models (rad, rad/s)
_UNITS = {"energy": "rad²/s", "peak-control": "rad/s", "excursion": "rad", "duration": "s"}
_KEYS = {
    "energy": "energy_equal_time",
    "peak-control": "peak_control",
    "excursion": "excursion",
    "duration": "duration",
}


def _shared_words(reasons: list[str]) -> str:
    """The words every failure reason starts with, where they differ after them and the
    shared part is long enough to hide what differs once clipped ("the constrained search
    stalled on leg 1: the joint limits of" q1 / q3 ...): "" otherwise."""
    distinct = list(dict.fromkeys(reasons))
    if len(distinct) < 2:
        return ""
    words = [r.split(" ") for r in distinct]
    n = 0
    while all(len(w) > n + 1 for w in words) and len({w[n] for w in words}) == 1:
        n += 1
    while n and not words[0][n - 1].endswith((":", ";", ",")):  # a phrase's end, not "leg"
        n -= 1
    shared = " ".join(words[0][:n])
    return shared if n >= 3 and len(shared) >= 20 else ""


def _clipped(text: str, width: int) -> str:
    """`text`, or its words that fit in `width` characters and an ellipsis (a word cut in
    the middle read as another: "self-collision stil", "an obstacle still v")."""
    if len(text) <= width:
        return text
    return textwrap.shorten(text, width, placeholder=" …")


def _axis_label(doc: dict[str, Any]) -> str:
    criterion = doc["criterion"]
    label = CRITERION_LABELS[criterion]
    if criterion == "energy":
        label += " ∫|u|² dt"
        if doc.get("reference_duration_s") is not None:
            label += f", each path run in {doc['reference_duration_s']:g} s"
    if criterion == "duration" or doc.get("model") != "custom":
        return f"{label} [{_UNITS[criterion]}]"
    return f"{label} (the model's units)"


def ranking_figure(doc: dict[str, Any]) -> Figure:
    """Horizontal bars of the criterion per sequence, best on top and highlighted.

    One rule for the scale: a log axis whenever the largest plotted value exceeds `LOG_RATIO`
    times the smallest (positive) one, as the axis label and a note say; linear otherwise.
    Failed sequences get their reason instead of a bar.
    """
    key = _KEYS[doc["criterion"]]
    rows = doc["rows"]
    if rows and key not in rows[0]:  # a record written before energies were compared so
        key = doc["criterion"]
    labels = [f"{'→'.join(r['sequence'])} · {r['strategy'][:4]}." for r in rows]
    ok = [i for i, r in enumerate(rows) if r["status"] == "ok" and r[key] is not None]
    values = [rows[i][key] for i in ok]
    bounds = _bounds(rows, key, ok)  # rows not searched: their lower bounds, as hollow bars
    plotted = [*values, *bounds.values()]
    positive = [v for v in plotted if v > 0]
    if not positive:  # nothing, or all zero
        ratio = 1.0
    else:  # a zero among positive values: an infinite range
        ratio = max(positive) / min(positive) if len(positive) == len(plotted) else math.inf
    log = ratio > LOG_RATIO
    floor = min(positive) / 2 if log else 0.0
    height = max(3.0, 0.26 * len(rows) + 1.5)
    fig = Figure(figsize=(8.0, height))
    ax = fig.add_subplot()
    best = 0 if doc.get("best") == 0 and 0 in ok else None
    colors = [BEST_COLOR if i == best else OTHER_COLOR for i in ok]
    shown = [max(v, floor) for v in values]  # a zero on a log axis sits at the floor
    # bars as one collection each (36 `barh` rectangles, each added and its limits updated,
    # were a third of the chart's time); the axis limits are set below
    ax.add_collection(_bars(ok, shown, floor, facecolors=colors), autolim=False)
    ends: dict[str, float] = {}  # each text written after a bar: the farthest bar it ends
    for i, v, x in zip(ok, values, shown, strict=True):
        ax.text(x, i, text := f" {_short(v)}", va="center", fontsize=VALUE_SIZE)
        ends[text] = max(x, ends.get(text, x))
    at_least = [max(b, floor) for b in bounds.values()]
    ax.add_collection(_bars(list(bounds), at_least, floor, **HOLLOW), autolim=False)
    for i, b, x in zip(bounds, bounds.values(), at_least, strict=True):
        ax.text(
            x, i, text := f" ≥ {_short(b)}", va="center", fontsize=VALUE_SIZE, color=BOUNDED_COLOR
        )
        ends[text] = max(x, ends.get(text, x))
    reasons = {
        i: r["reason"] or r["status"] for i, r in enumerate(rows) if i not in ok and i not in bounds
    }
    failed = bool(reasons)
    shared = _shared_words(list(reasons.values()))  # said once, in the legend
    for i, reason in reasons.items():
        own = "… " + reason[len(shared) :].lstrip() if shared else reason
        text = " failed: " + _clipped(own, REASON_CHARS)
        ax.text(floor, i, text, va="center", fontsize=VALUE_SIZE, color=FAILED_COLOR)
    if log:
        ax.set_xscale("log")
        plain_log_labels(ax.xaxis, minor=ratio < 1000)  # 2 and 5 too, up to three decades
        ax.tick_params(axis="x", which="minor", labelsize=MINOR_SIZE)
    # the sequences' labels as texts left of the axes where tick labels stand (a tick per row
    # was as costly as the bars)
    ax.set_yticks([])
    beside = offset_copy(ax.get_yaxis_transform(), fig=fig, x=-LABEL_GAP / 72, units="inches")
    for i, label in enumerate(labels):
        ax.text(0.0, i, label, transform=beside, ha="right", va="center", fontsize=LABEL_SIZE)
    ax.set_ylim(len(rows) - 0.5, -0.5)
    ax.set_xlabel(_axis_label(doc) + (" — log scale" if log else ""), fontsize=9)
    ranked_by = CRITERION_LABELS[doc["criterion"]]
    if doc["criterion"] == "energy" and doc.get("reference_duration_s") is not None:
        ranked_by = f"energy at an equal total duration of {doc['reference_duration_s']:g} s"
    ax.grid(axis="x", alpha=0.3)
    left = max(_widths(fig, labels, LABEL_SIZE), default=0.0) + 0.25  # labels, ticks, a gap
    title = f"{doc['scenario']}: {len(rows)} sequences ranked by {ranked_by}"
    title_lines = _wrapped(fig, title, left)
    ax.set_title("\n".join(title_lines), fontsize=TITLE_SIZE)
    if plotted:  # room on the right for the values written after the bars (fixed margins)
        room = _room(fig, ends, fig.get_figwidth() - left - RIGHT, log, floor)
        ax.set_xlim(
            floor if log else 0.0, max(max([*shown, *at_least]) * (1.7 if log else 1.18), room)
        )
        if log:  # the last decade's label (10,000) ran past the figure's right edge
            room = fig.get_figwidth() - left - RIGHT
            ax.set_xlim(floor, _last_label_inside(fig, ax, room, minor=ratio < 1000))
    handles = []
    if best is not None:
        handles.append(Patch(color=BEST_COLOR, label=f"best: {labels[best]}"))
    if len(ok) > (best is not None):
        handles.append(Patch(color=OTHER_COLOR, label="reached the goal"))
    if bounds:
        why = "not searched: ≥ its lower bound, at least the best's value"
        handles.append(Patch(**HOLLOW, label=why))
    if failed:
        from matplotlib.lines import Line2D

        label = f"failed: {_clipped(shared, REASON_CHARS)} …" if shared else "failed"
        handles.append(Line2D([], [], color=FAILED_COLOR, ls="none", marker="$x$", label=label))
    span = "from 0" if math.isinf(ratio) else f"{ratio:,.3g}×"
    relation = ">" if log else "≤"
    scale = f"{'log' if log else 'linear'} scale: values span {span} ({relation} {LOG_RATIO:g}×)"
    if not ok and not bounds:  # (an empty 0-1 axis "spanning 1x")
        scale = "no values: every sequence failed"
    legend = dict(loc="lower center", bbox_to_anchor=(0.5, 0.0), fontsize=8, title=scale)
    legend.update(title_fontsize=8, frameon=False)
    ncols = len(handles)
    drawn = fig.legend(handles=handles, ncols=ncols, **legend)
    if drawn.get_window_extent(fig.canvas.get_renderer()).width > fig.bbox.width:
        drawn.remove()  # one row would be wider than the chart: two columns
        ncols = 2
        fig.legend(handles=handles, ncols=ncols, **legend)
    rows_more = math.ceil(len(handles) / max(ncols, 1)) - 1  # legend rows below the first
    top = 0.32 + 0.17 * (len(title_lines) - 1)
    fixed_margins(fig, left=left, right=RIGHT, top=top, bottom=1.05 + 0.17 * rows_more)
    return fig


def _bars(rows: list[int], ends: list[float], start: float, **style) -> PolyCollection:
    """Horizontal bars from `start` to `ends` at `rows`, 0.7 high, as one artist."""
    h = BAR_HEIGHT / 2
    corners = zip(rows, ends, strict=True)
    boxes = [[(start, i - h), (x, i - h), (x, i + h), (start, i + h)] for i, x in corners]
    return PolyCollection(boxes, closed=True, **style)


def _widths(fig: Figure, texts: list[str], size: float, total=None):
    """Inches of each of `texts` at `size` pt (or `total` of them), measured once
    (constrained layout measured every text of the figure twice: half the chart's time)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.font_manager import FontProperties

    renderer = FigureCanvasAgg(fig).get_renderer()
    font = FontProperties(size=size)
    widths = [renderer.get_text_width_height_descent(t, font, ismath=False)[0] for t in texts]
    inches = [w / fig.dpi for w in widths]
    return inches if total is None else total(inches)


def _room(fig: Figure, ends: dict[str, float], axes: float, log: bool, floor: float) -> float:
    """The least right end of the value axis at which every text of `ends` (text: the value
    it is written after) ends inside the axes, `axes` inches wide."""
    widths = _widths(fig, list(ends), VALUE_SIZE)
    need = 0.0
    for x, width in zip(ends.values(), widths, strict=True):
        stretch = axes / max(axes - width, 0.25 * axes)  # of the axis up to the text's start
        need = max(need, floor * (x / floor) ** stretch if log else x * stretch)
    return need


def _last_label_inside(fig: Figure, ax, axes: float, minor: bool) -> float:
    """The right end of a log value axis `axes` inches wide at which the label of its last
    labelled tick (decades; with `minor` labels, 2 and 5 of each decade too) ends inside the
    figure (centred on its tick, it may stand out of the axes by RIGHT at most); the current
    end if it does already."""
    lo, hi = ax.get_xlim()
    steps = (1.0, 2.0, 5.0) if minor else (1.0,)
    decades = range(math.floor(math.log10(lo)), math.floor(math.log10(hi)) + 1)
    ticks = [m * 10.0**k for k in decades for m in steps if lo <= m * 10.0**k <= hi]
    if not ticks:
        return hi
    last = max(ticks)
    size = TICK_SIZE if math.log10(last).is_integer() else MINOR_SIZE
    half = _widths(fig, [f"{last:,.10g}"], size)[0] / 2 + 0.03  # a small gap
    if (1 - math.log(last / lo) / math.log(hi / lo)) * axes + RIGHT >= half:
        return hi
    share = 1 - (half - RIGHT) / axes  # of the axis up to the tick
    return lo * (last / lo) ** (1 / share)


def _wrapped(fig: Figure, title: str, left: float) -> list[str]:
    """`title` in lines that fit the figure when centred over the axes (a long scenario name
    ran past both edges): the fewest lines whose widest fits."""
    width = fig.get_figwidth()
    centre = (left + width - RIGHT) / 2
    room = 2 * min(centre, width - centre) - 0.1  # inches a centred line may take
    for chars in range(len(title), 19, -5):
        lines = textwrap.wrap(title, chars, break_long_words=True) or [""]
        if max(_widths(fig, lines, TITLE_SIZE)) <= room:
            return lines
    return textwrap.wrap(title, 20, break_long_words=True)


def _bounds(rows: list[dict], key: str, ok: list[int]) -> dict[int, float]:
    """Row -> the lower bound of a sequence that was bounded, not searched (its
    `energy_bound`, or `energy_bound_equal_time` for the equal-duration energy)."""
    name = key.replace("energy", "energy_bound", 1)
    return {
        i: r[name]
        for i, r in enumerate(rows)
        if i not in ok and r["status"] == "bounded" and r.get(name) is not None
    }


def ranking_png(doc: dict[str, Any], fmt: str = "png") -> bytes:
    """`ranking_figure` as PNG (or SVG or PDF) bytes."""
    return save_figure(ranking_figure(doc), fmt)
