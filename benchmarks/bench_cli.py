"""Whole-process cost of `stratplan` commands, beside `python -c "import numpy"`.

Each command runs as a fresh process (`python -m stratcli ...` from this checkout) `--runs`
times, round-robin so that a burst of load on the machine touches every command alike. Wall
time is measured around the process; CPU time is the user + system time of the finished child
(`getrusage(RUSAGE_CHILDREN)`), which on a shared, noisy machine is the number to trust.
Medians are printed as a markdown table, with the load average before and after.

A first, untimed `plan` run creates the record `show` reads and fills the model cache
(`stratcli.models.codecache`), so the `plan` rows are warm runs: what a user sees from the
second run on.

    python benchmarks/bench_cli.py [--runs 5]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = "scenarios/sim4_task_d.toml"


def commands(out: Path, run: Path) -> dict[str, list[str]]:
    """Label -> argv (after the interpreter) of every measured process."""
    cli = ["-m", "stratcli"]
    return {
        'python -c "import numpy"': ["-c", "import numpy"],
        "stratplan --help": [*cli, "--help"],
        "stratplan --version": [*cli, "--version"],
        "stratplan models": [*cli, "models"],
        "stratplan runs": [*cli, "runs", "--out", str(out)],
        "stratplan show RUN": [*cli, "show", str(run)],
        f"stratplan plan {SCENARIO}": [*cli, "plan", SCENARIO, "-q", "--out", str(out)],
        f"stratplan plan {SCENARIO} --animation": [
            *cli,
            "plan",
            SCENARIO,
            "-q",
            "--animation",
            "--out",
            str(out),
        ],
    }


def measure(argv: list[str], env: dict[str, str]) -> tuple[float, float]:
    """(wall, CPU) seconds of one process running `python argv`."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    clock = time.perf_counter()
    subprocess.run(
        [sys.executable, *argv], cwd=ROOT, env=env, check=True, stdout=subprocess.DEVNULL
    )
    wall = time.perf_counter() - clock
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help="Runs per command (median; ≥ 5).")
    args = parser.parse_args()
    # Bytecode caching on, as on a user's machine: with PYTHONDONTWRITEBYTECODE set (some CI
    # images set it) every run compiles stratplan's ~70 modules from source, ~0.14 s CPU.
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "runs"
        warm = ["-m", "stratcli", "plan", SCENARIO, "-q", "--out", str(out)]
        subprocess.run([sys.executable, *warm], cwd=ROOT, env=env, check=True)
        (run,) = out.iterdir()
        table = commands(out, run)
        times: dict[str, list[tuple[float, float]]] = {label: [] for label in table}
        for _ in range(args.runs):
            for label, argv in table.items():
                times[label].append(measure(argv, env))
    load_after = os.getloadavg()
    numpy_cpu = statistics.median(c for _, c in times['python -c "import numpy"'])
    print(f"{args.runs} runs each, round-robin; {os.cpu_count()} cores; load average (1, 5, 15")
    print(
        f"min) {', '.join(f'{x:.2f}' for x in load_before)} before, "
        f"{', '.join(f'{x:.2f}' for x in load_after)} after\n"
    )
    print("| command | wall median (s) | CPU median (s) | CPU ÷ numpy import |")
    print("|---|---:|---:|---:|")
    for label, runs in times.items():
        wall = statistics.median(w for w, _ in runs)
        cpu = statistics.median(c for _, c in runs)
        print(f"| `{label}` | {wall:.3f} | {cpu:.3f} | {cpu / numpy_cpu:.1f}× |")


if __name__ == "__main__":
    main()
