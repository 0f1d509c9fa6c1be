"""Plots of a run: manipulators, custom models, long plans."""

from __future__ import annotations

import io

import numpy as np
from PIL import Image

import stratcli.simulate as simulate
from stratcli.records.plots import render_plots

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def test_plots_of_a_manipulator(one_arm):
    files = render_plots(one_arm.plan, one_arm.traj, one_arm.name)
    assert set(files) == {"configuration.png", "controls.png", "stroboscope.png", "motion.gif"}
    for name in ("configuration.png", "controls.png", "stroboscope.png"):
        data = files[name]
        assert data.startswith(PNG_MAGIC) and 20_000 < len(data) < 2_000_000
        width, height = Image.open(io.BytesIO(data)).size
        assert 600 <= width <= 2000 and 300 <= height <= 2000
    gif = Image.open(io.BytesIO(files["motion.gif"]))
    assert files["motion.gif"][:6] == b"GIF89a" and len(files["motion.gif"]) < 2_000_000
    assert 10 <= gif.n_frames <= 120 and gif.info.get("loop") == 0
    gif.seek(0)
    first = np.asarray(gif.convert("RGB")).copy()
    gif.seek(gif.n_frames // 2)
    assert not np.array_equal(first, np.asarray(gif.convert("RGB")))  # it moves


def test_plots_without_animation(two_arm):
    files = render_plots(two_arm.plan, two_arm.traj, two_arm.name, animation=False)
    assert set(files) == {"configuration.png", "controls.png", "stroboscope.png"}
    assert all(data.startswith(PNG_MAGIC) for data in files.values())


def test_plots_of_a_custom_model(biped):
    files = render_plots(biped.plan, biped.traj, biped.name)
    assert set(files) == {"configuration.png", "controls.png"}
    for data in files.values():
        assert data.startswith(PNG_MAGIC) and len(data) > 20_000


def test_long_plans_are_plotted_without_per_leg_labels(unicycle_plan, monkeypatch):
    import stratcli.records.plots as plots

    _, plan = unicycle_plan
    traj = simulate.sample(plan, 20)
    monkeypatch.setattr(plots, "MAX_LABELLED_LEGS", 0)
    fig = plots.configuration_figure(plan, traj, "t")
    assert "leg labels omitted" in fig._suptitle.get_text()
    assert len(fig.axes[0].texts) == 0
