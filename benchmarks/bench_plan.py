"""Median planning time of every shipped scenario (no start-up, no I/O).

Usage: python benchmarks/bench_plan.py [--repeats N] [SCENARIO ...]

Model compilation (sympy → numpy, once per stratum per process) happens in a warm-up run
and is reported separately; the timed runs call `plan_sequence` only.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time
from pathlib import Path

from stratcli.scenario import load_scenario
from stratcli.stratified import plan_sequence

ROOT = Path(__file__).resolve().parents[1]


def bench(path: Path, repeats: int) -> dict:
    task = load_scenario(path)
    clock = time.perf_counter()
    for leg in task.legs:
        task.system.compiled(leg.stratum)
    compile_time = time.perf_counter() - clock
    result = plan_sequence(task.system, task.start, task.legs, task.settings)  # warm-up
    times = []
    for _ in range(repeats):
        clock = time.perf_counter()
        result = plan_sequence(task.system, task.start, task.legs, task.settings)
        times.append(time.perf_counter() - clock)
    return {
        "scenario": task.scenario.name,
        "legs": len(task.legs),
        "status": "ok" if result.ok else "failed",
        "iterations": sum(leg.iterations for leg in result.legs),
        "energy": result.total_energy,
        "paper": task.scenario.reference.energy if task.scenario.reference else None,
        "median_ms": 1e3 * statistics.median(times),
        "min_ms": 1e3 * min(times),
        "compile_ms": 1e3 * compile_time,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenarios", nargs="*", type=Path)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    paths = args.scenarios or sorted((ROOT / "scenarios").glob("*.toml"))
    print(
        f"{platform.processor() or platform.machine()}, Python {platform.python_version()}, "
        f"{args.repeats} timed runs each\n"
    )
    print(
        "| scenario | legs | status | Newton iterations | energy | paper | median ms | min ms "
        "| compile ms |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for path in paths:
        r = bench(path, args.repeats)
        paper = f"{r['paper']:.2f}" if r["paper"] else "–"
        print(
            f"| {r['scenario']} | {r['legs']} | {r['status']} | {r['iterations']} | "
            f"{r['energy']:.2f} | {paper} | {r['median_ms']:.1f} | {r['min_ms']:.1f} | "
            f"{r['compile_ms']:.0f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
