"""Saving figures: the format's bytes, at the records' resolution, the figure left as it was."""

from __future__ import annotations

import io

import numpy as np
import pytest
from matplotlib.figure import Figure
from PIL import Image

from stratcli.records.figure_common import DPI, save_figure


def _figure() -> Figure:
    fig = Figure(figsize=(4.0, 3.0), dpi=72)
    ax = fig.add_subplot()
    ax.plot(np.linspace(0, 1, 50), np.linspace(0, 1, 50) ** 2)
    return fig


def test_a_png_is_drawn_at_the_records_resolution_and_the_figure_keeps_its_own():
    fig = _figure()
    png = save_figure(fig)
    image = Image.open(io.BytesIO(png))
    assert image.mode == "RGB" and image.size == (round(4.0 * DPI), round(3.0 * DPI))
    assert fig.dpi == 72  # what the caller set, as savefig leaves it
    assert save_figure(fig) == png  # the same bytes again


@pytest.mark.parametrize(("fmt", "head"), [("svg", b"<?xml"), ("pdf", b"%PDF")])
def test_vector_formats_carry_no_creation_date(fmt, head):
    one, two = save_figure(_figure(), fmt), save_figure(_figure(), fmt)
    assert one.startswith(head) and one == two
