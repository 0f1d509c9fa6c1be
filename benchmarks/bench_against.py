"""Planning CPU time of scenarios in this checkout against another, side by side.

Usage: python benchmarks/bench_against.py DIR [--rounds 5] [--plans 9] [SCENARIO ...]  (a shipped
scenario's name, or a scenario file's path)

DIR is another checkout (e.g. `git archive REV | tar -x -C DIR`). Each round runs one fresh
process per checkout, alternating; each process plans every scenario once untimed (model
compilation), then `--plans` times, and reports the median CPU time (time.process_time) per
plan and the plan's energy. Printed: per scenario the median over the rounds for each
checkout, their ratio and the two energies. On a shared machine whose speed drifts within
minutes, such side-by-side ratios say whether a change made planning faster where absolute
times of separate runs cannot. Default scenarios: the paper's Sim 4 tasks A-D.
(`bench_constraints.py --against DIR` is this, for the constrained scenarios.)
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

from casadi_baseline import scenario_paths

ROOT = Path(__file__).resolve().parents[1]
CHILD = r"""
import json, os, statistics, sys, time
os.environ["OPENBLAS_NUM_THREADS"] = "1"  # as the stratplan command does
sys.path.insert(0, sys.argv[1])
import stratcli
if not stratcli.__file__.startswith(sys.argv[1]):
    sys.exit(f"stratcli was imported from {stratcli.__file__}, not from {sys.argv[1]}")
from stratcli.api.planning import plan_run
from stratcli.scenario import load_scenario
out = {}
for path in sys.argv[3:]:
    task = load_scenario(path)
    plan_run(task, check=False)
    times = []
    for _ in range(int(sys.argv[2])):
        clock = time.process_time()
        result = plan_run(task, check=False).result
        times.append(time.process_time() - clock)
    out[path] = [statistics.median(times), result.total_energy]
print(json.dumps(out))
"""


def side_by_side(paths: list[Path], other: Path, rounds: int, plans: int) -> dict:
    """Per scenario path: (other's median CPU s, this one's, other's energy, this one's)."""
    roots = {"other": str(other.resolve()), "this": str(ROOT)}
    found: dict[str, dict[str, list]] = {k: {str(p): [] for p in paths} for k in roots}
    for round_ in range(rounds):
        # each round swaps which goes first, so that an order effect cannot pass for a
        # speed-up (the same code on both sides, always second, measured 0.82x on task C)
        for which, root in list(roots.items())[:: 1 if round_ % 2 == 0 else -1]:
            argv = [sys.executable, "-c", CHILD, root, str(plans), *map(str, paths)]
            done = subprocess.run(argv, capture_output=True, text=True, check=True, cwd=ROOT)
            for path, row in json.loads(done.stdout).items():
                found[which][path].append(row)
    out = {}
    for path in map(str, paths):
        o, t = found["other"][path], found["this"][path]
        median = [statistics.median(r[0] for r in rows) for rows in (o, t)]
        out[path] = (*median, o[0][1], t[0][1])
    return out


def report(names: list[str], paths: list[Path], other: Path, rounds: int, plans: int) -> None:
    """`side_by_side`, printed as a table."""
    rows = side_by_side(paths, other, rounds, plans)
    print(f"this checkout vs {other}: CPU ms per plan, median of {rounds} rounds of "
          f"{plans} plan{'s' if plans != 1 else ''} (fresh processes, alternating)")  # fmt: skip
    print(f"{'scenario':26} {'other ms':>9} {'this ms':>9} {'other/this':>10}  energies")
    for name, path in zip(names, paths, strict=True):
        o, t, e_o, e_t = rows[str(path)]
        print(f"{name:26} {1000 * o:9.1f} {1000 * t:9.1f} {o / t:10.2f}  {e_o:.6f} -> {e_t:.6f}")


def not_a_checkout(other: Path) -> str:
    """Why `other` cannot be compared with (its children would import this checkout's
    stratcli and compare it with itself), or ""."""
    if (other / "stratcli" / "__init__.py").is_file():
        return ""
    return f"{other} is not a checkout of stratplan (no stratcli/__init__.py)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("other", type=Path, help="The other checkout.")
    parser.add_argument("scenarios", nargs="*", default=[f"sim4_task_{t}" for t in "abcd"])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--plans", type=int, default=9)
    args = parser.parse_intermixed_args()
    if why := not_a_checkout(args.other):
        parser.error(why)
    paths = scenario_paths(args.scenarios)
    report(args.scenarios, paths, args.other, args.rounds, args.plans)


if __name__ == "__main__":
    main()
