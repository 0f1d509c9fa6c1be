"""What every figure of a record shares: formats and saving, leg names, the FAILED stamp."""

from __future__ import annotations

import io
import textwrap

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator

from ..sequence import SequencePlan
from ..wording import method_words

__all__ = [
    "DPI",
    "FAILED_COLOR",
    "FORMATS",
    "LOG_RATIO",
    "TICK_STEPS",
    "failed_message",
    "fixed_margins",
    "leg_method",
    "locked_names",
    "message_band",
    "plain_log_labels",
    "save_figure",
    "stamp_failed",
    "title_lines",
]

DPI = 110
FORMATS = ("png", "svg", "pdf")  # of the figures; the animation is always a GIF
FAILED_COLOR = "#c0392b"  # a failed plan's stamp and title
TICK_STEPS = (1, 2, 2.5, 5, 10)  # tick spacings allowed, times a power of ten
LOG_RATIO = 10.0  # one rule: a log axis whenever the plotted values span more than this
# no creation dates: the same plan gives the same bytes
_METADATA = {"png": {}, "svg": {"Date": None}, "pdf": {"CreationDate": None}}


def locked_names(plan: SequencePlan, k: int) -> list[str]:
    """Names of the coordinates locked on leg `k`."""
    return [plan.system.states[i] for i in plan.legs[k].locked]


def leg_method(plan: SequencePlan, k: int) -> str:
    """Stratum and method of leg `k`: "S1 · newton", "S2 · newton (continuation)" (the
    homotopy reached its goal), "S1 · newton (constrained)" (the constrained search planned
    it), "S1 · lie (8 steps)"."""
    leg = plan.legs[k]
    steps = len(leg.pieces)
    if leg.method == "lie":
        return f"{leg.stratum} · lie ({steps} step{'s' if steps != 1 else ''})"
    return f"{leg.stratum} · {method_words(leg.method, leg.strategy)}"


def fixed_margins(
    fig: Figure,
    left: float,
    right: float,
    top: float,
    bottom: float,
    hspace: float = 0.0,
    wspace: float = 0.0,
) -> None:
    """Place the subplots with margins and gaps given in inches.

    Matplotlib's constrained (or tight) layout measures every text on every draw and took
    half of a record's plotting time (0.30 of 0.60 s CPU for Sim 4 D); the figures here have
    known label sizes, so fixed margins in inches serve as well at any figure size.
    """
    width, height = fig.get_size_inches()
    rows, cols = _grid_shape(fig)
    inner_h = height - top - bottom
    inner_w = width - left - right
    fig.subplots_adjust(
        left=left / width,
        right=1.0 - right / width,
        top=1.0 - top / height,
        bottom=bottom / height,
        hspace=hspace / max((inner_h - hspace * (rows - 1)) / rows, 1e-6),
        wspace=wspace / max((inner_w - wspace * (cols - 1)) / cols, 1e-6),
    )


def _grid_shape(fig: Figure) -> tuple[int, int]:
    for ax in fig.axes:
        spec = ax.get_subplotspec()
        if spec is not None:
            return spec.get_gridspec().get_geometry()
    return 1, 1


def save_figure(fig: Figure, fmt: str = "png") -> bytes:
    """The figure as PNG, SVG or PDF bytes (no creation date in the file).

    PNGs are written from the Agg canvas as RGB (the figures are opaque) by PIL directly:
    matplotlib's own path re-maps the RGBA buffer through a colormap and compresses a fourth
    channel, and took a quarter of a record's plotting time for the same pixels.
    """
    if fmt not in FORMATS:
        raise ValueError(f"figure format must be one of {', '.join(FORMATS)}, not {fmt!r}")
    buf = io.BytesIO()
    canvas = FigureCanvasAgg(fig)
    if fmt != "png":
        from matplotlib import rc_context

        with rc_context({"svg.hashsalt": "stratplan"}):  # SVG ids not random: same bytes
            fig.savefig(buf, format=fmt, dpi=DPI, metadata=_METADATA[fmt])
        return buf.getvalue()
    from PIL import Image  # a dependency of matplotlib

    dpi = fig.dpi
    fig.set_dpi(DPI)  # as savefig does: for this drawing only
    try:
        canvas.draw()
        width, height = canvas.get_width_height(physical=True)
        rgba = Image.frombuffer("RGBA", (width, height), canvas.buffer_rgba(), "raw", "RGBA", 0, 1)
        # zlib level 3 instead of PIL's 6: a tenth of a record's figure time for 7 % more bytes
        rgba.convert("RGB").save(buf, format="png", compress_level=3, dpi=(DPI, DPI))
    finally:
        fig.set_dpi(dpi)
    return buf.getvalue()


def plain_log_labels(axis, minor: bool = True, pattern: str = "{:,.10g}") -> None:
    """A log axis labelled in plain numbers (`pattern`: 1,000, not 10³), with `minor` at 2
    and 5 of each decade too, so that a value can be read off the axis."""
    plain = FuncFormatter(lambda x, _: pattern.format(x))
    axis.set_major_formatter(plain)
    if minor:
        axis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
        axis.set_minor_formatter(plain)


def title_lines(title: str, width: float, fontsize: float = 11) -> str:
    """`title` wrapped to a figure `width` inches wide (bold, `fontsize` pt): a one-panel
    figure's title ran past both edges, "— FAILED" with it."""
    return "\n".join(textwrap.wrap(title, max(int(width * 120 / fontsize), 20)))


def failed_message(plan: SequencePlan, width: float) -> list[str]:
    """A failed plan's message as the lines `stamp_failed` prints in a figure `width` inches
    wide (none for a plan that is ok)."""
    if plan.ok:
        return []
    # (long enough for the message's advice: cut at 300, its "what to try" was lost)
    message = textwrap.shorten(plan.message or "the plan did not reach its goal", 700)
    left = plan.planned_legs - len(plan.legs)
    if left > 0:  # (the figures show the legs planned only: the rest went unsaid)
        first = len(plan.legs) + 1
        legs = f"leg {first}" if left == 1 else f"legs {first} to {plan.planned_legs}"
        message += f" ({legs} of {plan.planned_legs} not planned)"
    return textwrap.wrap(message, int(width * 11))


def message_band(plan: SequencePlan, width: float) -> float:
    """Inches a figure adds at its bottom for `stamp_failed`'s message (0 if ok)."""
    lines = failed_message(plan, width)
    return 0.17 * len(lines) + 0.3 if lines else 0.0


def stamp_failed(fig: Figure, plan: SequencePlan, band_at: float | None = None) -> None:
    """A failed plan: a red diagonal FAILED across the figure and the plan's message, boxed
    over the figure's middle, or with `band_at` (inches from the bottom) in the band the
    figure made for it there (`message_band`), clear of the plots."""
    if plan.ok:
        return
    fig.text(
        0.5,
        0.5,
        "FAILED",
        rotation=24,
        fontsize=64,
        fontweight="bold",
        color=FAILED_COLOR,
        alpha=0.28,
        ha="center",
        va="center",
        zorder=100,
    )
    lines = failed_message(plan, fig.get_figwidth())
    y, va = (0.36, "top") if band_at is None else (band_at / fig.get_figheight(), "bottom")
    fig.text(
        0.5,
        y,
        "\n".join(lines),
        fontsize=9,
        color=FAILED_COLOR,
        ha="center",
        va=va,
        zorder=100,
        bbox={"facecolor": "white", "alpha": 0.7, "edgecolor": FAILED_COLOR, "lw": 0.8},
    )
