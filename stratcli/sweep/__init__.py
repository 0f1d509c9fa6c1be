"""Sweeps: many tasks of one base scenario, planned on a process pool or a Dask cluster.

`spec` reads and validates sweep files, `worker` plans one task into a row, `run` runs the
tasks on an executor into a sweep directory (durable, resumable), `outputs` writes the table,
summary and plots. The use cases are `stratcli.api.run_sweep` and `stratcli.api.read_sweep`.
"""

from .run import ExecutorInfo, SweepOutcome, dask_executor, local_executor, run_sweep
from .spec import Sweep, SweepTask, load_sweep
from .worker import STATUSES, TIMING_COLUMNS, run_task

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
