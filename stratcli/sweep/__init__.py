"""Sweeps: many tasks of one base scenario, planned on a process pool or a Dask cluster.

`spec` reads and validates sweep files, `worker` plans one task into a row, `run` runs the
tasks on an executor (`executors`: a local process pool, a Dask cluster's) into a sweep
directory (durable, resumable), `outputs` writes the table, summary and plots. The use cases
are `stratcli.api.run_sweep` and `stratcli.api.read_sweep`.
"""

from importlib import import_module
from typing import Any

# Names are imported on first use (PEP 562): a worker process imports `sweep.worker` alone,
# not the sweep files' schema and the executors (start-up speed of every worker).
_WHERE = {
    "ExecutorInfo": "executors",
    "SweepOutcome": "run",
    "dask_executor": "executors",
    "local_executor": "executors",
    "run_sweep": "run",
    "Sweep": "spec",
    "SweepTask": "spec",
    "load_sweep": "spec",
    "STATUSES": "worker",
    "TIMING_COLUMNS": "worker",
    "run_task": "worker",
}


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f".{_WHERE[name]}", __name__), name)
    globals()[name] = value
    return value


__all__ = [
    "STATUSES",
    "TIMING_COLUMNS",
    "ExecutorInfo",
    "Sweep",
    "SweepOutcome",
    "SweepTask",
    "dask_executor",
    "load_sweep",
    "local_executor",
    "run_sweep",
    "run_task",
]
