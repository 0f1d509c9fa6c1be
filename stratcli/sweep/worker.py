"""One sweep task, planned in a worker process: the public API, and a row of plain values.

`run_task` never raises for anything a task can cause: a plan that misses its goal is a row
with status "failed", a scenario the task's values make invalid is "invalid", a stratum that
cannot steer the task is "not-controllable", any other exception is "error" with its type and
message. What it returns is plain data (JSON-able; floats exact), so it crosses a process pool
or a Dask cluster unchanged and the row is the same wherever it was planned.
"""

from __future__ import annotations

import importlib
import math
import os
import socket
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

from ..errors import UnusedLegsWarning

STATUSES = ("ok", "failed", "invalid", "not-controllable", "error")
# columns that depend on the machine and the moment, not on the task (left out of comparisons)
TIMING_COLUMNS = ("planning_time_s", "task_time_s", "worker")


def ranking_text(comparison) -> str:
    """A compare-mode row's `ranking`: the sequences that reached the goal, best first, then
    those the screen bounded (not searched: not ranked among themselves) and those that
    failed: "(S1, S3) > (S3, S1); bounded: (S2, S1), ...; failed: ..." (a new user read the
    18 of one row, one searched, as 18 ranked)."""
    groups: dict[str, list[str]] = {"ok": [], "bounded": [], "failed": []}
    for k in comparison.ranking:
        o = comparison.outcomes[k]
        kind = "ok" if o.ok else "bounded" if o.status == "bounded" else "failed"
        groups[kind].append(o.candidate.label)
    parts = [" > ".join(groups.pop("ok"))] if groups["ok"] else []
    parts += [f"{kind}: {', '.join(labels)}" for kind, labels in groups.items() if labels]
    return "; ".join(parts)


def _finite(x: Any) -> float | None:
    return float(x) if x is not None and math.isfinite(float(x)) else None


def preload() -> None:
    """Import what `run_task` needs (before forking workers that then need not)."""
    from ..api import compare_sequences, plan_auto, plan_run, write_record  # noqa: F401
    from ..metrics import peak_and_excursion  # noqa: F401
    from ..scenario import load_scenario  # noqa: F401


def run_task(payload: dict[str, Any]) -> dict[str, Any]:
    """Plan one task; `{"row": {...}, "record": None | (name, {file: bytes})}`.

    Parameters
    ----------
    payload : dict
        `index`, `inputs`, `seed`, `scenario` (a scenario dict), `mode` (legs | auto |
        compare), `check`, `exhaustive`, `records` (all | failed | none: which tasks' run
        records to return, as file contents), `name` (the sweep's name).
    """
    from ..api import compare_sequences, plan_auto, plan_run, write_record  # in the worker
    from ..errors import InputError, NotControllableError
    from ..metrics import peak_and_excursion
    from ..scenario import load_scenario

    clock = time.perf_counter()
    index = payload["index"]
    row: dict[str, Any] = {
        "index": index,
        **payload["inputs"],
        "seed": payload["seed"],
        "status": "error",
        "message": "",
        "energy": None,
        "peak_control": None,
        "excursion": None,
        "duration": None,
        "legs": None,
        "sequence": None,
        "candidates": None,
        "reached": None,
    }
    outcome = None
    try:
        _own_planners(payload.get("planners") or {}, payload["scenario"])
        task = load_scenario(payload["scenario"], name=f"task {index}")
        mode = payload["mode"]
        if mode == "legs":
            outcome = plan_run(task, check=payload["check"])
            plan = outcome.result
            planning = outcome.planning_time
        else:
            if mode == "auto":
                outcome = plan_auto(task, check=payload["check"], jobs=1)
            else:  # a base with [[legs]] compared afresh: the sweep's mode, not a surprise
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", UnusedLegsWarning)
                    outcome = compare_sequences(task, jobs=1, exhaustive=payload["exhaustive"])
            comparison = outcome.comparison
            plan = outcome.best.result
            row.update(
                candidates=len(comparison.outcomes),
                reached=sum(o.ok for o in comparison.outcomes),
            )
            if mode == "compare":
                row["ranking"] = ranking_text(comparison)
            planning = comparison.wall_time
        # the plan as run: re-timed (planner.time_scale) and slowed to its rate limits, its
        # own basis (the task's has the period before re-timing); in auto and compare mode
        # not the comparison's numbers, which are the chosen sequence as planned
        peak, excursion = peak_and_excursion(plan, task.system)
        row.update(
            peak_control=_finite(peak),
            excursion=_finite(excursion),
            status="ok" if plan.ok else "failed",
            message="" if plan.ok else plan.message,
            energy=_finite(plan.total_energy),
            duration=_finite(plan.duration),
            legs=len(plan.legs),
            sequence=",".join(leg.stratum for leg in plan.legs),
            planning_time_s=planning,
        )
        row.update(_margins(plan.constraints))
    except InputError as exc:
        row.update(status="invalid", message=str(exc).replace("\n", "; "))
    except NotControllableError as exc:
        row.update(status="not-controllable", message="; ".join(exc.problems))
    except Exception as exc:  # a task's failure is a row, never a lost task
        row.update(status="error", message=f"{type(exc).__name__}: {exc}")
    record, lost = None, None
    wanted = payload["records"]
    if outcome is not None and (wanted == "all" or (wanted == "failed" and not outcome.ok)):
        record, lost = _record_files(outcome, write_record, payload)
    row.setdefault("planning_time_s", None)
    row["task_time_s"] = time.perf_counter() - clock
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return {"row": row, "record": record, "record_lost": lost}


def own_planners() -> dict[str, str]:
    """{method: module} of the leg planners registered in this process that are not
    stratplan's own (a user's `LegPlanner` subclasses): what a worker that did not inherit
    them (spawned, or a Dask worker) imports to register them (`run_task`)."""
    from ..planners import PLANNERS

    return {
        method: cls.__module__
        for method, cls in PLANNERS.items()
        if not cls.__module__.startswith("stratcli.")
    }


def _own_planners(modules: dict[str, str], scenario: dict[str, Any]) -> None:
    """Register the parent's own leg planners that this worker lacks by importing their
    modules; a planner defined in the parent's main script (a notebook, `python script.py`)
    cannot be imported here: an `InputError` naming the leg that uses it."""
    from ..errors import InputError, Problem
    from ..planners import PLANNERS

    for method, module in modules.items():
        if method in PLANNERS:
            continue
        if module != "__main__":
            try:
                importlib.import_module(module)
            except ImportError:
                pass  # the scenario's own check names the method
        if method not in PLANNERS:
            legs = scenario.get("legs") if isinstance(scenario, dict) else None
            for i, leg in enumerate(legs if isinstance(legs, list) else []):
                if isinstance(leg, dict) and leg.get("method") == method:
                    where = "its main script" if module == "__main__" else f"module {module}"
                    raise InputError(
                        [
                            Problem(
                                f"legs[{i}].method",
                                f"leg planner {method!r} is defined in {where}, which this "
                                "worker (spawned, or on a Dask cluster) cannot import: define "
                                "it in a module that the workers can import (a sweep's "
                                "workers inherit it where they are forked: on Linux, no "
                                "other thread running and OPENBLAS_NUM_THREADS, "
                                "OMP_NUM_THREADS and MKL_NUM_THREADS set to 1 before numpy "
                                "loaded)",
                            )
                        ]
                    )


def _margins(report) -> dict[str, float]:
    """Under [constraints]: the smallest margin to each limit over the legs, as columns
    `margin_<limit>` (`constraint_report.MARGINS` order; negative where a limit is broken)."""
    out: dict[str, float] = {}
    for margins in report.legs if report is not None else ():
        for key, value in margins.items():
            if value is not None:
                out[f"margin_{key}"] = min(out.get(f"margin_{key}", value), value)
    return {key: _finite(value) for key, value in out.items()}


def replan_command(mode: str, check: bool, exhaustive: bool) -> list[str]:
    """A task record's manifest command: the one that plans the task again from the record's
    own scenario.toml (there is no command that plans one task of a sweep)."""
    if mode == "compare":
        return ["stratplan", "compare-sequences", "scenario.toml"] + (
            ["--exhaustive"] if exhaustive else []
        )
    return ["stratplan", "plan", "scenario.toml"] + ([] if check else ["--no-check"])


def _record_files(outcome, write_record, payload) -> tuple[tuple | None, str | None]:
    """The task's run record as file contents (the sweep's process writes them), or None and
    why it could not be made (the sweep reports it; the row is kept either way)."""
    argv = replan_command(payload["mode"], payload["check"], payload.get("exhaustive", False))
    try:
        with tempfile.TemporaryDirectory(prefix="stratplan-sweep-") as tmp:
            run_dir = write_record(tmp, outcome, argv=argv)
            files = {p.name: p.read_bytes() for p in Path(run_dir).iterdir() if p.is_file()}
        return (f"task-{payload['index']:06d}", files), None
    except Exception as exc:  # a record that cannot be drawn or written loses no row
        return None, f"{type(exc).__name__}: {exc}".replace("\n", "; ")
