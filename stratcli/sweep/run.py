"""Running a sweep's tasks on any `concurrent.futures.Executor`, durably and resumably.

Each task is a call of `worker.run_task` on the executor: a local process pool
(`local_executor`, the default), a Dask cluster's executor (`dask_executor`), or any other.
Rows come back as tasks complete and are appended to rows.jsonl (fsync'd) at once, so a sweep
killed at any instant loses only the tasks that were running; `resume=True` plans only the
tasks without a row. A task that fails or raises is a row (its status and message); a task
whose worker died (a killed process, Dask's `KilledWorker`) gets no row and is counted as
missing: the sweep says so, and `--resume` plans it again.

Results do not depend on the executor: every task is planned in a worker process that does
nothing else, with single-threaded BLAS (the local pool's processes are forked from a process
whose BLAS is single-threaded, or spawned with `OPENBLAS_NUM_THREADS=1` and friends; a Dask
nanny sets the same variables before its worker starts), and a row holds only the task's own
numbers besides `TIMING_COLUMNS`.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import sys
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from .. import blas
from ..errors import InputError, Problem
from ..records import sweepdir
from ..records.rundir import write_run
from .spawning import BareSpawnContext
from .spec import Sweep
from .worker import run_task

RECORDS = ("best", "failed", "all", "none")
CONNECT_TIMEOUT = "20s"  # to reach a Dask scheduler
PROBE_TIMEOUT = 5.0  # s: a host:port that refuses or does not exist fails before Client waits
# tasks submitted ahead of the rows that came back: enough to keep every worker busy, few
# enough that a sweep of a million tasks does not build a million scenario dicts up front
IN_FLIGHT_PER_WORKER = 8
MIN_IN_FLIGHT = 16
Progress = Callable[[int, int], None]  # (tasks done, tasks in all)


@dataclass(frozen=True)
class ExecutorInfo:
    """What ran the tasks (recorded in sweep.json)."""

    kind: str  # "process-pool", "dask" or the executor's class name
    workers: int
    address: str | None = None


@dataclass(frozen=True)
class SweepOutcome:
    """A sweep run: every row so far, the summary and the files written."""

    out: Path
    rows: dict[int, dict[str, Any]]  # task index -> row (all of the sweep's, by index)
    summary: dict[str, Any]  # sweep.json
    planned: int  # tasks planned by this call
    resumed: int  # rows that were already there (--resume)
    missing: list[int]  # tasks still without a row (their worker died)
    files: list[Path] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        return not self.missing


def local_executor(jobs: int) -> ProcessPoolExecutor:
    """A pool of `jobs` worker processes with single-threaded BLAS.

    On Linux, forked when that is safe: no other thread runs in this process, and its BLAS
    was limited to one thread before numpy loaded (`blas.limited`: the `stratplan` command
    does so first thing; a script can set the three variables before it imports numpy). A
    forked worker starts with what this process has imported, in a few milliseconds instead
    of the 0.3 s a fresh interpreter needs to import numpy, pydantic and the planner.
    Otherwise spawned: a worker imports numpy itself, after the BLAS variables are set,
    whatever threads the calling process runs (a notebook, Dask's client); it does not import
    the caller's `__main__` (`spawning`): a script read from standard input works too, and no
    script needs the `if __name__ == "__main__":` guard. Workers die with the process that
    started them and leave SIGINT to it (`trie.worker_init`).
    """
    from ..trie import worker_init

    fork = _fork_is_safe()
    blas.single_threaded()  # for spawned workers (a forked one has this process's BLAS)
    if fork:
        from .worker import preload

        preload()  # once here, instead of once in every worker
    context = multiprocessing.get_context("fork") if fork else BareSpawnContext()
    return ProcessPoolExecutor(
        max_workers=jobs, mp_context=context, initializer=worker_init, initargs=(os.getpid(),)
    )


def _fork_is_safe() -> bool:
    # not on macOS: system libraries (Accelerate) are not fork-safe, and CPython spawns there
    return sys.platform.startswith("linux") and threading.active_count() == 1 and blas.limited()


@contextmanager
def dask_executor(address: str) -> Iterator[tuple[Executor, ExecutorInfo]]:
    """A Dask cluster's executor: `address` is a scheduler address or a scheduler JSON file.

    Raises
    ------
    InputError
        Naming the argument `dask`: Dask is not installed (the `stratplan[dask]` extra), or
        the scheduler cannot be reached.
    """
    try:
        from distributed import Client
    except ImportError:
        raise _bad_dask(
            None,
            "dask.distributed is not installed (pip install 'stratplan[dask]'; in a source "
            "checkout: pip install -e '.[dask]')",
        ) from None
    target = address
    if address.endswith(".json") or Path(address).is_file():  # a scheduler file: its address
        try:
            target = json.loads(Path(address).read_text())["address"]
            assert isinstance(target, str)
        except (OSError, ValueError, KeyError, TypeError, AssertionError):
            raise _bad_dask(
                address, "not a readable Dask scheduler file (JSON with an address)"
            ) from None
    if (problem := _address_problem(target)) is not None:
        raise _bad_dask(address, problem)
    if (refused := _unreachable(target)) is not None:
        raise _bad_dask(address, f"cannot reach the scheduler ({refused})")
    try:
        client = Client(target, timeout=CONNECT_TIMEOUT)
    except Exception as exc:  # whatever distributed raises for an address it cannot use
        raise _bad_dask(address, f"cannot reach the scheduler ({exc})") from None
    try:
        workers = len(client.scheduler_info().get("workers", {}))
        info = ExecutorInfo("dask", workers, str(client.scheduler.address))
        yield client.get_executor(pure=False), info
    finally:
        client.close()


def _bad_dask(address: str | None, message: str) -> InputError:
    """The error of the `dask` argument (`--dask` on the command line: `cli.render.FLAGS`)."""
    return InputError([Problem("dask", message, given=address)])


def _address_problem(address: str) -> str | None:
    """Why `address` cannot be a scheduler's, as far as its text tells: a port that is not a
    number from 0 to 65535, or an in-process (inproc://) address, which only the process that
    made it can use. None otherwise (other mistakes are left to `Client`'s own words)."""
    from distributed.comm.addressing import parse_address

    try:
        scheme, location = parse_address(address)
    except ValueError:
        return None
    if scheme == "inproc":
        return (
            "an inproc:// address is usable only inside the process that made it; give the "
            "scheduler's tcp:// address (host:port) or its scheduler file"
        )
    if scheme not in ("tcp", "tls", "ws", "wss", "ucx"):
        return None
    if location.startswith("["):  # [IPv6]:port
        _, _, rest = location.partition("]")
        colon, port = rest[:1] == ":", rest[1:]
    else:
        _, colon, port = location.partition(":")
        colon = bool(colon) and ":" not in port  # a bare IPv6 address has no port
    if colon and not (port.isascii() and port.isdigit() and int(port) <= 65535):
        return f"invalid port {port!r} (a number from 0 to 65535)"
    return None


def _unreachable(address: str) -> str | None:
    """Why a TCP connection to a scheduler's host:port fails at once (refused, unknown host,
    no route), or None: it connects, it did not answer within `PROBE_TIMEOUT`, or `address`
    is not a TCP one (inproc://, ucx://). `Client` itself retries such failures for
    `CONNECT_TIMEOUT` before giving up; a scheduler that is up sees one connection closed
    before the handshake (logged at INFO level)."""
    import socket

    from distributed.comm.addressing import get_address_host_port, unparse_host_port

    try:
        host, port = get_address_host_port(address)
    except (ValueError, TypeError):  # not host:port (inproc://, no port): Client's message
        return None
    try:
        with socket.create_connection((host, port), timeout=PROBE_TIMEOUT):
            return None
    except TimeoutError:  # slow, not refused: Client waits for it as usual
        return None
    except socket.gaierror as exc:
        return f"unknown host {host!r}: {exc.strerror}"
    except OSError as exc:  # refused, no route to the host
        reason = exc.strerror or str(exc)
        return f"{reason[:1].lower()}{reason[1:]} at {unparse_host_port(host, port)}"


def spec_document(sweep: Sweep) -> dict[str, Any]:
    """spec.json: what the sweep is (its digest is what --resume checks)."""
    return {
        "format": sweepdir.FORMAT,
        "name": sweep.name,
        "description": sweep.description,
        "mode": sweep.mode,
        "kind": sweep.kind,
        "keys": list(sweep.keys),
        "axes": [list(a) for a in sweep.axes],
        "count": sweep.count,
        "random": sweep.random.model_dump() if sweep.random else None,
        "states": list(sweep.states),
        "reference_energy": sweep.reference_energy,
        "source": sweep.source,
        "digest": sweep.digest,
        "created": datetime.now(UTC).isoformat(),
    }


def _stop(executor: Executor, futures: dict[Future, int]) -> None:
    """Cancel what is queued and end the local workers now (a foreign executor: shut down)."""
    if isinstance(executor, ProcessPoolExecutor):
        from ..trie import stop_workers as stop_pool

        stop_pool(executor, futures)
        return
    for future in futures:
        future.cancel()
    executor.shutdown(wait=False, cancel_futures=True)


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
        Worker processes of the default executor (default: all cores).
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
    from ..trie import default_jobs

    if records not in RECORDS:
        raise InputError([Problem("records", f"one of {', '.join(RECORDS)} (got {records!r})")])
    out = Path(out)
    clock, started = time.perf_counter(), datetime.now(UTC)
    rows = sweepdir.prepare(out, spec_document(sweep), sweep.text, resume)
    rows = {k: v for k, v in rows.items() if 0 <= k < sweep.count}
    finished = _finished(out, rows, sweep.count) if resume else None
    if finished is not None:  # nothing to plan: the summary as written, files untouched
        return finished
    resumed = len(rows)
    own = executor is None
    if own:
        jobs = jobs or default_jobs()
        executor = local_executor(jobs)
        info = ExecutorInfo("process-pool", jobs)
    elif info is None:
        workers = getattr(executor, "_max_workers", None) or 0
        info = ExecutorInfo(type(executor).__name__, int(workers))
    advance = progress or (lambda done, total: None)
    per_task = "all" if records == "all" else "failed" if records == "failed" else "none"
    futures: dict[Future, int] = {}
    written: list[Path] = []
    try:
        advance(len(rows), sweep.count)
        with sweepdir.RowLog(out / sweepdir.ROWS) as log:
            todo = sweep.tasks(skip=set(rows))
            window = max(MIN_IN_FLIGHT, IN_FLIGHT_PER_WORKER * max(1, info.workers))
            accepting = _submit(executor, futures, todo, window, sweep, per_task)
            # the plots' matplotlib loads while the workers start (0.3 s each), not after
            # the last task, when nothing else runs: 1.3 ms a task off a 200-task sweep
            from .outputs import finish

            while futures:
                finished, _ = wait(futures, return_when=FIRST_COMPLETED)
                for future in sorted(finished, key=futures.get):
                    index = futures.pop(future)
                    try:
                        result = future.result()
                    except Exception:  # the worker died (not the task: run_task gives rows)
                        continue
                    if result["record"] is not None:  # before the row: a row means it is there
                        written.append(_write_record(out, *result["record"]))
                    log.append(result["row"])
                    rows[index] = result["row"]
                    advance(len(rows), sweep.count)
                if accepting:
                    accepting = _submit(executor, futures, todo, window, sweep, per_task)
        if records == "best":
            best = _best(rows)
            if best is not None and not (out / "records" / f"task-{best:06d}").exists():
                task = next(t for t in sweep.tasks() if t.index == best)
                result = executor.submit(run_task, _payload(sweep, task, "all")).result()
                if result["record"] is not None:
                    written.append(_write_record(out, *result["record"]))
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
        sweep, out, rows, info, wall, planned, resumed, missing, started.isoformat()
    )
    rows = dict(sorted(rows.items()))  # in task order, as results.csv (they came as finished)
    return SweepOutcome(out, rows, summary, planned, resumed, missing, files + written)


def _finished(out: Path, rows: dict[int, dict[str, Any]], count: int) -> SweepOutcome | None:
    """The outcome of a finished sweep (`sweepdir.finished_summary`), or None: killed before
    its summary, it has its tables, plots and summary written again."""
    summary = sweepdir.finished_summary(out, rows, count)
    if summary is None:
        return None
    names = (sweepdir.TABLE, *summary.get("plots", ()))
    files = [out / name for name in names if (out / name).is_file()]
    return SweepOutcome(out, rows, summary, 0, len(rows), [], files)


def _submit(executor, futures: dict, todo: Iterator, window: int, sweep: Sweep, records) -> bool:
    """Submit tasks from `todo` until `window` are in flight (bounded memory and queue);
    False when the executor refuses work (a broken pool: the rest stays missing)."""
    while len(futures) < window:
        task = next(todo, None)
        if task is None:
            return True
        try:
            futures[executor.submit(run_task, _payload(sweep, task, records))] = task.index
        except Exception:  # e.g. BrokenProcessPool after a worker was killed
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
    }


def _write_record(out: Path, name: str, files: dict[str, bytes]) -> Path:
    return write_run(out / "records", name, files)


def _best(rows: dict[int, dict[str, Any]]) -> int | None:
    """The task that reached its goal with the lowest energy (ties: the lower index)."""
    ok = [(r["energy"], k) for k, r in rows.items() if r["status"] == "ok"]
    ok = [(e, k) for e, k in ok if e is not None]
    return min(ok)[1] if ok else None
