"""Speed of the Lie-algebraic leg planner: the Lie leg of paper Sim 3 (target ≤ 0.5 s).

Usage: python benchmarks/bench_lie.py [--repeats N]

The two Newton legs of `scenarios/sim3_hybrid.toml` are planned once (as `plan` does); then
the Lie leg alone is planned from where they end, with the controls they end with, `N` times
after a warm-up (median and min; no start-up, no I/O). Brackets and iterated-integral tensors
are generated once per stratum and process: their time is reported separately, like model
compilation in bench_plan.py. Also shown: the same leg with degree 2 and with the paper's
two-stage α (`lie.alpha = "pinv"`), and the time of `stratplan check` on both presets. The
paper's group reports about 11.5 s per elementary Lie-algebraic task (Mathematica).
"""

from __future__ import annotations

import os

# as the stratplan command does (stratcli/__main__.py): no BLAS threads for small matrices
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import statistics
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from stratcli.api.check import check_document
from stratcli.iterated import iterated_integrals
from stratcli.liealgebra import lie_basis
from stratcli.models.presets import PRESETS
from stratcli.objectives import plan_sequence
from stratcli.scenario import load_scenario
from stratcli.stratified import LegStart, plan_next_leg, planner_for

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    task = load_scenario(ROOT / "scenarios" / "sim3_hybrid.toml")
    system, settings = task.system, task.settings
    newton_legs = task.legs[:2]
    lie_leg = task.legs[2]
    plan = plan_sequence(system, task.start, task.legs, settings)
    assert plan.ok, plan.message
    q = plan.legs[1].end
    previous = plan.legs[1].end_controls()
    print(
        f"Sim 3: Newton legs {', '.join(leg.stratum for leg in newton_legs)} then the Lie leg on "
        f"{lie_leg.stratum} from q = {np.round(q, 4).tolist()}, u(0) = "
        f"{np.round(previous[0], 3).tolist()}"
    )
    print("| variant | steps | final error | energy | median ms | min ms | setup ms |")
    print("|---|---|---|---|---|---|---|")
    variants = {
        f"degree {settings.lie.degree} (scenario)": settings.lie,
        "degree 2": replace(settings.lie, degree=2),
        'degree 3, alpha = "pinv"': replace(settings.lie, degree=3, alpha="pinv"),
    }
    for label, lie in variants.items():
        fresh = PRESETS["one-arm"]()  # setup from scratch: brackets derived, tensors built
        iterated_integrals.cache_clear()
        clock = time.perf_counter()
        lie_basis(fresh, lie_leg.stratum, lie.degree)
        iterated_integrals(settings.basis, lie.step_duration, 2, lie.degree)
        setup = time.perf_counter() - clock
        leg = replace(lie_leg, lie=lie)

        def run(leg=leg):
            at = LegStart(q, previous, 2.0, 2)
            return plan_next_leg(system, settings, leg, at, None, planner_for(leg, settings))

        result = run()  # warm-up
        times = []
        for _ in range(args.repeats):
            clock = time.perf_counter()
            result = run()
            times.append(time.perf_counter() - clock)
        print(
            f"| {label} | {result.iterations} | {result.error:.1e} | {result.energy:.2f} | "
            f"{1e3 * statistics.median(times):.0f} | {1e3 * min(times):.0f} | {1e3 * setup:.0f} |"
        )
    print()
    print("| stratplan check (degree 2, 100 samples) | strata | wall ms (first, incl. brackets) |")
    print("|---|---|---|")
    for name, make in PRESETS.items():
        system = make()  # fresh instance: brackets derived from scratch
        clock = time.perf_counter()
        doc = check_document(system, list(system.strata), np.zeros(system.n), samples=100)
        ms = 1e3 * (time.perf_counter() - clock)
        verdict = "strongly controllable" if doc["strongly_controllable"] else "not"
        print(f"| {name} ({verdict}) | {len(system.strata)} | {ms:.0f} |")


if __name__ == "__main__":
    main()
