"""Plots of a run: manipulators, custom models, long plans."""

from __future__ import annotations

import dataclasses
import io

import numpy as np
import pytest
from conftest import ROOT
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from PIL import Image
from typer.testing import CliRunner

import stratcli
import stratcli.records.plots as plots
import stratcli.simulate as simulate
from stratcli.cli import app
from stratcli.models.presets import preset
from stratcli.objectives import plan_sequence
from stratcli.records.plots import render_plots
from stratcli.records.ranking import ranking_figure, ranking_png
from stratcli.records.robot_figures import (
    HOLD_MS,
    frame_schedule,
    motion_gif,
    stroboscope_figure,
)
from stratcli.scenario import load_scenario
from stratcli.settings import PlannerSettings
from stratcli.stratified import LegSpec

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
    _, plan = unicycle_plan
    traj = simulate.sample(plan, 20)
    monkeypatch.setattr(plots, "MAX_LABELLED_LEGS", 0)
    fig = plots.configuration_figure(plan, traj, "t")
    assert "leg labels omitted" in fig._suptitle.get_text()
    assert len(fig.axes[0].texts) == 0


def test_long_coordinate_names_label_their_panels_without_overlapping(unicycle_plan):
    """A URDF's joint names (`u_shoulder_pitch [rad/s]`) ran each y label into the next
    panel's: each label now stays within its own panel's height."""
    _, plan = unicycle_plan
    traj = simulate.sample(plan, 20)
    names = tuple(f"u_very_long_joint_name_{i}" for i in range(len(plan.system.states)))
    fig = plots._time_series(plan, traj, traj.q, names, "rad/s", "t", "configuration")
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    for ax in fig.axes:
        label = ax.yaxis.label.get_window_extent(renderer)
        panel = ax.get_window_extent(renderer)
        assert panel.y0 - 1 <= label.y0 and label.y1 <= panel.y1 + 1, ax.get_ylabel()
    assert fig.axes[0].get_ylabel() == "u_very_long_joint_name_0\n[rad/s]"
    short = plots._time_series(plan, traj, traj.q, plan.system.states, "rad", "t", "configuration")
    assert short.axes[0].get_ylabel() == f"{plan.system.states[0]} [rad]"  # one line


# --------------------------------------------------------------------------------------------
# What a paper needs: units, leg methods, Lie steps, a FAILED stamp, the ranking's scale rule
# --------------------------------------------------------------------------------------------


def _texts(fig) -> list[str]:
    """Every text of a figure: its own, its axes' and their titles and labels."""
    out = [t.get_text() for t in fig.texts]
    if fig._suptitle is not None:
        out.append(fig._suptitle.get_text())
    for ax in fig.axes:
        out += [t.get_text() for t in ax.texts]
        out += [ax.get_title(loc) for loc in ("left", "center", "right")]
    return out


@pytest.fixture(scope="module")
def lie_plan():
    """Newton → Lie → Newton on the one-arm robot (the Lie leg on S1 takes several steps)."""
    pi = np.pi
    settings = PlannerSettings(objective="newton")
    via1 = np.array([0.0, pi / 3, 0.3, -0.05])
    legs = [
        LegSpec("S1", via1),
        LegSpec("S1", via1 + np.array([0.0, 0.1, -0.05, 0.04]), method="lie", lie=settings.lie),
        LegSpec("S3", np.array([-0.2, pi / 3 + 0.1, 0.25, np.nan])),
    ]
    plan = plan_sequence(preset("one-arm"), np.array([0.0, pi / 4, 0.0, 0.0]), legs, settings)
    assert plan.ok and len(plan.legs[1].pieces) > 1
    return plan, simulate.sample(plan, 60)


@pytest.fixture(scope="module")
def failed_plan():
    """sim4_task_c with one Newton iteration: leg 1 does not reach its goal."""
    task = load_scenario(ROOT / "scenarios" / "sim4_task_c.toml")
    settings = dataclasses.replace(task.settings, objective="newton", max_iterations=1, restarts=0)
    plan = plan_sequence(task.system, task.start, task.legs, settings)
    assert not plan.ok and plan.message
    return plan, simulate.sample(plan, 60)


def test_every_axis_has_a_unit(one_arm):
    conf = plots.configuration_figure(one_arm.plan, one_arm.traj, "t")
    ctrl = plots.controls_figure(one_arm.plan, one_arm.traj, "t")
    strobo = stroboscope_figure(one_arm.plan, one_arm.traj, "t")
    assert all(ax.get_ylabel().endswith("[rad]") for ax in conf.axes)
    assert all(ax.get_ylabel().endswith("[rad/s]") for ax in ctrl.axes)
    assert conf.axes[-1].get_xlabel() == ctrl.axes[-1].get_xlabel() == "time [s]"
    shown = [ax for ax in strobo.axes if ax.get_visible()]
    assert any(ax.get_xlabel() == "x [m]" for ax in shown)
    assert any(ax.get_ylabel() == "y [m]" for ax in shown)


def test_custom_model_says_its_units_are_its_own(biped):
    fig = plots.configuration_figure(biped.plan, biped.traj, "t")
    assert "own units" in fig._suptitle.get_text()
    assert fig.axes[-1].get_xlabel() == "time [s]"


def test_the_last_goal_marker_is_not_clipped(one_arm):
    fig = plots.configuration_figure(one_arm.plan, one_arm.traj, "t")
    end = one_arm.plan.duration
    goals = [
        line
        for ax in fig.axes
        for line in ax.lines
        if line.get_marker() == "o" and np.isclose(line.get_xdata()[-1], end)
    ]
    assert goals and not any(line.get_clip_on() for line in goals)


def test_legs_are_labelled_with_method_and_lie_steps_are_drawn(lie_plan):
    plan, traj = lie_plan
    steps = len(plan.legs[1].pieces)
    for make in (plots.configuration_figure, plots.controls_figure):
        fig = make(plan, traj, "t")
        texts = "\n".join(_texts(fig)) + (fig._supxlabel.get_text() if fig._supxlabel else "")
        assert "S1 · newton" in texts and "S3 · newton" in texts
        assert f"S1 · lie ({steps} steps)" in texts
        assert "Lie step" in texts
        lines = [c for c in fig.axes[0].collections if isinstance(c, LineCollection)]
        assert sum(len(c.get_segments()) for c in lines) == (steps - 1) + len(plan.switches)
        assert "FAILED" not in texts
    strobo = stroboscope_figure(plan, traj, "t")
    assert any(f"lie ({steps} steps)" in t for t in _texts(strobo))


def test_a_failed_plan_is_stamped_failed(failed_plan):
    plan, traj = failed_plan
    figures = [
        plots.configuration_figure(plan, traj, "t"),
        plots.controls_figure(plan, traj, "t"),
        stroboscope_figure(plan, traj, "t"),
    ]
    for fig in figures:
        texts = _texts(fig)
        assert "FAILED" in texts  # the diagonal stamp
        assert any(plan.message[:30] in t.replace("\n", " ") for t in texts)
        assert fig._suptitle.get_text().endswith("FAILED")
    files = render_plots(plan, traj, "t", animation=False)
    assert set(files) == {"configuration.png", "controls.png", "stroboscope.png"}
    # the message sits under the plots, in a band of its own (it covered the lower panels'
    # curves, and the stroboscope's poses), clear of the axes' labels (and the legend)
    for fig in figures:
        renderer = FigureCanvasAgg(fig).get_renderer()
        fig.draw(renderer)
        (box,) = [t for t in fig.texts if plan.message[:30] in t.get_text().replace("\n", " ")]
        extent = box.get_bbox_patch().get_window_extent(renderer)
        shown = [ax for ax in fig.axes if ax.get_visible() and ax.get_xlabel()]
        assert all(extent.y1 < ax.xaxis.label.get_window_extent(renderer).y0 for ax in shown)
        for legend in fig.legends:
            assert extent.y1 < legend.get_window_extent(renderer).y0
        assert all(extent.y1 < ax.get_window_extent(renderer).y0 for ax in fig.axes)


def test_a_one_panel_stroboscopes_title_and_whole_message_fit_the_figure(failed_plan):
    """A plan failed on its first leg has one stroboscope panel: its title ran past both
    edges of the figure with a long scenario name, "— FAILED" with it, and the boxed message
    was cut at 300 characters, its advice lost. Both are whole and inside the figure."""
    plan, traj = failed_plan
    one_leg = dataclasses.replace(plan, legs=plan.legs[:1])
    traj = simulate.sample(one_leg, 60)
    fig = stroboscope_figure(one_leg, traj, "a_scenario_with_a_considerably_longer_name_than_usual")
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    width = fig.get_window_extent(renderer)
    title = fig._suptitle.get_window_extent(renderer)
    assert width.x0 <= title.x0 and title.x1 <= width.x1 and title.y1 <= width.y1
    assert fig._suptitle.get_text().endswith("— FAILED")
    assert all(fig._suptitle.get_window_extent(renderer).y0 > ax.title.get_window_extent(
        renderer).y1 for ax in fig.axes if ax.get_visible())  # fmt: skip
    (box,) = [t for t in fig.texts if plan.message[:30] in t.get_text().replace("\n", " ")]
    assert " ".join(box.get_text().split()).startswith(" ".join(plan.message.split()))
    # the legs after the failed one, which no figure shows, are said
    assert " ".join(box.get_text().split()).endswith("(legs 2 to 3 of 3 not planned)")


def test_a_plan_with_an_acceleration_limit_gets_its_accelerations_figure(shipped_plans, one_arm):
    """max_acceleration of [constraints] is met (time scaling) and now drawn: the inputs'
    rates of change against time, each curve's closest approach to the limit marked ×
    (the trial found the limit in result.json only); a plan without one has no such file."""
    _, outcome = shipped_plans["sim4_task_d_rate_limited"]
    plan = outcome.result
    traj = simulate.sample(plan, 60)
    assert "accelerations.png" in render_plots(plan, traj, "t", animation=False)
    fig = plots.accelerations_figure(plan, traj, "t")
    assert [ax.get_ylabel() for ax in fig.axes] == [f"du{i}/dt [rad/s²]" for i in (1, 2, 3)]
    for ax, i in zip(fig.axes, range(3), strict=True):  # the marked points are the peaks
        (x,) = [line for line in ax.lines if line.get_marker() == "x"]
        assert abs(x.get_ydata()[0]) == pytest.approx(np.abs(traj.du[:, i]).max())
    assert "acceleration limit" in " ".join(_texts(fig))
    assert "accelerations.png" not in render_plots(one_arm.plan, one_arm.traj, "t", False)


def test_the_gif_plays_in_real_time(one_arm):
    gif = Image.open(io.BytesIO(motion_gif(one_arm.plan, one_arm.traj, "t")))
    durations = []
    for i in range(gif.n_frames):
        gif.seek(i)
        durations.append(gif.info["duration"])
    motion = sum(durations[:-1])  # the last frame holds the final pose
    assert abs(motion - 1000 * one_arm.plan.duration) <= 20
    assert durations[-1] == HOLD_MS


def test_a_long_gif_states_its_speed_up():
    times, durations, speed = frame_schedule(0.0, 16.3, max_frames=120, frame_ms=50)
    assert speed == 4 and len(times) <= 120 and times[-1] == 16.3
    assert abs(sum(durations[:-1]) - 16.3 / 4 * 1000) <= 20
    assert frame_schedule(0.0, 3.0)[2] == 1  # real time


def _ranking_doc(values: list[float | None]) -> dict:
    rows = [
        {
            "rank": i + 1,
            "sequence": ["S1", f"S{i + 2}"],
            "strategy": "conservative",
            "status": "ok" if v is not None else "failed",
            "reason": None if v is not None else "leg 2 did not converge",
            "energy": v,
        }
        for i, v in enumerate(values)
    ]
    return {"criterion": "energy", "rows": rows, "best": 0, "scenario": "s", "model": "one-arm"}


@pytest.mark.parametrize(
    ("values", "log"),
    [
        ([60.0, 70.0, 590.0], False),  # 9.8x
        ([60.0, 70.0, 610.0], True),  # 10.2x
        ([60.0, None, *[62.0 + i for i in range(15)], 2400.0], True),  # one 40x the rest
        ([0.0, 1.0, 2.0], True),  # from 0: an infinite range
    ],
)
def test_ranking_uses_a_log_axis_iff_the_values_span_more_than_10x(values, log):
    fig = ranking_figure(_ranking_doc(values))
    (ax,) = fig.axes
    assert (ax.get_xscale() == "log") is log
    assert ax.get_xlabel().startswith("total energy") and "[rad²/s]" in ax.get_xlabel()
    (legend,) = fig.legends
    assert legend.get_title().get_text().startswith("log scale" if log else "linear scale")
    labels = [t.get_text() for t in legend.get_texts()]
    assert labels[0] == "best: S1→S2 · cons."


@pytest.mark.parametrize("top", [6115.0, 2950.0, 9000.0, 30_000.0, 61_150.0])
def test_ranking_every_value_axis_label_ends_inside_the_figure(top):
    """The exhaustive Sim 4 chart (64.8 to 6,115) cut its last decade's label, 10,000, at
    the figure's right edge; a review found the minor labels (5,000 up to 2,950; 50,000 up to
    30,000) past it too."""
    fig = ranking_figure(_ranking_doc([64.8, 104.1, 451.8, top]))
    (ax,) = fig.axes
    renderer = fig.canvas.get_renderer()
    fig.draw(renderer)
    assert ax.get_xscale() == "log"
    labels = [*ax.get_xticklabels(), *ax.get_xticklabels(minor=True)]
    shown = [t for t in labels if t.get_visible() and t.get_text()]
    lo, hi = ax.get_xlim()
    inside = [t for t in shown if lo <= t.get_position()[0] <= hi]
    assert inside
    for label in inside:
        box = label.get_window_extent(renderer)
        assert 0 <= box.x0 and box.x1 <= fig.bbox.width, label.get_text()
    assert hi >= top  # every bar still inside


def test_ranking_shows_a_bounded_row_as_its_bound_not_as_a_failure():
    doc = _ranking_doc([60.0, None, 70.0])
    doc["rows"][1].update(status="bounded", energy_bound=64.5, reason="not searched")
    fig = ranking_figure(doc)
    (ax,) = fig.axes
    texts = [t.get_text() for t in ax.texts]
    assert " ≥ 64.5" in texts
    assert not any("failed" in t for t in texts)
    (legend,) = fig.legends
    keys = [t.get_text() for t in legend.get_texts()]
    assert "failed" not in keys and any(k.startswith("not searched: ≥ its lower") for k in keys)
    # a hollow bar to its bound, on the same scale as the others (70 / 60 < 10: linear)
    (hollow,) = [c for c in ax.collections if not c.get_facecolor().any()]
    (bar,) = hollow.get_paths()
    assert bar.get_extents().x0 == 0.0 and bar.get_extents().x1 == pytest.approx(64.5)
    assert bar.get_extents().y0 == pytest.approx(0.65)  # on row 1, 0.7 high
    assert ax.get_xscale() == "linear"
    assert ax.get_xlim()[1] >= 70.0


def test_ranking_clips_a_long_failure_reason_at_a_word_with_an_ellipsis():
    reason = (
        "the constrained search stalled on leg 1: self-collision still violated by 0.194 at "
        "its nodes, after three starts and a basis of five harmonics"
    )
    doc = _ranking_doc([60.0, None])
    doc["rows"][1]["reason"] = reason
    (ax,) = ranking_figure(doc).axes
    (text,) = [t.get_text() for t in ax.texts if t.get_text().startswith(" failed: ")]
    shown = text.removeprefix(" failed: ")
    assert shown.endswith(" …") and len(shown) <= 100
    kept = shown.removesuffix(" …")
    assert reason.startswith(kept) and reason[len(kept)] == " "  # whole words only


def test_ranking_scale_counts_the_bounds():
    """Bounds ten times the best make the axis logarithmic, as values would."""
    doc = _ranking_doc([60.0, None])
    doc["rows"][1].update(status="bounded", energy_bound=900.0)
    (ax,) = ranking_figure(doc).axes
    assert ax.get_xscale() == "log" and ax.get_xlim()[1] > 900.0


def test_the_ranking_labels_fit_in_the_figure():
    """Fixed margins instead of constrained layout: the longest label still fits."""
    doc = _ranking_doc([60.0, 65.0])
    doc["rows"][1]["sequence"] = ["S1", "S2", "S3", "S1", "S2", "S3"]
    fig = ranking_figure(doc)
    renderer = FigureCanvasAgg(fig).get_renderer()
    (ax,) = fig.axes
    labels = [t for t in ax.texts if t.get_text().endswith(" · cons.")]
    boxes = [t.get_window_extent(renderer) for t in labels]
    assert len(boxes) == 2 and min(b.x0 for b in boxes) >= 0
    assert max(b.x1 for b in boxes) < ax.get_window_extent(renderer).x0  # left of the axes
    legend = fig.legends[0].get_window_extent(renderer)
    assert legend.y0 >= 0 and legend.y1 < ax.xaxis.get_tightbbox(renderer).y0


def _inside(fig, artists) -> bool:
    renderer = FigureCanvasAgg(fig).get_renderer()
    width, height = fig.bbox.width, fig.bbox.height
    boxes = [a.get_window_extent(renderer) for a in artists]
    return all(b.x0 >= 0 and b.y0 >= 0 and b.x1 <= width and b.y1 <= height for b in boxes)


@pytest.mark.parametrize("log", [False, True])
def test_the_values_after_the_last_bars_end_in_the_figure(log):
    """Fixed margins no longer shrink the axes for them: the axis leaves them room."""
    values = [10.0 * (i + 1) ** (3 if log else 0.3) for i in range(40)]
    doc = _ranking_doc([*values, None, None])
    for row, bound in zip(doc["rows"][-2:], (1.01 * values[-1], 1.09 * values[-1]), strict=True):
        row.update(status="bounded", energy_bound=bound)
    fig = ranking_figure(doc)
    (ax,) = fig.axes
    assert (ax.get_xscale() == "log") is log
    assert _inside(fig, ax.texts)


def test_a_legend_wider_than_the_chart_takes_two_columns():
    doc = _ranking_doc([60.0, 65.0, None, None])
    doc["rows"][0]["sequence"] = ["S1", "S2", "S3", "S1", "S2", "S3", "S1"]
    doc["rows"][2].update(status="bounded", energy_bound=61.0)  # four kinds of rows
    fig = ranking_figure(doc)
    (legend,) = fig.legends
    assert len(legend.get_texts()) == 4 and _inside(fig, [legend])
    renderer = FigureCanvasAgg(fig).get_renderer()
    assert legend.get_window_extent(renderer).y1 < fig.axes[0].xaxis.get_tightbbox(renderer).y0


@pytest.mark.parametrize(("fmt", "magic"), [("svg", (b"<?xml", b"<svg")), ("pdf", (b"%PDF",))])
def test_plots_in_svg_and_pdf(one_arm, fmt, magic):
    files = render_plots(one_arm.plan, one_arm.traj, "t", animation=False, fmt=fmt)
    assert set(files) == {f"configuration.{fmt}", f"controls.{fmt}", f"stroboscope.{fmt}"}
    assert all(data.startswith(magic) for data in files.values())
    assert ranking_png(_ranking_doc([1.0, 2.0]), fmt).startswith(magic)
    with pytest.raises(ValueError, match="png, svg, pdf"):
        render_plots(one_arm.plan, one_arm.traj, "t", fmt="gif")


def test_plan_format_svg_writes_svg_files(tmp_path):
    out = tmp_path / "runs"
    args = ["plan", str(ROOT / "scenarios" / "sim4_task_c.toml"), "--out", str(out)]
    result = CliRunner().invoke(app, [*args, "-q", "--no-animation", "--format", "svg"])
    assert result.exit_code == 0, result.output
    (run,) = out.iterdir()
    names = {p.name for p in run.iterdir()}
    assert {"configuration.svg", "controls.svg", "stroboscope.svg"} <= names
    assert not any(name.endswith(".png") for name in names)
    assert (run / "configuration.svg").read_bytes().startswith((b"<?xml", b"<svg"))
    bad = CliRunner().invoke(app, [*args, "--format", "gif"])
    assert bad.exit_code == 2


def _annotations(fig) -> list[str]:
    return [t.get_text() for ax in fig.axes for t in ax.texts] + [t.get_text() for t in fig.texts]


@pytest.mark.parametrize("constraints", [None, {"joint_limits": [-3.2, 3.2], "max_rate": 2.0}])
def test_off_labels_mark_inputs_only_and_limits_show_on_the_configuration(constraints):
    """'off (u = 0)' belongs to the controls figure (an input off on a leg), never to the
    configuration figure, whose rows are coordinates; joint limits draw dashed lines there,
    rate limits on the controls."""
    import tomllib

    import stratcli

    raw = tomllib.loads((ROOT / "scenarios" / "sim4_task_d.toml").read_text())
    raw["planner"]["objective"] = "newton"
    if constraints:
        raw["constraints"] = constraints
    task = stratcli.load_scenario(raw)
    plan = stratcli.api.plan_run(task, check=False).result
    traj = plan.sample(100)
    configuration = plots.configuration_figure(plan, traj)
    controls = plots.controls_figure(plan, traj)
    assert not any("off (u = 0)" in t for t in _annotations(configuration))
    assert any("off (u = 0)" in t for t in _annotations(controls))
    dashed = [
        line for ax in configuration.axes for line in ax.get_lines() if line.get_linestyle() == "--"
    ]
    limit_lines = [line for line in dashed if np.allclose(line.get_ydata(), 3.2)]
    assert bool(limit_lines) == bool(constraints)
    dashed = [
        line for ax in controls.axes for line in ax.get_lines() if line.get_linestyle() == "--"
    ]
    rate_lines = [line for line in dashed if np.allclose(np.abs(line.get_ydata()), 2.0)]
    assert bool(rate_lines) == bool(constraints)
    assert any("rate limit" in t for t in _annotations(controls)) == bool(constraints)


def test_a_limit_far_off_the_axis_is_said_in_its_panel():
    """A rate limit far from its curve was left out (it would squash it): the panel of u2,
    limited to 20 rad/s, showed no sign of having a limit at all."""
    import tomllib

    import stratcli

    raw = tomllib.loads((ROOT / "scenarios" / "sim4_task_d.toml").read_text())
    raw["planner"]["objective"] = "newton"
    raw["constraints"] = {"max_rate": [2.0, 20.0, 2.0]}
    plan = stratcli.api.plan_run(stratcli.load_scenario(raw), check=False).result
    controls = plots.controls_figure(plan, plan.sample(100))
    said = [
        [t.get_text() for t in ax.texts if "off the axis" in t.get_text()] for ax in controls.axes
    ]
    assert said == [[], ["rate limit -20 and 20 (off the axis)"], []]


def test_a_far_limits_label_does_not_hide_the_near_limits_line(shipped_plans):
    """The rate-limited task's q2 and q3: +pi drawn near the top, -pi far below; the label
    "joint limit -3.14159 (off the axis)" sat at the top, over the +pi line. It sits at the
    edge the far limit lies beyond, clear of every drawn limit line."""
    _, outcome = shipped_plans["sim4_task_d_rate_limited"]
    plan = outcome.result
    fig = plots.configuration_figure(plan, plan.sample(100))
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    labelled = 0
    for ax in fig.axes:
        for text in (t for t in ax.texts if "off the axis" in t.get_text()):
            labelled += 1
            box = text.get_window_extent(renderer)
            for line in ax.get_lines():
                y = line.get_ydata()
                if line.get_linestyle() == "--" and len(set(np.ravel(y))) == 1:  # a limit
                    at = ax.transData.transform((0.0, float(np.ravel(y)[0])))[1]
                    assert not box.y0 <= at <= box.y1, (text.get_text(), float(np.ravel(y)[0]))
    assert labelled == 2  # q2's and q3's lower limit


def test_figures_show_an_obstacle_far_from_the_robot_whole():
    import dataclasses

    import stratcli
    from stratcli.constraint_report import ConstraintReport

    plan = stratcli.plan(ROOT / "scenarios" / "sim4_task_d.toml")
    far = [{"shape": "circle", "centre": [5.0, -4.0], "radius": 0.5}]
    plan = dataclasses.replace(plan, constraints=ConstraintReport({"obstacles": far}))
    traj = plan.sample(50)
    ax = stroboscope_figure(plan, traj).axes[0]
    assert ax.get_xlim()[1] >= 5.5 and ax.get_ylim()[0] <= -4.5


def test_a_long_scenario_name_wraps_the_ranking_title_inside_the_figure():
    """A 150-character scenario name was cut at both edges of the chart."""
    doc = _ranking_doc([60.0, 65.0])
    doc["scenario"] = "a_very_long_scenario_name_" * 6
    fig = ranking_figure(doc)
    renderer = FigureCanvasAgg(fig).get_renderer()
    (ax,) = fig.axes
    box = ax.title.get_window_extent(renderer)
    width, height = fig.get_size_inches() * fig.dpi
    assert box.x0 >= 0 and box.x1 <= width and box.y1 <= height
    assert ax.title.get_text().count("\n") >= 1


def test_the_stroboscope_marks_each_legs_closest_approach_to_an_obstacle():
    import stratcli
    from stratcli.constraint_report import ConstraintReport
    from stratcli.records.trajectory import world_geometry

    plan = stratcli.plan(ROOT / "scenarios" / "sim4_task_d.toml")
    circle = {"shape": "circle", "centre": [1.6, 1.1], "radius": 0.1}
    plan = dataclasses.replace(plan, constraints=ConstraintReport({"obstacles": [circle]}))
    traj = plan.sample(60)
    fig = stroboscope_figure(plan, traj)
    for leg, ax in enumerate(fig.axes[: len(plan.legs)]):
        # independently: the links' points (capsules of radius 0.05) nearest the circle
        s = traj.leg_slice(leg)
        geo = world_geometry(plan.system.robot, traj.q[s])
        a, b = geo["proximal"], geo["distal"]  # (N, k, 2)
        t = np.linspace(0, 1, 2001)[:, None, None, None]
        points = a[None] + t * (b - a)[None]  # (2001, N, k, 2)
        gap = np.linalg.norm(points - np.array([1.6, 1.1]), axis=-1) - 0.1 - 0.05
        i, n, j = np.unravel_index(np.argmin(gap), gap.shape)
        (cross,) = [line for line in ax.get_lines() if line.get_marker() == "x"]
        np.testing.assert_allclose(cross.get_xydata()[0], points[i, n, j], atol=0.02)
        (label,) = [x.get_text() for x in ax.texts if x.get_text().startswith("closest")]
        assert label.startswith(f"closest approach: margin {gap.min():.3g}, near t = "), label
        assert f"t = {traj.t[s][n]:.4g} s" in label


def test_a_lie_legs_stroboscope_poses_are_mid_step():
    """A Lie leg's loops close at its step boundaries, where evenly spaced poses landed: the
    leg looked still while its joints swung. Its poses are now the middle of evenly chosen
    steps (between its start and end), and a record samples 24 a step."""
    from stratcli.records.robot_figures import _instants
    from stratcli.records.run import SAMPLES_PER_PIECE
    from stratcli.simulate import sample

    plan = stratcli.plan(ROOT / "scenarios" / "sim3_hybrid.toml", check=False)
    leg = plan.legs[2]
    assert leg.method == "lie" and len(leg.pieces) > 2
    traj = sample(plan, SAMPLES_PER_PIECE * len(leg.pieces) + 1)
    s = traj.leg_slice(2)
    idx = _instants(leg, traj.t, s, 10)
    assert idx[0] == s.start and idx[-1] == s.stop - 1
    for i in idx[1:-1]:  # each inside a step, half way through it (to a sample spacing)
        local = traj.t[i] - leg.t0
        step = next(p for p in leg.pieces if p.t0 <= local <= p.t0 + p.duration)
        assert abs(local - (step.t0 + step.duration / 2)) <= traj.t[s][1] - traj.t[s][0]


def test_a_curve_constant_but_for_rounding_is_drawn_flat():
    """sim2's energy plan keeps q1, q3 and θ at 0 up to ~1e-14: matplotlib fitted their axes
    to the noise, a full-height swing under a small '1e-14' offset label."""
    plan = stratcli.plan(ROOT / "scenarios" / "sim2.toml")
    traj = simulate.sample(plan)
    fig = plots.configuration_figure(plan, traj, "t")
    q = traj.q
    flat = [i for i in range(q.shape[1]) if np.ptp(q[:, i]) < 1e-9]
    moving = [i for i in range(q.shape[1]) if np.ptp(q[:, i]) > 0.1]
    assert flat and moving
    FigureCanvasAgg(fig).draw()
    for i in flat:
        low, high = fig.axes[i].get_ylim()
        assert high - low >= 2.0 and low < q[0, i] < high
        assert fig.axes[i].yaxis.get_major_formatter().get_offset() == ""
    for i in moving:  # fitted to the curve as before
        low, high = fig.axes[i].get_ylim()
        assert high - low < 1.5 * np.ptp(q[:, i])


def test_ranking_failure_labels_show_what_differs_and_the_legend_what_they_share():
    """Clipped, every label read 'the constrained search stalled on leg 1: the joint limits
    of …': the same words, what told them apart cut off. The shared words end a phrase."""
    shared = "the constrained search stalled on leg 1:"
    doc = _ranking_doc([60.0, None, None])
    own = "the joint limits of {} still violated by {} rad at its nodes, after three starts"
    doc["rows"][1]["reason"] = f"{shared} {own.format('q1', 0.23)}"
    doc["rows"][2]["reason"] = f"{shared} {own.format('q3', 0.41)}"
    fig = ranking_figure(doc)
    (ax,) = fig.axes
    texts = [t.get_text() for t in ax.texts if t.get_text().startswith(" failed: ")]
    assert texts == [f" failed: … {own.format('q1', 0.23)}", f" failed: … {own.format('q3', 0.41)}"]
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert f"failed: {shared} …" in labels


def test_a_long_failed_title_clears_the_corner_keys(failed_plan):
    """configuration.png of a failed plan with a long scenario name: its title ran under the
    "○ goal of the leg" key in the corner; it wraps between the keys."""
    plan, traj = failed_plan
    fig = plots.configuration_figure(
        plan, traj, "a_scenario_with_a_considerably_longer_name_than_usual"
    )
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    title = fig._suptitle.get_window_extent(renderer)
    keys = [t for t in fig.texts if t is not fig._suptitle and "goal of the leg" in t.get_text()]
    assert keys and fig._suptitle.get_text().endswith("— FAILED")
    for key in keys:
        box = key.get_window_extent(renderer)
        assert box.x1 < title.x0 or title.x1 < box.x0 or box.y1 < title.y0 or title.y1 < box.y0
