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
