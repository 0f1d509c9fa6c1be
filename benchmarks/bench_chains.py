"""Scale: one leg on planar chains of 3 to 30 links (one lock each), Newton and energy.

Usage: python benchmarks/bench_chains.py [--repeats N]

Each chain is one arm of uniform rods (total length 3 m, total mass 3 kg) on a 10 kg, 1 x 1 m
base; the leg locks joint 1 and steers every other joint by +0.3 rad and θ by +0.1 rad from a
bent start. The model comes from physical parameters (closed-form A and dA, no sympy).
Timed (CPU time, medians): the paper's Newton method, and the energy objective (its multi-start
included). The last line is the energy objective's growth exponent from 10 to 30 links,
log(t30 / t10) / log 3.
"""

from __future__ import annotations

import os

# as the stratplan command does (stratcli/__main__.py): no BLAS threads for small matrices
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import math
import statistics
import time
from dataclasses import replace

import numpy as np

from stratcli.models.manipulator import ManipulatorSystem
from stratcli.models.planar import Arm, Base, Link, PlanarManipulator
from stratcli.objectives import plan_sequence
from stratcli.stratified import LegSpec, PlannerSettings


def chain(n: int) -> ManipulatorSystem:
    links = tuple(Link(3.0 / n, 3.0 / n) for _ in range(n))
    robot = PlanarManipulator(Base.rectangle(10.0, 1.0, 1.0), (Arm((0.5, 0.0), 0.0, 1, links),))
    return ManipulatorSystem(robot, lock_sets=[(0,)])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--links", type=int, nargs="+", default=[3, 5, 10, 20, 30])
    args = parser.parse_args()
    print(
        "| links | status | iterations | final error | median ms | ms per iteration "
        "| energy objective: energy (Newton's) | median ms |"
    )
    print("|---|---|---|---|---|---|---|---|")
    energy_ms = {}
    for n in args.links:
        system = chain(n)
        start = np.concatenate([np.full(n, 0.4), [0.0]])
        goal = start + np.concatenate([[0.0], np.full(n - 1, 0.3), [0.1]])
        legs = [LegSpec("S1", goal)]
        settings = PlannerSettings(continuity="none", objective="newton")  # one Newton leg
        result, median = _timed(system, start, legs, settings, args.repeats)
        optimal, optimal_ms = _timed(
            system, start, legs, replace(settings, objective="energy"), max(3, args.repeats // 2)
        )
        energy_ms[n] = optimal_ms
        leg = result.legs[0]
        print(
            f"| {n} | {'ok' if result.ok else 'failed'} | {leg.iterations} | {leg.error:.1e} | "
            f"{median:.1f} | {median / max(leg.iterations, 1):.1f} | "
            f"{optimal.total_energy:.2f} ({result.total_energy:.2f}) | {optimal_ms:.0f} |",
            flush=True,
        )
    if 10 in energy_ms and 30 in energy_ms:
        exponent = math.log(energy_ms[30] / energy_ms[10]) / math.log(3.0)
        print(f"\nenergy objective, 10 -> 30 links: time grows as n^{exponent:.2f}")


def _timed(system, start, legs, settings, repeats: int):
    """(plan, median CPU ms) after a warm-up run."""
    result = plan_sequence(system, start, legs, settings)
    times = []
    for _ in range(repeats):
        clock = time.process_time()
        result = plan_sequence(system, start, legs, settings)
        times.append(time.process_time() - clock)
    return result, 1e3 * statistics.median(times)


if __name__ == "__main__":
    main()
