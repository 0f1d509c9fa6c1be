"""Plots of a sweep: which figures a sweep gets, drawn from rows (failed cells included)."""

from __future__ import annotations

import numpy as np

from stratcli.records.sweep_plots import (
    energy_hist,
    energy_line,
    energy_map,
    sequence_map,
    sweep_figures,
)


def _spec(kind="grid", axes=((0.0, 1.0, 2.0), (-1.0, 1.0)), mode="auto"):
    keys = ["goal.q1", "goal.theta"][: len(axes)]
    return {"name": "t", "mode": mode, "kind": kind, "axes": [list(a) for a in axes],
            "keys": keys, "reference_energy": None}  # fmt: skip


def _rows(n):
    rows = {}
    for k in range(n):
        status = "failed" if k == 3 else "ok"
        rows[k] = {"index": k, "status": status, "energy": 10.0 + k, "sequence": "S1,S2"}
    rows[4]["sequence"] = "S3,S1"
    return rows


def test_a_2d_grid_gets_an_energy_map_and_a_sequence_map():
    rows = _rows(6)
    figures = sweep_figures(_spec(), rows)
    assert sorted(figures) == ["energy_map.png", "sequence_map.png"]
    assert all(data.startswith(b"\x89PNG") for data in figures.values())
    mesh = energy_map(_spec(), rows).axes[0].collections[0]
    values = mesh.get_array()
    assert values.count() == 5 and values.max() == 15.0  # the failed cell is masked
    legend = sequence_map(_spec(), rows).legends[0]
    assert sorted(t.get_text() for t in legend.get_texts()) == ["(S1,S2): 4", "(S3,S1): 1"]
    assert sorted(sweep_figures(_spec(mode="legs"), rows)) == ["energy_map.png"]


def test_a_1d_grid_and_random_tasks():
    assert sorted(sweep_figures(_spec(axes=((0.0, 1, 2, 3, 4, 5),)), _rows(6))) == ["energy.png"]
    assert sorted(sweep_figures(_spec(kind="random", axes=()), _rows(6))) == ["energy_hist.png"]
    assert sweep_figures(_spec(), {}) == {}


def test_a_histogram_of_energies_equal_but_for_rounding():
    # the same task at two tolerances: 84.04084130530867 and 84.04084130530865 (numpy
    # refused 30 bins over that range: the sweep ended with a traceback, no results.csv)
    rows = {k: {"index": k, "status": "ok", "energy": e, "sequence": "S3,S1"}
            for k, e in enumerate((84.04084130530867, 84.04084130530865))}  # fmt: skip
    figure = energy_hist(_spec(kind="random", axes=()), rows)
    assert sum(patch.get_height() for patch in figure.axes[0].patches) == 2
    assert sweep_figures(_spec(kind="random", axes=()), rows)["energy_hist.png"].startswith(
        b"\x89PNG"
    )


def test_the_energy_maps_colour_scale_is_log_only_across_a_decade():
    """A log colour bar over 68-172 had one labelled tick (10²): energies within a decade get
    a linear scale, wider ones a log scale."""
    from matplotlib.colors import LogNorm

    narrow = _rows(6)  # energies 10-15
    assert not isinstance(energy_map(_spec(), narrow).axes[0].collections[0].norm, LogNorm)
    wide = {k: {**r, "energy": 10.0**k} for k, r in _rows(6).items()}
    assert isinstance(energy_map(_spec(), wide).axes[0].collections[0].norm, LogNorm)


def test_axes_are_labelled_with_the_units_the_sweep_knows():
    """The axes said goal.q3 and goal.theta, without units (the record's plots have them); a
    spec.json of an older sweep has no units and keeps the bare keys."""
    from stratcli.sweep.keys import unit_of

    spec = {**_spec(), "units": ["rad", "rad"]}
    ax = energy_map(spec, _rows(6)).axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("goal.q1 (rad)", "goal.theta (rad)")
    assert energy_map(_spec(), _rows(6)).axes[0].get_xlabel() == "goal.q1"
    assert [unit_of(k, "preset") for k in ("legs[0].goal.q2", "planner.leg_duration")] == [
        "rad",
        "s",
    ]
    assert unit_of("constraints.obstacles[0].centre[1]", "planar-manipulator") == "m"
    assert unit_of("goal.x", "custom") == "" and unit_of("planner.tolerance", "preset") == "rad"
    assert unit_of("planner.tolerance", "custom") == ""  # (the scenario format: rad, per leg)
    # a per-joint table's entry as its list form (the joint's name named no unit)
    assert unit_of("constraints.joint_limits.q2[0]", "preset") == "rad"
    assert unit_of("constraints.max_rate.u1", "urdf") == "rad/s"


def test_a_1d_grids_energy_axis_is_log_only_across_a_decade_and_keeps_its_label():
    """Energies 101-124 on a log axis had minor labels (1.05×10²) so wide that the axis'
    label was drawn off the figure: within a decade the axis is linear; wider, log in plain
    numbers."""
    spec = _spec(axes=((0.0, 1, 2, 3, 4, 5),))
    narrow = energy_line(spec, _rows(6))  # energies 10-15
    assert narrow.axes[0].get_yscale() == "linear"
    wide = energy_line(spec, {k: {**r, "energy": 10.0**k} for k, r in _rows(6).items()})
    ax = wide.axes[0]
    assert ax.get_yscale() == "log" and ax.get_ylabel() == "energy ∫|u|² dt"
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    for figure in (narrow, wide):  # the axis' label inside the figure, as saved
        canvas = FigureCanvasAgg(figure)
        canvas.draw()
        assert figure.axes[0].yaxis.label.get_window_extent(canvas.get_renderer()).x0 >= 0
    assert "×" not in " ".join(t.get_text() for t in ax.get_yticklabels(minor=True))


def test_a_map_over_a_decade_of_a_setting_has_a_log_axis_of_equal_cells():
    """A grid over planner.tolerance = [1e-3, 1e-4] drew cells of unequal size on a linear
    axis, one reaching below 0: positive values a decade apart or more get a log axis."""
    spec = _spec(axes=((1e-3, 1e-4), (-0.5, 0.0, 0.5)))
    ax = energy_map(spec, _rows(6)).axes[0]
    assert (ax.get_xscale(), ax.get_yscale()) == ("log", "linear")
    edges = ax.collections[0].get_coordinates()[0, :, 0]  # x of the first row of corners
    assert np.all(edges > 0) and np.allclose(np.diff(np.log(edges)), np.log(0.1))
    assert energy_map(_spec(), _rows(6)).axes[0].get_xscale() == "linear"  # 0, 1, 2
    from stratcli.records.sweep_plots import _edges

    # values above 1 whose logs are a decade apart too (the log rule applied twice drew
    # [1.13, 3.92, 5.5e6] about 1.5 and 100)
    assert np.allclose(
        _edges([1.5, 100]), [1.5**1.5 / 100**0.5, (1.5 * 100) ** 0.5, 100**1.5 / 1.5**0.5]
    )


def test_plots_of_a_sweep_with_no_task_ok_say_so_instead_of_empty_axes():
    """A sweep whose every task failed drew an empty histogram over "energy / median energy
    (1)" and an empty line plot with a y axis of ±0.04."""
    from stratcli.records.sweep_plots import NO_TASK_OK

    rows = {k: {"index": k, "status": "failed", "energy": 84.0} for k in range(2)}
    hist = energy_hist(_spec(kind="random", axes=()), rows).axes[0]
    assert hist.get_xlabel() == "energy / median energy" and not hist.patches
    line = energy_line(_spec(axes=((0.0, 1.0),)), rows).axes[0]
    for ax in (hist, line):
        assert [t.get_text() for t in ax.texts] == [NO_TASK_OK]


def test_the_energy_has_its_unit_and_a_whole_number_axis_whole_ticks():
    """The sweep's energy axes said "energy ∫|u|² dt" without the unit the ranking figure
    gives, and a sweep of planner.basis.harmonics over 2..5 had ticks at 2.5 and 3.5."""
    from stratcli.sweep.keys import energy_unit

    spec = {**_spec(axes=((2.0, 3.0, 4.0, 5.0),)), "energy_unit": energy_unit("preset")}
    spec["keys"] = ["planner.basis.harmonics"]
    ax = energy_line(spec, _rows(5)).axes[0]
    assert ax.get_ylabel() == "energy ∫|u|² dt [rad²/s]"
    ax.figure.canvas.draw()
    assert all(float(t).is_integer() for t in ax.get_xticks())
    assert energy_unit("custom") == ""
    colorbar = energy_map({**_spec(), "energy_unit": "rad²/s"}, _rows(6)).axes[1]
    assert colorbar.get_ylabel() == "energy ∫|u|² dt [rad²/s]"
