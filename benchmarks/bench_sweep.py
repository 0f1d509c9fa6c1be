"""Sweep throughput: Sim-4-like random tasks on 1 and 2 local processes and a Dask cluster.

Usage: python benchmarks/bench_sweep.py [--newton 1000] [--energy 200] [--seed 0]
                                        [--no-dask] [--keep DIR]

The tasks (issue 18, item 5) are the paper's Sim 4 task A (`scenarios/sim4_task_a.toml`,
sequence S1, S2 with its via, lr-C1) with the goal's q1 drawn from [-π/2, 0] and θ from
[-0.5, 0] per task (`[sweep.random]`, per-task `SeedSequence`), planned in legs mode:
`--newton` tasks with the Newton objective (the paper's method), `--energy` tasks with the
energy objective. Each set is run by `stratcli.run_sweep` (rows fsync'd as they come, the
table, sweep.json and the plots at the end: everything `stratplan sweep` does but drawing
the progress bar) on

* a local process pool of 1 worker, and of 2 workers (`--jobs 1`, `--jobs 2`),
* a `distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1)` started
  before the clock starts (the sweep connects to it by address, as `--dask ADDRESS` does),
  after the local pools have run: a running cluster keeps an event-loop thread in this
  process, so local workers would be spawned instead of forked (`local_executor`), and its
  idle processes would share the cores.

Printed per run, as markdown: wall time (one run each, `time.perf_counter()` around
`run_sweep`, worker start-up included), tasks/s, the planner's own time per task (median of
the rows' `planning_time_s`), the time in the worker beyond planning (median of
`task_time_s - planning_time_s`: loading the scenario dict, the controllability check,
peak |u| and excursion) and the overhead per task beyond planning: `wall × workers / tasks -
mean planning_time_s` (what a task costs the pool beyond the planner: dispatch, the worker's
own part, the fsync'd row, start-up shared out). Parallel efficiency of a 2-worker run:
`throughput(2) / (2 × throughput(1))`. The rows are checked identical (timing columns aside)
across the three runs. CPU ms/task: user + system time of this process and the local pool's
workers (joined at the end of the sweep, so counted by `RUSAGE_CHILDREN`) per task; not
measured for Dask, whose workers outlive the run. The load average is printed before and
after: on a shared machine, wall times and the efficiency follow the other load, CPU does not.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # as the stratplan command does, before numpy loads

import argparse
import platform
import resource
import shlex
import statistics
import sys
import tempfile
import time
from pathlib import Path

import stratcli
from stratcli.sweep import TIMING_COLUMNS, load_sweep, run_sweep

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "sim4_task_a.toml"


def sweep_file(folder: Path, objective: str, count: int, seed: int) -> Path:
    path = folder / f"bench_{objective}.toml"
    path.write_text(
        f'[sweep]\nname = "bench_{objective}"\nscenario = "{SCENARIO}"\nmode = "legs"\n'
        f'set = {{ "planner.objective" = "{objective}" }}\n\n[sweep.random]\n'
        f"count = {count}\nseed = {seed}\n"
        'ranges = { "goal.q1" = ["-pi/2", 0], "goal.theta" = [-0.5, 0.0] }\n'
    )
    return path


def measure(label: str, path: Path, out: Path, workers: int, **how) -> dict:
    sweep = load_sweep(path)
    cpu = _cpu()
    clock = time.perf_counter()
    outcome = run_sweep(sweep, out, records="none", **how)
    wall = time.perf_counter() - clock
    cpu = _cpu() - cpu  # the local pool's workers are joined: counted; Dask's are not
    rows = list(outcome.rows.values())
    planning = [r["planning_time_s"] or 0.0 for r in rows]
    inside = [r["task_time_s"] - (r["planning_time_s"] or 0.0) for r in rows]
    n = len(rows)
    return {
        "label": label,
        "workers": workers,
        "tasks": n,
        "ok": sum(r["status"] == "ok" for r in rows),
        "wall": wall,
        "rate": n / wall,
        "planning_median": statistics.median(planning),
        "planning_mean": statistics.fmean(planning),
        "inside_median": statistics.median(inside),
        "overhead": wall * workers / n - statistics.fmean(planning),
        "cpu": cpu / n if "executor" not in how else None,
        "rows": {
            k: {c: v for c, v in r.items() if c not in TIMING_COLUMNS}
            for k, r in outcome.rows.items()
        },
    }


def _cpu() -> float:
    """CPU seconds (user + system) of this process and its joined child processes."""
    own, children = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def report(objective: str, runs: list[dict]) -> None:
    print(f"\n### {objective} objective, {runs[0]['tasks']} tasks ({runs[0]['ok']} reached)\n")
    print(
        "| executor | workers | wall s | tasks/s | planning ms (median) | in worker beyond "
        "planning ms (median) | overhead/task beyond planning ms | CPU ms/task | "
        "parallel efficiency |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    one = runs[0]["rate"]
    for r in runs:
        eff = f"{100 * r['rate'] / (r['workers'] * one):.0f} %" if r["workers"] > 1 else "–"
        cpu = "–" if r["cpu"] is None else f"{1e3 * r['cpu']:.1f}"
        print(
            f"| {r['label']} | {r['workers']} | {r['wall']:.1f} | {r['rate']:.1f} | "
            f"{1e3 * r['planning_median']:.1f} | {1e3 * r['inside_median']:.1f} | "
            f"{1e3 * r['overhead']:.1f} | {cpu} | {eff} |"
        )
    same = all(r["rows"] == runs[0]["rows"] for r in runs)
    print(f"\nrows identical across executors (timing columns aside): {same}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--newton", type=int, default=1000)
    parser.add_argument("--energy", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-dask", action="store_true")
    parser.add_argument("--keep", type=Path, default=None, help="keep the sweep directories")
    args = parser.parse_args()
    print(f"`python {shlex.join(sys.argv)}`  ")
    print(f"stratplan {stratcli.__version__}, Python {platform.python_version()}, "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}")  # fmt: skip
    folder = args.keep or Path(tempfile.mkdtemp(prefix="bench-sweep-"))
    folder.mkdir(parents=True, exist_ok=True)
    sets = [(o, n) for o, n in (("newton", args.newton), ("energy", args.energy)) if n > 0]
    paths = {o: sweep_file(folder, o, n, args.seed) for o, n in sets}
    # the local pools first, alone: a running LocalCluster keeps an event-loop thread in this
    # process (its workers would then be spawned, not forked) and heartbeats on the cores
    runs = {
        o: [
            measure("process pool", paths[o], folder / f"{o}-1", 1, jobs=1),
            measure("process pool", paths[o], folder / f"{o}-2", 2, jobs=2),
        ]
        for o, _ in sets
    }
    if not args.no_dask:
        from distributed import LocalCluster

        cluster = LocalCluster(
            n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
        )
        try:
            for o, _ in sets:
                with stratcli_dask(cluster.scheduler_address) as (executor, info):
                    runs[o].append(measure("Dask LocalCluster", paths[o], folder / f"{o}-dask",
                                           2, executor=executor, info=info))  # fmt: skip
        finally:
            cluster.close()
    for o, _ in sets:
        report(o, runs[o])
    print(f"load average after: {os.getloadavg()[0]:.2f}")


def stratcli_dask(address: str):
    from stratcli.sweep import dask_executor

    return dask_executor(address)


if __name__ == "__main__":
    main()
