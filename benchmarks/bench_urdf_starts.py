"""URDF robots' energy search with and without the lowest legs start, side by side.

Usage: python benchmarks/bench_urdf_starts.py [--tasks 8] [--seed 100]

Legs without exact second derivatives (URDF robots) get no pulled start; the search races the
*lowest legs* (`stratcli.newton_starts.lowest_legs`: each leg the lowest-energy of six Newton
plans) after the Newton plan's own search. This plans each task with the energy objective
both ways in one process, alternating which goes first from task to task (the machine's
speed drifts), and prints per task the energy and CPU time (time.process_time) of each,
then the ratios' median. "without" is the search as it was before the lowest legs
(`objectives.lowest_legs` replaced by one that makes none).

Tasks: scenarios/spatial/arm3_reorient.toml and arm7_three_legs.toml, a user's arm3 task
(30° about x on S3, about y on S1, the rest on S3; soft start, full stop) and `--tasks`
random arm3 tasks: 2-3 legs on S1-S3 (never one stratum twice in a row), joints drawn
within ±0.8 rad and moved by up to ±0.8 rad on each leg (within ±1.5), the attitude moved by
up to ±0.15 rad per rotation-vector component on each leg, lr-C1, 2 s legs, tolerance 1e-6,
each from `numpy.random.default_rng(seed + k)`.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the stratplan command does

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

import stratcli.objectives as objectives
from stratcli.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
ARM3 = str(ROOT / "robots" / "arm3.urdf")
PLANNER = {"continuity": "lr-C1", "leg_duration": 2.0, "tolerance": 1e-6}


def _configuration(q, attitude) -> dict:
    return {**{f"j{i + 1}": float(v) for i, v in enumerate(q)}, "attitude": list(attitude)}


def turns_task() -> dict:
    """A user's task: arm3 turned 30° about x, then about y, then about z."""
    still = [0.0, 0.0, 0.0]
    goal = [0.6372332777095085, 0.36790680442217233, 0.6372332777095085]
    return {
        "name": "arm3_turns",
        "model": {"kind": "urdf", "path": ARM3},
        "task": {"start": _configuration(still, [0, 0, 0]), "goal": _configuration(still, goal)},
        "planner": {**PLANNER, "soft_start": True, "full_stop": True},
        "legs": [
            {"stratum": "S3", "goal": _configuration(still, ["30deg", 0, 0])},
            {"stratum": "S1", "goal": _configuration(still, ["*", 0.511472554961272, "*"])},
            {"stratum": "S3"},
        ],
    }


def random_task(seed: int) -> dict:
    """A random arm3 task (module docstring)."""
    rng = np.random.default_rng(seed)
    strata: list[str] = []
    for _ in range(int(rng.integers(2, 4))):
        strata.append(
            str(rng.choice([s for s in ("S1", "S2", "S3") if not strata or s != strata[-1]]))
        )
    q, attitude = rng.uniform(-0.8, 0.8, 3), np.zeros(3)
    start = _configuration(q, attitude)
    goals = []
    for stratum in strata:
        locked = int(stratum[1]) - 1
        moved = np.clip(q + rng.uniform(-0.8, 0.8, 3), -1.5, 1.5)
        q = np.where(np.arange(3) == locked, q, moved)
        attitude = attitude + rng.uniform(-0.15, 0.15, 3)
        goals.append(_configuration(q, attitude))
    return {
        "name": f"arm3_random_{seed}",
        "model": {"kind": "urdf", "path": ARM3},
        "task": {"start": start, "goal": goals[-1]},
        "planner": PLANNER,
        "legs": [{"stratum": s, "goal": g} for s, g in zip(strata[:-1], goals[:-1], strict=True)]
        + [{"stratum": strata[-1]}],
    }


def _planned(task, lowest: bool):
    made = objectives.lowest_legs
    if not lowest:
        objectives.lowest_legs = lambda *args, **kwargs: None
    try:
        clock = time.process_time()
        plan = objectives.plan_sequence(task.system, task.start, task.legs, task.settings)
        return plan, time.process_time() - clock
    finally:
        objectives.lowest_legs = made


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", type=int, default=8)
    parser.add_argument("--seed", type=int, default=100)
    args = parser.parse_args()
    sources = [
        ROOT / "scenarios" / "spatial" / "arm3_reorient.toml",
        ROOT / "scenarios" / "spatial" / "arm7_three_legs.toml",
        turns_task(),
        *(random_task(args.seed + k) for k in range(args.tasks)),
    ]
    print(f"CPU time (time.process_time), one plan each way a task; load {os.getloadavg()[0]:.2f}")
    print()
    print("| task | legs | energy without | energy with | s without | s with | ratio | won by |")
    print("|---|---|---:|---:|---:|---:|---:|---|")
    ratios, lower = [], 0
    for k, source in enumerate(sources):
        task = load_scenario(source)
        order = (False, True) if k % 2 == 0 else (True, False)
        runs = dict(zip(order, (_planned(task, lowest) for lowest in order), strict=True))
        (plain, t_plain), (with_low, t_low) = runs[False], runs[True]
        opt = with_low.optimisation
        best = "-" if opt is None or opt.best is None else opt.starts[opt.best].kind  # none won
        lower += (
            plain.ok and with_low.ok and with_low.total_energy < plain.total_energy * (1 - 1e-9)
        )
        ratios.append(t_low / t_plain)
        print(
            f"| {task.scenario.name} | {' '.join(leg.stratum for leg in task.legs)} | "
            f"{plain.total_energy:,.2f} | {with_low.total_energy:,.2f} | {t_plain:.2f} | "
            f"{t_low:.2f} | {t_low / t_plain:.2f} | {best} |"
        )
    print()
    print(
        f"lower with the lowest legs on {lower} of {len(sources)} tasks; CPU ratio median "
        f"{statistics.median(ratios):.2f} ({min(ratios):.2f}-{max(ratios):.2f})"
    )


if __name__ == "__main__":
    main()
