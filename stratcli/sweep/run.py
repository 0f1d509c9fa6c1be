"""Running a sweep's tasks on any `concurrent.futures.Executor`, durably and resumably.

Each task is a call of `worker.run_task` on the executor: a local process pool
(`executors.local_executor`, the default), a Dask cluster's executor
(`executors.dask_executor`), or any other.
Rows come back as tasks complete and are appended to rows.jsonl (fsync'd) at once, so a sweep
killed at any instant loses only the tasks that were running; `resume=True` plans only the
tasks without a row. A task that fails or raises is a row (its status and message); a task
whose worker died (a killed process, Dask's `KilledWorker`, a lost connection) is submitted
once more where the executor still takes work (a Dask cluster with other workers; not a local
pool, which a killed worker breaks), else it gets no row and is counted as missing: the sweep
says so, and `--resume` plans it again.

Results do not depend on the executor: every task is planned in a worker process that does
nothing else, with single-threaded BLAS (the local pool's processes are forked from a process
whose BLAS is single-threaded, or spawned with `OPENBLAS_NUM_THREADS=1` and friends; a Dask
nanny sets the same variables before its worker starts), and a row holds only the task's own
numbers besides `TIMING_COLUMNS`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from ..errors import InputError, Problem
from ..frozen_json import HoldsDocument
from ..interrupts import checkpoint
from ..records import sweepdir
from ..records.model_files import sweep_files
from ..records.rundir import write_run
from ..wording import counted
from .executors import ExecutorInfo, local_executor
from .keys import energy_unit, unit_of
from .spec import Sweep
from .worker import own_planners, run_task

RECORDS = ("best", "failed", "all", "none")
# tasks submitted ahead of the rows that came back: enough to keep every worker busy, few
# enough that a sweep of a million tasks does not build a million scenario dicts up front
IN_FLIGHT_PER_WORKER = 8
MIN_IN_FLIGHT = 16
Progress = Callable[[int, int], None]  # (tasks done, tasks in all)


@dataclass(frozen=True)
class SweepOutcome(HoldsDocument):
    """A sweep run: every row so far, the summary and the files written.

    Attributes
    ----------
    out : Path
        The sweep's directory.
    rows : dict of int to dict
        Every row so far, by task index (this call's and those resumed).
    summary : dict
        sweep.json: counts, success rate, executor, wall time, chosen sequences.
    planned, resumed : int
        Tasks planned by this call; rows that were there already (`resume`).
    missing : list of int
        Tasks still without a row (their worker died): run again with `resume`.
    files : list of Path
        What this call wrote (results.csv, sweep.json, plots).
    reprinted : bool
        The sweep was finished before this call: nothing was run or written.
    complete : bool
        Every task has its row.
    """

    _documents = ("rows", "summary", "missing", "files")  # read-only (`frozen_json`)

    out: Path
    rows: dict[int, dict[str, Any]]  # task index -> row (all of the sweep's, by index)
    summary: dict[str, Any]  # sweep.json
    planned: int  # tasks planned by this call
    resumed: int  # rows that were already there (--resume)
    missing: list[int]  # tasks still without a row (their worker died)
    files: list[Path] = field(default_factory=list)
    reprinted: bool = False  # finished before this call (`--resume`): nothing run or written

    @property
    def complete(self) -> bool:
        """Whether every task has its row (a worker that died leaves some: resume)."""
        return not self.missing

    def __repr__(self) -> str:  # the dataclass's prints every row (kB per 10 tasks)
        return f"SweepOutcome({tally(self.summary, self.out)}, {self.planned} planned here)"


def tally(summary: dict[str, Any], path: Path) -> str:
    """A sweep in a repr: `'name' in DIR: 13 of 441 tasks (ok 12, failed 1)`."""
    counts = ", ".join(f"{k} {n}" for k, n in summary.get("counts", {}).items() if n)
    return (
        f"{summary.get('name')!r} in {str(path)!r}: {summary.get('done')} of "
        f"{counted(summary.get('tasks') or 0, 'task')}" + (f" ({counts})" if counts else "")
    )


def _model_kind(sweep: Sweep) -> str | None:
    return (sweep.base.get("model") or {}).get("kind")


def spec_document(sweep: Sweep) -> dict[str, Any]:
    """spec.json: what the sweep is (its digest is what --resume checks)."""
    return {
        "format": sweepdir.FORMAT,
        "name": sweep.name,
        "description": sweep.description,
        "mode": sweep.mode,
        "kind": sweep.kind,
        "keys": list(sweep.keys),
        "units": [unit_of(key, _model_kind(sweep)) for key in sweep.keys],
        "energy_unit": energy_unit(_model_kind(sweep)),
        "axes": [list(a) for a in sweep.axes],
        "count": sweep.count,
        "random": sweep.random.model_dump() if sweep.random else None,
        "states": list(sweep.states),
        "reference_energy": sweep.reference_energy,
        "source": sweep.source,
        "source_path": _file_path(sweep.source),
        "digest": sweep.digest,
        "created": datetime.now(UTC).isoformat(),
    }


def _file_path(source: str) -> str | None:
    """The sweep file's absolute path, where `source` names one (else text or a dict): the
    resume hint of `stratplan show` names it from wherever it runs."""
    try:
        path = Path(source)
        return str(path.resolve()) if path.is_file() else None
    except (OSError, ValueError):  # text that is no path
        return None


def _stop(executor: Executor, futures: dict[Future, int]) -> None:
    """Cancel what is queued and end the local workers now (a foreign executor: shut down)."""
    if isinstance(executor, ProcessPoolExecutor):
        from ..trie import stop_workers as stop_pool

        stop_pool(executor, futures)
        return
    for future in futures:
        future.cancel()
    try:
        executor.shutdown(wait=False, cancel_futures=True)
    except TypeError:  # Dask's ClientExecutor takes no cancel_futures (they are cancelled)
        executor.shutdown(wait=False)


def run_sweep(
    sweep: Sweep,
    out: str | Path,
    *,
    executor: Executor | None = None,
    info: ExecutorInfo | None = None,
    jobs: int | None = None,
    resume: bool = False,
    records: str = "failed",
    progress: Progress | None = None,
) -> SweepOutcome:
    """Plan every task of `sweep` (those without a row, with `resume`) into `out`.

    Parameters
    ----------
    sweep : Sweep
        A validated sweep (`load_sweep`).
    out : str or Path
        The sweep directory (created; with `resume`, the one of an earlier run).
    executor : Executor, optional
        Where tasks run (not shut down here); default: `local_executor(jobs)`.
    info : ExecutorInfo, optional
        What `executor` is, for sweep.json (default: its class name and worker count).
    jobs : int, optional
        Worker processes of the default executor (default: all cores; no more than the
        tasks to plan, nor than 4 a core: `trie.workers_for`).
    resume : bool
        Reopen `out` and plan only the tasks it has no row of.
    records : str
        Run records written under `out/records`: best | failed | all | none.
    progress : callable, optional
        Called as `progress(done, total)` as rows arrive.

    Returns
    -------
    SweepOutcome
        The rows, sweep.json and the tasks still missing (a worker died: resume).
    """
    from ..trie import default_jobs, workers_for

    if records not in RECORDS:
        raise InputError([Problem("records", f"one of {', '.join(RECORDS)} (got {records!r})")])
    out = Path(out)
    clock, started = time.perf_counter(), datetime.now(UTC)
    files = sweep_files(sweep, set(sweepdir.NAMES))
    rows = sweepdir.prepare(out, spec_document(sweep), files, resume)
    rows = {k: v for k, v in rows.items() if 0 <= k < sweep.count}
    finished = _finished(out, rows, sweep) if resume else None
    if finished is not None:  # nothing to plan: the summary as written, files untouched
        return finished
    resumed = len(rows)
    own = executor is None
    if own:
        workers = workers_for(jobs or default_jobs(), sweep.count - len(rows))
        executor = local_executor(workers)
        info = ExecutorInfo("process-pool", workers)
    elif info is None:
        workers = getattr(executor, "_max_workers", None) or 0
        info = ExecutorInfo(type(executor).__name__, int(workers))
    advance = progress or (lambda done, total: None)
    per_task = "all" if records == "all" else "failed" if records == "failed" else "none"
    futures: dict[Future, int] = {}
    payloads: dict[int, dict[str, Any]] = {}  # of the tasks in flight, to submit again
    retried: set[int] = set()  # tasks submitted again after their worker died
    written: list[Path] = []
    lost = _lost_before(out, rows) if resume else {}  # task -> why its record was not made
    try:
        advance(len(rows), sweep.count)
        with sweepdir.RowLog(out / sweepdir.ROWS) as log:
            todo = sweep.tasks(skip=set(rows))
            window = max(MIN_IN_FLIGHT, IN_FLIGHT_PER_WORKER * max(1, info.workers))
            refused: list[Exception] = []
            accepting = _submit(executor, futures, payloads, todo, window, sweep, per_task, refused)
            if refused and not futures:  # not one task taken: no sweep to speak of
                raise RuntimeError(
                    f"executor: refused the sweep's first task ({type(refused[0]).__name__}: "
                    f"{refused[0]}); give one that takes work (not one shut down)"
                ) from refused[0]
            # the plots' matplotlib loads while the workers start (0.3 s each), not after
            # the last task, when nothing else runs: 1.3 ms a task off a 200-task sweep
            from .outputs import finish

            while futures:
                finished, _ = wait(futures, return_when=FIRST_COMPLETED)
                checkpoint()  # a Ctrl-C a finaliser swallowed stops here, with its resume note
                for future in sorted(finished, key=futures.get):
                    index = futures.pop(future)
                    try:
                        result = future.result()
                    except Exception:  # the worker died (not the task: run_task gives rows)
                        if index in retried:  # died twice: missing (`--resume` plans it)
                            payloads.pop(index, None)
                        elif _again(executor, futures, payloads, index):
                            retried.add(index)
                        continue
                    payloads.pop(index, None)
                    _take_record(out, result, index, written, lost)  # before the row: a
                    log.append(result["row"])  # row means its record is there
                    rows[index] = result["row"]
                    advance(len(rows), sweep.count)
                if accepting:
                    accepting = _submit(executor, futures, payloads, todo, window, sweep, per_task)
        checkpoint()
        if records == "best":
            best = _best(rows)
            if best is not None and not (out / "records" / f"task-{best:06d}").exists():
                task = next(t for t in sweep.tasks() if t.index == best)
                result = executor.submit(run_task, _payload(sweep, task, "all")).result()
                _take_record(out, result, best, written, lost)
    except BaseException:  # an interrupt: the rows written so far stay; stop the workers
        _stop(executor, futures)
        raise
    finally:
        if own:
            executor.shutdown(wait=True, cancel_futures=True)
    wall = time.perf_counter() - clock
    planned = len(rows) - resumed
    missing = [k for k in range(sweep.count) if k not in rows]  # their workers died
    summary, files = finish(
        sweep, out, rows, info, wall, planned, resumed, missing, started.isoformat(), lost
    )
    rows = sweepdir.in_table_order(list(sweep.keys), rows)  # (they came as finished)
    return SweepOutcome(out, rows, summary, planned, resumed, missing, files + written)


def _take_record(out: Path, result: dict, index: int, written: list, lost: dict) -> None:
    """Write a task's run record, if its worker made one (an earlier run's failure to make
    it is then over), else keep why it could not (`lost`)."""
    if result["record"] is not None:
        written.append(_write_record(out, *result["record"]))
        lost.pop(index, None)
    if result.get("record_lost"):
        lost[index] = result["record_lost"]


def _lost_before(out: Path, rows: dict[int, dict[str, Any]]) -> dict[int, str]:
    """The records an earlier run of a resumed sweep could not make, of the tasks it keeps
    (sweep.json's records_lost; none if it never wrote one): not planned again, they stay
    reported."""
    summary = sweepdir.read_summary(out)
    entries = (summary.get("records_lost") if isinstance(summary, dict) else None) or []
    if not isinstance(entries, list):
        return {}
    return {
        x["task"]: str(x.get("reason", ""))
        for x in entries
        if isinstance(x, dict) and isinstance(x.get("task"), int) and x["task"] in rows
    }


def _finished(out: Path, rows: dict[int, dict[str, Any]], sweep: Sweep) -> SweepOutcome | None:
    """The outcome of a finished sweep (`sweepdir.finished_summary`), or None: killed before
    its summary, it has its tables, plots and summary written again."""
    summary = sweepdir.finished_summary(out, rows, sweep.count)
    if summary is None:
        return None
    rows = sweepdir.in_table_order(list(sweep.keys), rows)
    names = (sweepdir.TABLE, *summary.get("plots", ()))
    files = [out / name for name in names if (out / name).is_file()]
    return SweepOutcome(out, rows, summary, 0, len(rows), [], files, reprinted=True)


def _submit(
    executor,
    futures: dict,
    payloads: dict,
    todo: Iterator,
    window: int,
    sweep: Sweep,
    records,
    refused: list | None = None,
) -> bool:
    """Submit tasks from `todo` until `window` are in flight (bounded memory and queue), each
    payload kept in `payloads` until its row is in; False when the executor refuses work (a
    broken pool: the rest stays missing), its exception then added to `refused`."""
    while len(futures) < window:
        task = next(todo, None)
        if task is None:
            return True
        payloads[task.index] = _payload(sweep, task, records)
        if not _again(executor, futures, payloads, task.index, refused):
            return False
    return True


def _again(executor, futures: dict, payloads: dict, index: int, refused=None) -> bool:
    """Submit task `index` (its kept payload); False if the executor refuses it (its
    exception then added to `refused`)."""
    try:
        futures[executor.submit(run_task, payloads[index])] = index
    except Exception as exc:  # e.g. BrokenProcessPool after a worker was killed
        payloads.pop(index, None)
        if refused is not None:
            refused.append(exc)
        return False
    return True


def _payload(sweep: Sweep, task, records: str) -> dict[str, Any]:
    return {
        "index": task.index,
        "inputs": task.inputs,
        "seed": task.seed,
        "scenario": task.scenario,
        "mode": sweep.mode,
        "check": sweep.check,
        "exhaustive": sweep.exhaustive,
        "records": records,
        "name": sweep.name,
        "planners": own_planners(),  # a user's own leg planners: imported where not known
    }


def _write_record(out: Path, name: str, files: dict[str, bytes]) -> Path:
    return write_run(out / "records", name, files)


def _best(rows: dict[int, dict[str, Any]]) -> int | None:
    """The task that reached its goal with the lowest energy (ties: the lower index)."""
    ok = [(r["energy"], k) for k, r in rows.items() if r["status"] == "ok"]
    ok = [(e, k) for e, k in ok if e is not None]
    return min(ok)[1] if ok else None
