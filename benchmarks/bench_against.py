"""Planning CPU time of scenarios in this checkout against another, side by side.

Usage: python benchmarks/bench_against.py DIR [--rounds 5] [--plans 9] [SCENARIO ...]

DIR is another checkout (e.g. `git archive REV | tar -x -C DIR`). Each round runs one fresh
process per checkout, alternating; each process plans every scenario once untimed (model
compilation), then `--plans` times, and reports the median CPU time (time.process_time) per
plan. Printed: per scenario the median over the rounds for each checkout and their ratio.
On a shared machine whose speed drifts within minutes, such side-by-side ratios say whether
a change made planning faster where absolute times of separate runs cannot. Default
scenarios: the paper's Sim 4 tasks A-D.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CHILD = r"""
import json, os, statistics, sys, time
os.environ["OPENBLAS_NUM_THREADS"] = "1"  # as the stratplan command does
sys.path.insert(0, sys.argv[1])
from stratcli.api.planning import plan_run
from stratcli.scenario import load_scenario
out = {}
for path in sys.argv[3:]:
    task = load_scenario(path)
    plan_run(task, check=False)
    times = []
    for _ in range(int(sys.argv[2])):
        clock = time.process_time()
        plan_run(task, check=False)
        times.append(time.process_time() - clock)
    out[path] = statistics.median(times)
print(json.dumps(out))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("other", type=Path, help="The other checkout.")
    parser.add_argument("scenarios", nargs="*", default=[f"sim4_task_{t}" for t in "abcd"])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--plans", type=int, default=9)
    args = parser.parse_intermixed_args()
    paths = [str(ROOT / "scenarios" / f"{name}.toml") for name in args.scenarios]
    roots = {"other": str(args.other.resolve()), "this": str(ROOT)}
    times: dict[str, dict[str, list[float]]] = {k: {p: [] for p in paths} for k in roots}
    for _ in range(args.rounds):
        for which, root in roots.items():
            argv = [sys.executable, "-c", CHILD, root, str(args.plans), *paths]
            done = subprocess.run(argv, capture_output=True, text=True, check=True, cwd=ROOT)
            for path, seconds in json.loads(done.stdout).items():
                times[which][path].append(seconds)
    print(f"this checkout vs {args.other}: CPU ms per plan, median of {args.rounds} rounds of "
          f"{args.plans} plans (fresh processes, alternating)")  # fmt: skip
    print(f"{'scenario':26} {'other ms':>9} {'this ms':>9} {'other/this':>10}")
    for name, path in zip(args.scenarios, paths, strict=True):
        other = statistics.median(times["other"][path])
        this = statistics.median(times["this"][path])
        print(f"{name:26} {1000 * other:9.1f} {1000 * this:9.1f} {other / this:10.2f}")


if __name__ == "__main__":
    main()
