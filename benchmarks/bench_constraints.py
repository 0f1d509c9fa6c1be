"""Planning time under constraints: each constrained Sim 4 task against the same task without.

Usage: python benchmarks/bench_constraints.py [--repeats N] [--phases | --against DIR]
                                                [SCENARIO ...]

For scenarios/sim4_task_{a,b,c,d}_constrained.toml (joints within ±2.5 rad, self-collision
with clearance 0.05) and sim4_task_d_obstacles.toml, with the energy objective: the median CPU
time (time.process_time) of planning the task as shipped (the search, the re-chaining and the
dense verification of the [constraints] table) and of the same scenario with its
[constraints] table removed, over --repeats runs after a warm-up run that compiles the model;
their ratio (issue 17 asks ≤ 3x); the energies with and without the constraints, and the
status. A failed constrained plan is timed too (its search ran to its stall).

`--phases` times instead where each constrained plan's CPU goes (medians over --repeats):
the search's feasibility phases (Gauss-Newton steps onto the margins), barrier rounds and SQP
steps, the dense checks between the nodes and the dense verification, each with its count of
steps; the rest of the plan is the free plan it starts from and the re-chaining.

`--against DIR` (another checkout, e.g. `git archive REV | tar -x -C DIR`) times instead the
constrained plan of each scenario with this checkout and with DIR's code, in fresh processes
alternating the two, --repeats pairs (each process warms up first): on a shared machine whose
speed drifts, the ratio of such pairs is what says whether a change made the search faster
(`bench_against.report`, with one timed plan a process).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the stratplan command does

import argparse
import platform
import statistics
import time
import tomllib
from pathlib import Path

from bench_against import not_a_checkout, report

from stratcli.api.planning import plan_run
from stratcli.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1] / "scenarios"
DEFAULT = [
    "sim4_task_a_constrained",
    "sim4_task_b_constrained",
    "sim4_task_c_constrained",
    "sim4_task_d_constrained",
    "sim4_task_d_obstacles",
]


def _timed(task, repeats: int):
    plan_run(task, check=False)  # warm-up: compiles the model
    times, result = [], None
    for _ in range(repeats):
        clock = time.process_time()
        result = plan_run(task, check=False).result
        times.append(time.process_time() - clock)
    return statistics.median(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    either = parser.add_mutually_exclusive_group()  # each is its own report
    either.add_argument("--against", type=Path, help="another checkout, timed alternately")
    either.add_argument("--phases", action="store_true", help="where the constrained CPU goes")
    parser.add_argument("scenarios", nargs="*", default=DEFAULT)
    args = parser.parse_args()
    if args.phases:
        return phases(args.scenarios, args.repeats)
    if args.against is not None:  # one timed plan a process, as many pairs as --repeats
        if why := not_a_checkout(args.against):
            parser.error(why)
        paths = [ROOT / f"{name}.toml" for name in args.scenarios]
        return report(args.scenarios, paths, args.against, args.repeats, plans=1)
    where = platform.processor() or platform.machine()
    print(f"{where}, Python {platform.python_version()}, CPU time (time.process_time), "
          f"median of {args.repeats} runs after a warm-up")  # fmt: skip
    print(f"{'scenario':26} {'free s':>8} {'constr. s':>10} {'ratio':>6} "
          f"{'free E':>9} {'constr. E':>10}  status")  # fmt: skip
    for name in args.scenarios:
        raw = tomllib.loads((ROOT / f"{name}.toml").read_text())
        free_raw = {k: v for k, v in raw.items() if k != "constraints"}
        t_free, free = _timed(load_scenario(free_raw), args.repeats)
        t_con, con = _timed(load_scenario(raw), args.repeats)
        print(
            f"{name:26} {t_free:8.3f} {t_con:10.3f} {t_con / t_free:6.1f} "
            f"{free.total_energy:9.2f} {con.total_energy:10.2f}  {con.status.name.lower()}"
        )


PHASES = {  # (object, method): column; the search's own phases, its checks, the verification
    "feasibility": ("MarginSearch", "reach_feasible"),
    "barrier": ("MarginSearch", "_lower_barrier"),
    "SQP": ("MarginSearch", "_sqp_step"),
    "checks": ("NodeMargins", "refined"),
    "verification": ("limit_timing", "verify"),  # (as `enforce` calls it)
}


def owners_of_phases() -> dict:
    """The objects whose methods `PHASES` names."""
    from stratcli import limit_timing
    from stratcli.node_margins import NodeMargins
    from stratcli.planners import margin_search

    return {
        "MarginSearch": margin_search.MarginSearch,
        "NodeMargins": NodeMargins,
        "limit_timing": limit_timing,
    }


def phases(names: list[str], repeats: int) -> None:
    """`--phases`: per scenario, the median CPU of each phase of its constrained plan (its
    methods wrapped and timed) and its steps (search iterations; SQP steps; passes). Each
    column is its own median over the plans, so the columns need not add up to the plan's."""
    from stratcli.planners import margin_search

    owners = owners_of_phases()
    spent: dict[str, float] = {}
    steps: dict[str, int] = {}

    originals = [(owners[o], m, getattr(owners[o], m)) for o, m in PHASES.values()]

    def timed(column, owner, method):
        inner = getattr(owner, method)

        def wrapper(*args, **kwargs):
            search = args[0] if args and isinstance(args[0], margin_search.MarginSearch) else None
            before = search.iterations if search is not None else 0
            clock = time.process_time()
            try:
                return inner(*args, **kwargs)
            finally:
                spent[column] = spent.get(column, 0.0) + time.process_time() - clock
                done = search.iterations - before if search is not None else 1
                steps[column] = steps.get(column, 0) + (1 if column == "SQP" else done)

        setattr(owner, method, wrapper)

    for column, (owner, method) in PHASES.items():
        timed(column, owners[owner], method)
    try:
        _phase_rows(names, repeats, spent, steps)
    finally:  # (unwrapped: the caller's process plans as before)
        for owner, method, inner in originals:
            setattr(owner, method, inner)


def _phase_rows(names, repeats, spent, steps) -> None:
    print(f"CPU ms (time.process_time), median of {repeats} plans after a warm-up; (steps)")
    print(f"{'scenario':26} {'plan':>6} " + " ".join(f"{c:>16}" for c in PHASES))
    for name in names:
        task = load_scenario(ROOT / f"{name}.toml")
        plan_run(task, check=False)
        rows = []
        for _ in range(repeats):
            spent.clear()
            steps.clear()
            clock = time.process_time()
            plan_run(task, check=False)
            rows.append((time.process_time() - clock, dict(spent), dict(steps)))
        total = statistics.median(r[0] for r in rows)
        cells = [
            f"{1e3 * statistics.median(r[1].get(c, 0.0) for r in rows):9.0f} "
            f"({statistics.median(r[2].get(c, 0) for r in rows):4.0f})"
            for c in PHASES
        ]
        print(f"{name:26} {1e3 * total:6.0f} " + " ".join(f"{c:>16}" for c in cells))


if __name__ == "__main__":
    main()
