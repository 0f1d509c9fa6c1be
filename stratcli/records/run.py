"""Everything a `plan` run records, assembled in one place and written atomically."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

from ..scenario import Task
from ..sequence import SequencePlan
from . import drawing
from .foxglove_layout import run_layout
from .manifest import phase
from .mcap_log import mcap_log
from .model_files import model_files
from .rundir import run_name, write_run
from .trajectory import sample

SAMPLES, SAMPLES_PER_PIECE = 200, 24  # a leg's re-integrated samples in a record, at least


def _jsonable(value: Any) -> Any:
    """NaN (a goal entry "*") becomes null; tuples become lists."""
    if isinstance(value, float) and math.isnan(value):
        return None
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    return value


def resolved_scenario(task: Task) -> dict[str, Any]:
    """The validated scenario with every default filled in (`resolved.json`)."""
    return _jsonable(task.scenario.model_dump(mode="python"))


def record_files(
    task: Task,
    plan: SequencePlan,
    doc: dict,
    manifest: dict,
    animation: bool = False,
    fmt: str = "png",
    ranking: dict | None = None,
) -> dict[str, Any]:
    """Name → content of every file of the run directory (plots as `fmt`: png, svg or pdf;
    a comparison's `ranking` chart of its document; a URDF robot's URDF, `model_files`).

    The trajectory is re-integrated densely (≥ 200 samples per leg, 24 a piece of a Lie leg's
    steps: a 40-step leg's end-effector path was a jagged polyline) for the MCAP log and the
    plots; both are built in memory so the run directory can be written atomically. The
    figures are drawn by the drawing process where the command started one (`drawing`),
    else here; the MCAP log is built meanwhile, and its copy of the manifest added once they
    are, so that it has every phase's time. Each part is timed into `manifest["phases"]`.
    """
    phases = manifest.setdefault("phases", {})
    with phase(phases, "sample"):
        pieces = max((len(leg.pieces) for leg in plan.legs), default=1)
        traj = sample(plan, max(SAMPLES, SAMPLES_PER_PIECE * pieces + 1))
    title = task.scenario.name
    wall = time.perf_counter()
    drawn = drawing.ask(plan, traj, title, animation, fmt, ranking)
    layout = run_layout(plan, traj)
    files: dict[str, Any] = {
        "scenario.toml": task.text,
        "resolved.json": resolved_scenario(task),
        "result.json": doc,
        "manifest.json": manifest,
        "layout.json": layout,
    }
    # a URDF robot: its URDF beside scenario.toml, which names it (`model_files`)
    later = {"run.mcap", "comparison.json", "comparison.csv"}
    later |= {f"{name}.{fmt}" for name in ("configuration", "controls", "stroboscope", "ranking")}
    if urdf := model_files(task, {*files, *later, "motion.gif"}):
        files["scenario.toml"], copy, manifest["urdf"] = urdf
        files.update(copy)
        resolved = files["resolved.json"]  # names the copy too (it named the original file)
        resolved["model"] = {**resolved["model"], "path": manifest["urdf"]["file"]}
    with phase(phases, "run.mcap"):  # while the figures are drawn; its manifest after them
        # the record's scenario.toml: a URDF robot's names the record's copy of its URDF
        scenario = files["scenario.toml"]
        finish_log = mcap_log(plan, traj, doc, manifest, scenario, title, layout)
    with phase(phases, "plots"):
        if (answer := drawn()) is not None:  # wall from asking; CPU of the drawing processes
            plots, cpu = answer
        else:
            plots = _draw_here(plan, traj, title, animation, fmt, ranking)
    if answer is not None:
        phases["plots"] = {"wall_s": time.perf_counter() - wall, "cpu_s": cpu}
    files.update(plots)
    files["run.mcap"] = finish_log(manifest)
    return files


def _draw_here(plan, traj, title, animation, fmt, ranking) -> dict[str, bytes]:
    """The figures drawn in this process (the ranking chart beside them in a fork)."""
    from .plots import render_plots
    from .ranking import ranking_png

    ranked, stop = (None, None)
    if ranking is not None:
        ranked, stop = drawing.beside(ranking_png, ranking, fmt)
    try:
        plots = render_plots(plan, traj, title, animation=animation, fmt=fmt)
        if ranked is not None:
            plots[f"ranking.{fmt}"] = ranked()
    finally:
        if stop is not None:
            stop()
    return plots


def write_record(out: Path, task: Task, files: dict[str, Any], started) -> Path:
    """Write `files` as the run directory of `task` planned at `started` under `out` (named
    by `run_name`; whole or not at all: `rundir.write_run`); its path."""
    return write_run(out, run_name(task.scenario.name, task.text, started), files)
