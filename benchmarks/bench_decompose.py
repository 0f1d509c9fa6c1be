"""compare-sequences on the paper's Sim 4 task: all sequences up to length 3, both strategies.

Usage: python benchmarks/bench_decompose.py [--repeats N] [--jobs 1 2] [--no-energy]
                                           [--end-to-end]

Times the comparison itself (decomposition, planning every candidate with shared prefixes,
ranking) after a warm-up; model compilation (once per stratum, in the parent before workers
fork) and process start-up are reported separately, as in bench_plan.py. Also reported: the
median of the per-sequence planning times (a sequence's own legs, shared ones included), how
many legs sharing saved, the same work without sharing (plan_sequence per sequence, one
process), and the CPU time the workers used (on a busy machine wall time also measures the
neighbours). The energy objective is timed twice: screened (branch and bound on the legs'
minima, what the command does with the energy criterion; `--repeats` runs) and exhaustive
(every candidate to its minimum, `--exhaustive`; once). `--end-to-end` also times the whole
command as a user runs it, a fresh process per run, with both objectives.
"""

from __future__ import annotations

import os

# as the stratplan command does (stratcli/__main__.py): no BLAS threads for small matrices
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import dataclasses
import multiprocessing
import os
import platform
import re
import statistics
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from stratcli.compare import SCREEN_TOP, compare, compile_strata
from stratcli.decomposition import decompose
from stratcli.objectives import plan_sequence
from stratcli.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "sim4_auto.toml"


def _with_objective(settings, objective: str):
    if "objective" not in {f.name for f in dataclasses.fields(settings)}:
        return None
    return dataclasses.replace(settings, objective=objective)


def _cpu() -> float:
    """CPU seconds of this process and its finished children."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def _busy(n: int) -> int:
    s = 0
    for i in range(n):
        s += i * i
    return s


def parallel_capacity(jobs: int, n: int = 3_000_000) -> float:
    """Speed-up of `jobs` processes on a pure CPU loop right now (neighbours take cores too)."""
    clock = time.perf_counter()
    for _ in range(jobs):
        _busy(n)
    serial = time.perf_counter() - clock
    with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("fork")) as pool:
        clock = time.perf_counter()
        list(pool.map(_busy, [n] * jobs))
        parallel = time.perf_counter() - clock
    return serial / parallel


def run(task, candidates, settings, jobs: int, repeats: int, screen=None) -> dict:
    walls, cpus, result = [], [], None
    for _ in range(repeats):
        cpu = _cpu()
        result = compare(task.system, task.start, candidates, settings, jobs=jobs, screen=screen)
        walls.append(result.wall_time)
        cpus.append(_cpu() - cpu)
    per_sequence = [o.planning_time for o in result.outcomes]
    return {
        "jobs": jobs,
        "median_s": statistics.median(walls),
        "min_s": min(walls),
        "cpu_s": statistics.median(cpus),
        "per_sequence_ms": 1e3 * statistics.median(per_sequence),
        "ok": sum(o.ok for o in result.outcomes),
        "requested": result.legs_requested,
        "planned": result.legs_planned,
        "best": f"{result.best.candidate.label} {result.best.candidate.strategy}",
        "best_energy": result.best.energy,
    }


def without_sharing(task, candidates, settings) -> float:
    clock = time.perf_counter()
    for cand in candidates:
        plan_sequence(task.system, task.start, list(cand.legs), settings)
    return time.perf_counter() - clock


def end_to_end(objective: str, jobs: int, out: Path, repeats: int) -> dict:
    """`stratplan compare-sequences --strategy both` as a user runs it: a fresh process each
    time (start-up, compile, the search, the whole record), `repeats` times. Wall seconds
    and the CPU seconds of the command and its workers, medians (and the fastest wall)."""
    text = re.sub(r"(?m)^objective\s*=.*$", "", SCENARIO.read_text())
    text = text.replace("[planner]", f'[planner]\nobjective = "{objective}"', 1)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"sim4_auto_{objective}.toml"
    path.write_text(text)
    command = [sys.executable, "-m", "stratcli", "compare-sequences", str(path)]
    options = ["--strategy", "both", "--jobs", str(jobs), "--out", str(out), "--quiet"]
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # bytecode caching on, as on a user's machine
    walls, cpus = [], []
    for _ in range(repeats):
        cpu, clock = _cpu(), time.perf_counter()
        subprocess.run([*command, *options], check=False, env=env)
        walls.append(time.perf_counter() - clock)
        cpus.append(_cpu() - cpu)
    return {"wall": statistics.median(walls), "min": min(walls), "cpu": statistics.median(cpus)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--jobs", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--no-energy", action="store_true", help="skip the energy objective")
    parser.add_argument("--end-to-end", action="store_true", help="also time the command")
    args = parser.parse_args()
    task = load_scenario(SCENARIO)
    dec = decompose(
        task.system, task.start, task.goal, max_length=3, strategies=("conservative", "postponed")
    )
    compile_time = compile_strata(task.system, dec.candidates_strata)
    print(
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}; Sim 4, {len(dec.sequences)} sequences x "
        f"{len(dec.strategies)} strategies = {len(dec.candidates)} candidates; model compiled "
        f"in {compile_time * 1e3:.0f} ms; load average {os.getloadavg()[0]:.2f}; a CPU "
        f"loop ran {parallel_capacity(max(args.jobs)):.2f}x faster on {max(args.jobs)} "
        "processes than on one\n"
    )
    print(
        "| objective | jobs | median wall s | min wall s | CPU s | per-sequence median ms | "
        "reached goal | legs planned / requested | best |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    newton = _with_objective(task.settings, "newton") or task.settings
    compare(task.system, task.start, dec.candidates, newton, jobs=1)  # warm-up (caches)
    objectives = [("newton", newton, args.repeats, None)]
    energy = _with_objective(task.settings, "energy")
    if args.no_energy:
        pass
    elif energy is None:
        print("(energy objective: not in the planner settings yet, skipped)")
    else:
        # the command's default with the energy criterion: screened (branch and bound)
        objectives.append(("energy, screened", energy, args.repeats, SCREEN_TOP))
        objectives.append(("energy, exhaustive", energy, 1, None))
    for name, settings, repeats, screen in objectives:
        for jobs in args.jobs:
            r = run(task, dec.candidates, settings, jobs, repeats, screen)
            print(
                f"| {name} | {jobs} | {r['median_s']:.2f} | {r['min_s']:.2f} | {r['cpu_s']:.2f} "
                f"| {r['per_sequence_ms']:.0f} | {r['ok']}/{len(dec.candidates)} | "
                f"{r['planned']} / {r['requested']} ({r['requested'] - r['planned']} saved) | "
                f"{r['best']} {r['best_energy']:.2f} |",
                flush=True,
            )
    alone = without_sharing(task, dec.candidates, newton)
    print(f"\nnewton without sharing (plan_sequence per candidate, 1 process): {alone:.2f} s")
    if args.end_to_end:
        out = Path(os.environ.get("TMPDIR", "/tmp")) / "bench_decompose_runs"
        print(
            "\n`stratplan compare-sequences sim4_auto.toml --strategy both --jobs J` (whole "
            f"command: start-up, compile, search, record; {args.repeats} runs, medians)\n"
        )
        print("| objective | jobs | median wall s | min wall s | CPU s (command + workers) |")
        print("|---|---|---|---|---|")
        for name in ("newton", "energy"):
            for jobs in args.jobs:
                r = end_to_end(name, jobs, out, args.repeats)
                print(
                    f"| {name} | {jobs} | {r['wall']:.2f} | {r['min']:.2f} | {r['cpu']:.2f} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
