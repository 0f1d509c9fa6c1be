"""Auto mode's screen against the exhaustive search on seeded random one-arm tasks.

Usage: python benchmarks/bench_screen.py [--tasks 20] [--seed 0] [--jobs 2] [--no-sim4]
                                        [--robot one-arm|two-arm] [--no-exhaustive]

Each task draws from `numpy.random.default_rng(seed + i)`: a start within ±π/2 per coordinate
of the one-arm preset, a change of up to ±2.5 rad per joint and ±0.6 rad for θ (as in
bench_random.py), decomposed as auto mode does by default (sequences of up to 3 strata,
conservative vias). Every task's candidates are compared twice with the default (energy)
objective and criterion: screened (`compare(..., screen=SCREEN_TOP)`, auto mode's default:
branch and bound on the legs' minima, `stratcli.screen`) and exhaustive (`screen=None`, every
candidate to its minimum). Prints, as markdown, per task the two planning times
(`Comparison.wall_time`, model compiled before), the CPU time the screen's leg bounds took
(summed over the processes), how many candidates it searched and how many it only bounded,
the two choices and whether they match, then the medians. The Sim 4 task
(scenarios/sim4_auto.toml) comes first.

`--robot two-arm` draws the same kind of tasks for the two-arm preset (5 coordinates, 708
candidates of up to 3 of its 10 strata, lr-C1) and skips Sim 4; `--no-exhaustive` times the
screened comparison only (the exhaustive one takes minutes there).
"""

from __future__ import annotations

import os

# as the stratplan command does (stratcli/__main__.py): no BLAS threads for small matrices
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import platform
import statistics
from pathlib import Path

import numpy as np

from stratcli.compare import SCREEN_TOP, compare, compile_strata
from stratcli.decomposition import decompose
from stratcli.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
SIM4 = ROOT / "scenarios" / "sim4_auto.toml"
MAX_JOINT_CHANGE, MAX_THETA_CHANGE = 2.5, 0.6


def random_task(seed: int, joints: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Start and goal (joints..., θ) of one random task (one-arm: 3 joints)."""
    rng = np.random.default_rng(seed)
    start = rng.uniform(-np.pi / 2, np.pi / 2, joints + 1)
    change = np.concatenate(
        [
            rng.uniform(-MAX_JOINT_CHANGE, MAX_JOINT_CHANGE, joints),
            rng.uniform(-MAX_THETA_CHANGE, MAX_THETA_CHANGE, 1),
        ]
    )
    return start, start + change


def two_arm_task():
    """The two-arm preset with lr-C1 and the default objective and criterion."""
    zero = [0.0] * 5
    return load_scenario(
        {
            "name": "two_arm_auto",
            "model": {"kind": "preset", "name": "two-arm"},
            "task": {"start": zero, "goal": zero},
            "planner": {"continuity": "lr-C1"},
            "decompose": {"max_length": 3},
        }
    )


def both(system, settings, start, goal, jobs: int, exhaustive: bool = True) -> dict:
    """The screened and (if asked) the exhaustive comparison of one task."""
    dec = decompose(system, start, goal, max_length=3, strategies=("conservative",))
    compile_strata(system, dec.candidates_strata)
    runs = {"exhaustive": {"time": float("nan"), "choice": None, "label": "–", "cut": 0}}
    runs["exhaustive"].update(searched=0, bound_s=float("nan"))
    for name, screen in (("screened", SCREEN_TOP), ("exhaustive", None))[: 1 + exhaustive]:
        result = compare(system, start, dec.candidates, settings, jobs=jobs, screen=screen)
        best = result.best
        runs[name] = {
            "time": result.wall_time,
            "choice": (best.candidate.sequence, best.candidate.strategy),
            "label": f"{best.candidate.label} {best.energy:.2f}",
            "cut": sum(o.screened for o in result.outcomes),
            "searched": len(result.screen.searched) if result.screen else len(result.outcomes),
            "bound_s": result.screen.seconds if result.screen else float("nan"),
        }
    runs["candidates"] = len(dec.candidates)
    return runs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--no-sim4", action="store_true")
    parser.add_argument("--robot", choices=("one-arm", "two-arm"), default="one-arm")
    parser.add_argument("--no-exhaustive", action="store_true")
    args = parser.parse_args()
    exhaustive = not args.no_exhaustive
    sim4 = load_scenario(SIM4) if args.robot == "one-arm" else two_arm_task()
    system, settings = sim4.system, sim4.settings
    joints = system.n - 1
    tasks = (
        [] if args.no_sim4 or args.robot == "two-arm" else [("sim4_auto", sim4.start, sim4.goal)]
    )
    tasks += [
        (f"seed {args.seed + i}", *random_task(args.seed + i, joints)) for i in range(args.tasks)
    ]
    print(
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, jobs "
        f"{args.jobs}, screen top {SCREEN_TOP}, load average {os.getloadavg()[0]:.2f}\n"
    )
    print(
        "| task | candidates | screened s | leg bounds CPU s | searched | bounded | "
        "exhaustive s | screened best | exhaustive best | same |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    rows = []
    if args.robot == "one-arm":
        both(system, settings, sim4.start, sim4.goal, args.jobs)  # warm-up (caches)
    for name, start, goal in tasks:
        r = both(system, settings, start, goal, args.jobs, exhaustive)
        same = r["screened"]["choice"] == r["exhaustive"]["choice"]
        rows.append((name, r, same))
        print(
            f"| {name} | {r['candidates']} | {r['screened']['time']:.2f} | "
            f"{r['screened']['bound_s']:.2f} | {r['screened']['searched']} | "
            f"{r['screened']['cut']} | {r['exhaustive']['time']:.2f} | "
            f"{r['screened']['label']} | {r['exhaustive']['label']} | "
            f"{('yes' if same else 'NO') if exhaustive else '–'} |",
            flush=True,
        )
    random_rows = [r for name, r, _ in rows if name.startswith("seed")]
    for label, subset in (("random tasks", random_rows), ("all tasks", [r for _, r, _ in rows])):
        if subset:
            line = (
                f"\nmedian planning time, {label} ({len(subset)}): screened "
                f"{statistics.median(r['screened']['time'] for r in subset):.2f} s"
            )
            if exhaustive:
                median = statistics.median(r["exhaustive"]["time"] for r in subset)
                line += f", exhaustive {median:.2f} s"
            print(line)
    if exhaustive:
        print(f"same choice: {sum(same for *_, same in rows)} of {len(rows)}")


if __name__ == "__main__":
    main()
