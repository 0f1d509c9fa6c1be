"""Spatial (URDF) models: one Newton leg and the energy-optimal 3-leg task on the 7-joint arm.

Usage: python benchmarks/bench_spatial.py [--repeats N]

The model is robots/bus_arm7.urdf (a 7-joint arm on a 150 kg bus, Pinocchio). Timed: leg 2
of scenarios/spatial/arm7_three_legs.toml alone with Newton (lr-C1, 6 inputs steering 6 joints
and the attitude, tolerance 1e-6), and the whole 3-leg task with the energy objective.
Medians of wall and CPU time (process time) over the repeats; the model is built once. What
dominates is printed from the profile of one run: the share of Pinocchio's centroidal map and
momentum derivatives (`SpatialRobot.angular_map` and `angular_derivative`, where Pinocchio's
calls run) in the time.
"""

from __future__ import annotations

import os

# as the stratplan command does (stratcli/__main__.py): no BLAS threads for small matrices
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import cProfile
import pstats
import statistics
import time
from dataclasses import replace
from pathlib import Path

from stratcli.objectives import plan_sequence
from stratcli.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def _timed(system, start, legs, settings, repeats):
    walls, cpus, result = [], [], None
    for _ in range(repeats):
        w, c = time.perf_counter(), time.process_time()
        result = plan_sequence(system, start, legs, settings)
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
    return result, statistics.median(walls), statistics.median(cpus)


def _share(system, start, legs, settings) -> float:
    profile = cProfile.Profile()
    profile.runcall(plan_sequence, system, start, legs, settings)
    stats = pstats.Stats(profile)
    total = stats.total_tt
    connection = sum(
        v[2]  # own time: the Pinocchio calls run inside these functions
        for k, v in stats.stats.items()
        if k[2] in ("angular", "angular_map", "angular_derivative") and "spatial" in k[0]
    )
    return connection / total if total else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    task = load_scenario(ROOT / "scenarios" / "spatial" / "arm7_three_legs.toml")
    system, legs = task.system, task.legs
    newton = replace(task.settings, objective="newton")
    first = plan_sequence(system, task.start, legs[:1], newton)
    leg_start = first.legs[0].end
    one = [replace(legs[1])]
    rows = []
    result, wall, cpu = _timed(system, leg_start, one, newton, args.repeats)
    leg = result.legs[0]
    rows.append(
        (
            "Newton leg (S3, 6 inputs, 9 targets)",
            result.ok,
            f"{leg.iterations} it, error {leg.error:.1e}",
            wall,
            cpu,
            _share(system, leg_start, one, newton),
        )
    )
    energy = replace(task.settings, objective="energy")
    result, wall, cpu = _timed(system, task.start, legs, energy, max(3, args.repeats // 2))
    rows.append(
        (
            "energy-optimal 3-leg task",
            result.ok,
            f"energy {result.total_energy:.3f} (Newton's {result.optimisation.newton_energy:.3f})",
            wall,
            cpu,
            _share(system, task.start, legs, energy),
        )
    )
    print("| run | status | result | median wall ms | median CPU ms | share in Pinocchio calls |")
    print("|---|---|---|---|---|---|")
    for name, ok, what, wall, cpu, share in rows:
        print(
            f"| {name} | {'ok' if ok else 'failed'} | {what} | {wall * 1e3:.1f} | "
            f"{cpu * 1e3:.1f} | {share:.0%} |"
        )


if __name__ == "__main__":
    main()
