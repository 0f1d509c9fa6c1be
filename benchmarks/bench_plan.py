"""Median planning time of every shipped scenario, both objectives (no start-up, no I/O).

Usage: python benchmarks/bench_plan.py [--repeats N] [SCENARIO ...]

Model compilation (sympy → numpy, once per stratum per process) happens in a warm-up run
and is reported separately; the timed runs call `plan_sequence` only. `newton` is the
paper's method; `energy` (the default objective) adds the multi-start minimum-energy search.
"""

from __future__ import annotations

import os

# as the stratplan command does (stratcli/__main__.py): no BLAS threads for small matrices
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import platform
import statistics
import time
from dataclasses import replace
from pathlib import Path

from casadi_baseline import scenario_paths

from stratcli.objectives import plan_sequence
from stratcli.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def timed(task, settings, repeats: int):
    result = plan_sequence(task.system, task.start, task.legs, settings)  # warm-up
    times = []
    for _ in range(repeats):
        clock = time.perf_counter()
        result = plan_sequence(task.system, task.start, task.legs, settings)
        times.append(time.perf_counter() - clock)
    return result, 1e3 * statistics.median(times)


def bench(path: Path, repeats: int) -> dict:
    task = load_scenario(path)
    clock = time.perf_counter()
    for leg in task.legs:
        task.system.compiled(leg.stratum)
    compile_time = time.perf_counter() - clock
    newton, newton_ms = timed(task, replace(task.settings, objective="newton"), repeats)
    row = {
        "scenario": task.scenario.name,
        "legs": len(task.legs),
        "paper": task.scenario.reference.energy if task.scenario.reference else None,
        "newton": newton,
        "newton_ms": newton_ms,
        "compile_ms": 1e3 * compile_time,
        "energy": None,
    }
    if task.settings.objective == "energy":
        row["energy"], row["energy_ms"] = timed(task, task.settings, repeats)
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenarios", nargs="*", help="names or paths (default: every shipped one)")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    paths = (
        scenario_paths(args.scenarios) if args.scenarios else sorted(ROOT.glob("scenarios/*.toml"))
    )
    print(
        f"{platform.processor() or platform.machine()}, Python {platform.python_version()}, "
        f"median of {args.repeats} timed runs after a warm-up\n"
    )
    print(
        "| scenario | legs | paper energy | Newton energy | Newton ms | energy-optimal "
        "| energy-optimal ms | compile ms |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for path in paths:
        if not load_scenario(path).legs:
            continue  # auto mode ([decompose], no legs): benchmarks/bench_decompose.py
        r = bench(path, args.repeats)
        paper = f"{r['paper']:.2f}" if r["paper"] else "–"
        newton = r["newton"]
        n_txt = f"{newton.total_energy:.2f}" if newton.ok else "failed"
        if r["energy"] is None:
            e_txt, e_ms = "(scenario asks for newton)", "–"
        else:
            e_txt = f"{r['energy'].total_energy:.2f}" if r["energy"].ok else "failed"
            e_ms = f"{r['energy_ms']:.0f}"
        print(
            f"| {r['scenario']} | {r['legs']} | {paper} | {n_txt} | {r['newton_ms']:.1f} | "
            f"{e_txt} | {e_ms} | {r['compile_ms']:.0f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
