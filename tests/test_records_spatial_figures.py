"""Plots of a spatial plan: a stroboscope on the principal planes, times series in rad."""

from pathlib import Path

import pytest

pytest.importorskip("pinocchio")

from stratcli.api import plan_run
from stratcli.records.plots import configuration_figure, render_plots
from stratcli.records.trajectory import sample
from stratcli.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def test_stroboscope_and_units():
    task = load_scenario(ROOT / "scenarios" / "spatial" / "arm3_reorient.toml")
    task = task.with_changes({"planner": {"objective": "newton"}})
    plan = plan_run(task, check=False).result
    traj = sample(plan, samples_per_leg=30)
    files = render_plots(plan, traj, "arm3", animation=False)
    assert set(files) == {"configuration.png", "controls.png", "stroboscope.png"}
    assert files["stroboscope.png"][:4] == b"\x89PNG"
    labels = [ax.get_ylabel() for ax in configuration_figure(plan, traj).axes]
    assert "rx [rad]" in labels and "j1 [rad]" in labels


def test_a_failed_plans_stroboscope_is_stamped_failed_its_message_under_the_panels():
    """configuration.png and controls.png of a failed URDF plan were stamped FAILED, its
    stroboscope looked like a success's."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from stratcli.records.spatial_figures import spatial_stroboscope_figure

    task = load_scenario(ROOT / "scenarios" / "spatial" / "arm3_reorient.toml")
    task = task.with_changes({"planner": {"objective": "newton", "max_iterations": 1}})
    plan = plan_run(task, check=False).result
    assert not plan.ok and plan.message
    traj = sample(plan, samples_per_leg=30)
    fig = spatial_stroboscope_figure(plan, traj, "arm3")
    assert fig._suptitle.get_text().endswith("FAILED")
    texts = [t.get_text() for t in fig.texts]
    assert "FAILED" in texts
    (box,) = [t for t in fig.texts if plan.message[:30] in t.get_text().replace("\n", " ")]
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    top = box.get_bbox_patch().get_window_extent(renderer).y1
    assert all(top < ax.xaxis.label.get_window_extent(renderer).y0 for ax in fig.axes)
    fine = plan_run(task.with_changes({"planner.max_iterations": None}), check=False).result
    ok = spatial_stroboscope_figure(fine, sample(fine, samples_per_leg=30), "arm3")
    assert fine.ok and "FAILED" not in [t.get_text() for t in ok.texts]


def test_the_stroboscopes_axes_say_where_they_point():
    """Its axes read "principal axis 1 [m]", saying nothing of the direction; now the world
    direction of each, and the points are projected on that same direction."""
    import re

    import numpy as np

    from stratcli.records.spatial_figures import _axis_label, spatial_stroboscope_figure

    assert (
        _axis_label(np.array([0.98, 0.05, -0.17]), 0)
        == "principal axis 1: 0.98x−0.17z, from the CoM [m]"
    )
    task = load_scenario(ROOT / "scenarios" / "spatial" / "arm3_reorient.toml")
    plan = plan_run(task.with_changes({"planner": {"objective": "newton"}}), check=False).result
    fig = spatial_stroboscope_figure(plan, sample(plan, samples_per_leg=30), "arm3")
    for label in (fig.axes[0].get_xlabel(), fig.axes[0].get_ylabel(), fig.axes[1].get_ylabel()):
        assert re.fullmatch(
            r"principal axis [123]: −?[0-9.]+[xyz]([+−][0-9.]+[xyz])*, from the CoM \[m\]", label
        )
    # measured from the CoM, as they say (the origin of the poses drawn; the marker sat at
    # minus the drawn points' mean)
    for ax in fig.axes:
        (com,) = [line for line in ax.lines if line.get_label() == "system CoM (fixed)"]
        assert tuple(com.get_xydata()[0]) == (0.0, 0.0)
