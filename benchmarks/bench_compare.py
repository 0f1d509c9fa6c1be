"""Whole-process cost of `stratplan compare-sequences` on the Sim 4 task (issue 15 item 4).

The command, as a user runs it: all 36 candidates (sequences of up to 3 strata, both
strategies), the energy objective and criterion, 2 processes, the full record:

    stratplan compare-sequences scenarios/sim4_auto.toml --strategy both --jobs 2

Each run is a fresh process (`python -m stratcli ...`); wall time is measured around it, CPU
time is the user + system time of the finished child and its workers
(`getrusage(RUSAGE_CHILDREN)`). The phases come from each record's manifest.json. A first,
untimed run fills the model cache, so every timed run is warm. With `--against DIR` (another
checkout, e.g. /work/main) the same command runs from that checkout too, round-robin with this
one, so that both see the same load on a shared machine: compare them side by side.

    python benchmarks/bench_compare.py [--runs 5] [--against /work/main] [--exhaustive]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = "scenarios/sim4_auto.toml"
PHASES = ("import", "planning", "plots", "comparison files")


def measure(checkout: Path, argv: list[str], out: Path) -> dict[str, float]:
    """Wall, CPU and the manifest's phases (wall s) of one run from `checkout`."""
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # bytecode caching on, as on a user's machine
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    clock = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "stratcli", *argv, "--out", str(out)],
        cwd=checkout,
        env=env,
        check=True,
        stdout=subprocess.DEVNULL,
    )
    wall = time.perf_counter() - clock
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    run = max(out.iterdir(), key=lambda p: p.stat().st_mtime)
    manifest = json.loads((run / "manifest.json").read_text())
    phases = {k: v["wall_s"] for k, v in manifest.get("phases", {}).items()}
    phases["planning"] = manifest.get("planning_time_s", float("nan"))
    return {"wall": wall, "cpu": cpu, **phases}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help="Runs per checkout (median; ≥ 5).")
    parser.add_argument("--against", type=Path, help="Another checkout to run beside this one.")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--exhaustive", action="store_true", help="Pass --exhaustive.")
    args = parser.parse_args()
    argv = ["compare-sequences", SCENARIO, "--strategy", "both", "--jobs", str(args.jobs)]
    argv += ["--exhaustive"] if args.exhaustive else []
    checkouts = {"this checkout": ROOT}
    if args.against is not None:
        checkouts[str(args.against)] = args.against.resolve()
    load_before = os.getloadavg()
    times: dict[str, list[dict[str, float]]] = {label: [] for label in checkouts}
    with tempfile.TemporaryDirectory() as tmp:
        for label, checkout in checkouts.items():  # warm: the model cache
            measure(checkout, argv, Path(tmp) / label.replace("/", "_"))
        for _ in range(args.runs):
            for label, checkout in checkouts.items():
                times[label].append(measure(checkout, argv, Path(tmp) / label.replace("/", "_")))
    load_after = os.getloadavg()
    print(f"`stratplan {' '.join(argv)}`: {args.runs} runs each, round-robin; {os.cpu_count()}")
    print(
        f"cores; load average (1, 5, 15 min) {', '.join(f'{x:.2f}' for x in load_before)} "
        f"before, {', '.join(f'{x:.2f}' for x in load_after)} after\n"
    )
    header = " | ".join(f"{p} s" for p in PHASES)
    print(f"| checkout | wall median s | wall min s | CPU median s | {header} |")
    print("|---|---:|---:|---:|" + "---:|" * len(PHASES))
    for label, runs in times.items():
        wall = [r["wall"] for r in runs]
        cpu = statistics.median(r["cpu"] for r in runs)
        phases = " | ".join(
            f"{statistics.median(r.get(p, float('nan')) for r in runs):.2f}" for p in PHASES
        )
        print(
            f"| {label} | {statistics.median(wall):.2f} | {min(wall):.2f} | {cpu:.2f} | {phases} |"
        )
    print("\nphases: wall seconds from each record's manifest.json (medians)")


if __name__ == "__main__":
    main()
