"""Sweep use cases: plan a sweep file's tasks into a sweep directory; read one back."""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from concurrent.futures import Executor
from contextlib import nullcontext
from dataclasses import dataclass
from itertools import islice
from pathlib import Path
from typing import Any

from ..arguments import checked, choice, flag, instance, integer, optional, pathlike, source
from ..frozen_json import HoldsDocument
from ..records import sweepdir, sweeplock
from ..sweep.executors import ExecutorInfo, dask_executor
from ..sweep.outputs import MAX_LISTED, summarise
from ..sweep.run import RECORDS, Progress, SweepOutcome, tally
from ..sweep.run import run_sweep as run_tasks
from ..sweep.spec import Sweep, load_sweep


@dataclass(frozen=True)
class SweepReport(HoldsDocument):
    """A sweep directory read back: spec.json, the rows, and the summary of them.

    Attributes
    ----------
    path : Path
        The sweep's directory.
    spec : dict
        spec.json: the sweep file as it was run.
    rows : dict of int to dict
        Each task's row, by task index.
    summary : dict
        sweep.json when the sweep finished, else computed from the rows.
    finished : bool
        sweep.json was written (the last run got to the end).
    """

    _documents = ("spec", "rows", "summary")  # read-only (`frozen_json`)

    path: Path
    spec: dict[str, Any]
    rows: dict[int, dict[str, Any]]
    summary: dict[str, Any]  # sweep.json when the sweep finished, else computed from the rows
    finished: bool  # sweep.json was written (the last run got to the end)

    def __repr__(self) -> str:  # the dataclass's prints every row (kB per 10 tasks)
        state = "finished" if self.finished else "unfinished"
        return f"SweepReport({tally(self.summary, self.path)}, {state})"


@checked(
    file=source("sweep", Sweep),
    out=optional(pathlike),
    jobs=optional(integer(1)),
    dask=optional(instance("an address or file name", str, os.PathLike)),
    resume=flag,
    records=choice(*RECORDS),
    progress=optional(instance("a callable", Callable)),  # type: ignore[arg-type]
)
def run_sweep(
    file: str | Path | Mapping[str, Any] | Sweep,
    out: str | Path | None = None,
    *,
    jobs: int | None = None,
    dask: str | os.PathLike | None = None,
    executor: Executor | None = None,
    resume: bool = False,
    records: str = "failed",
    progress: Progress | None = None,
) -> SweepOutcome:
    """Plan every task of a sweep file (durably, resumably) and write its table and plots.

    Parameters
    ----------
    file : str, Path, Mapping or Sweep
        What `stratcli.sweep.load_sweep` takes (a sweep file's path, TOML text or a dict of
        the same structure, whose base scenario may be a `Task`: ``{"sweep": {...},
        "scenario": task}``), or a sweep it loaded.
    out : str or Path, optional
        The sweep directory (default: ``sweeps/<name>``).
    jobs : int, optional
        Local worker processes (default: all cores; no more than the tasks to plan, nor than
        4 a core: `trie.most_workers`); ignored with `dask` or `executor`.
    dask : str, optional
        A Dask scheduler's address or scheduler JSON file: run the tasks on that cluster.
    executor : concurrent.futures.Executor, optional
        Any executor to run the tasks on (not shut down here).
    resume : bool
        Finish the sweep in `out`: plan only the tasks it has no row of.
    records : str
        Full run records under ``out/records``: best | failed | all | none.
    progress : callable, optional
        Called as `progress(done, total)` as tasks finish.

    Returns
    -------
    SweepOutcome
        Every row, sweep.json, and the tasks still missing (their worker died).

    Raises
    ------
    InputError
        A bad sweep file (every problem, one line each), a bad `out` (one another sweep is
        writing into, too), or `resume` on a directory of another sweep.
    RuntimeError
        `executor` refused the first task (one already shut down, say); the directory is
        left as an interrupted sweep's, for `resume`.
    """
    loaded = file if isinstance(file, Sweep) else load_sweep(file)
    target = loaded.out_dir(out)
    context = (
        dask_executor(os.fspath(dask))
        if dask is not None and executor is None
        else nullcontext((executor, None))
    )
    with sweeplock.claimed(target), context as (chosen, info):  # one writer per directory
        return run_tasks(
            loaded,
            target,
            executor=chosen,
            info=info if chosen is not None else None,
            jobs=jobs,
            resume=resume,
            records=records,
            progress=progress,
        )


# sweep.json's keys about the run that wrote it, for rows no run has summarised (it was killed)
UNSUMMARISED = {
    "executor": None,
    "wall_time_s": None,
    "planned_this_run": None,
    "resumed_rows": None,
    "tasks_per_s": None,
    "started": None,
    "finished": None,
    "records_lost": [],
    "plots": [],
}


@checked(path=pathlike)
def read_sweep(path: str | Path) -> SweepReport:
    """Read a sweep directory back (also one whose run was killed: its rows so far).

    Parameters
    ----------
    path : str or Path
        A sweep directory (`sweep`'s `out`).

    Returns
    -------
    SweepReport

    Raises
    ------
    InputError
        Not a sweep directory, or its spec.json is damaged.
    TypeError
        `path` is not a str or Path.
    """
    path = Path(path)
    if not sweepdir.is_sweep_dir(path):
        from ..errors import InputError

        raise InputError(f"{path}: not a sweep directory (no {sweepdir.SPEC})")
    spec, rows, summary = sweepdir.read_sweep_dir(path)
    finished = summary is not None and summary.get("done") == len(rows)
    if not finished:  # the tasks without a row, as sweep.json lists them
        absent = (k for k in range(spec["count"]) if k not in rows)
        missing = list(islice(absent, MAX_LISTED))
        summary = {**UNSUMMARISED, **(summary or {}), **summarise(spec, rows, missing)}
    rows = sweepdir.in_table_order(list(spec.get("keys", [])), rows)  # (as they finished)
    return SweepReport(path, spec, rows, summary, finished)


__all__ = ["ExecutorInfo", "SweepReport", "read_sweep", "run_sweep"]
