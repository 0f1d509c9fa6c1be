"""Everything a `plan` run records, assembled in one place and written atomically."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from ..scenario import Task
from ..sequence import SequencePlan
from .foxglove_layout import run_layout
from .manifest import phase
from .mcap_log import mcap_bytes
from .model_files import model_files
from .plots import render_plots
from .rundir import run_name, write_run
from .trajectory import sample


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
) -> dict[str, Any]:
    """Name → content of every file of the run directory (plots as `fmt`: png, svg or pdf;
    a URDF robot's URDF, `model_files`).

    The trajectory is re-integrated densely (≥ 200 samples per leg) for the MCAP log and the
    plots; both are built in memory so the run directory can be written atomically. Each part
    is timed into `manifest["phases"]` (the log last, so that its copy has the plots' time).
    """
    phases = manifest.setdefault("phases", {})
    with phase(phases, "sample"):
        traj = sample(plan)
    with phase(phases, "plots"):
        plots = render_plots(plan, traj, task.scenario.name, animation=animation, fmt=fmt)
    layout = run_layout(plan, traj)
    files: dict[str, Any] = {
        "scenario.toml": task.text,
        "resolved.json": resolved_scenario(task),
        "result.json": doc,
        "manifest.json": manifest,
        "layout.json": layout,
        **plots,
    }
    # a URDF robot: its URDF beside scenario.toml, which names it (`model_files`)
    later = {"run.mcap", "comparison.json", "comparison.csv", f"ranking.{fmt}"}
    if urdf := model_files(task, {*files, *later}):
        files["scenario.toml"], copy, manifest["urdf"] = urdf
        files.update(copy)
    with phase(phases, "run.mcap"):
        name = task.scenario.name
        files["run.mcap"] = mcap_bytes(plan, traj, doc, manifest, task.text, name, layout)
    return files


def write_record(out: Path, task: Task, files: dict[str, Any], started) -> Path:
    return write_run(out, run_name(task.scenario.name, task.text, started), files)
