"""Robustness benchmark: seeded random tasks planned with lr-C1 and verified independently.

Usage: python benchmarks/bench_random.py [--tasks 200] [--seed 0] [--jobs 1] [--only SEED]
                                         [--theta-vias conservative|free] [--constraints]

Each task (issue 14, item 5) draws from its own `numpy.random.default_rng(task_seed)`, the task
seeds from `--seed`: the one-arm or the two-arm preset; a sequence of 2-4 strata (one-arm
S1..S3; two-arm S1..S4 and S12..S34), never the same stratum twice in a row; a start within
±π/2 per coordinate; a change of up to ±2.5 rad for every joint the sequence moves and up to
±0.6 rad for θ. Vias are conservative, as `stratcli.decomposition.boundary_configurations` makes
them (checked equal on the 200 default tasks): a leg sets every coordinate it can move to its
goal value, locked joints keep theirs; θ moves on every stratum, so it is at its goal from the
first leg on. `--theta-vias free` leaves θ free ("*") on the intermediate vias instead and the
last leg alone reaches the goal θ (it then undoes the θ drift of all earlier legs, often more
than 1 rad although the task's own θ change is at most 0.6 rad).

Every task is planned with `stratcli.plan(..., check=False)`, continuity lr-C1 and the default
objective, then `plan.to_dict()` is re-integrated with tests/reintegrate.py (the printed
equations, scipy DOP853): a task is *verified* when the plan is ok, the legs chain, every
leg's locked joints stay put, its recorded end is the true end and every coordinate this
script prescribed for it (locked ones included) is reached within the tolerance (1e-3, the
norm over the leg's prescribed coordinates).

Prints, as markdown: the command line and load average, the success rate per model, every
failure (task seed, model, sequence, status, message, what its worst leg was asked) and
percentiles of the planning CPU time per task (`time.process_time()` around `stratcli.plan`,
after an untimed warm-up per model and process). Results do not depend on `--jobs`;
`--only SEED` re-runs one task and prints its scenario as JSON.

`--constraints` plans every task with and without a [constraints] table (joints within
±2.5 rad, self-collision with clearance 0.05; tasks whose start, vias or goal break it are
redrawn and counted) and prints the status counts, the recorded margins of the ok plans, the
energy ratio constrained/free, the CPU times both ways and every task not ok
(benchmarks/random_constraints.py says how).
"""

from __future__ import annotations

import os

# as the stratplan command does (stratcli/__main__.py): no BLAS threads for small matrices
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import json
import multiprocessing
import platform
import shlex
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from functools import partial
from pathlib import Path

import numpy as np

import stratcli

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
import random_constraints
from reintegrate import PRINTED, reintegrate

JOINTS = {"one-arm": 3, "two-arm": 4}
STRATA = {
    "one-arm": ("S1", "S2", "S3"),
    "two-arm": ("S1", "S2", "S3", "S4", "S12", "S13", "S14", "S23", "S24", "S34"),
}
MAX_JOINT_CHANGE = 2.5
MAX_THETA_CHANGE = 0.6
TOLERANCE = 1e-3
END_SLACK = 1e-6  # recorded end vs re-integrated end (the tests use 1e-8)


def locked_joints(stratum: str) -> set[int]:
    """0-based joints a preset stratum locks: S13 locks q1 and q3."""
    return {int(c) - 1 for c in stratum[1:]}


def make_task(seed: int, theta_vias: str = "conservative") -> dict:
    """The scenario dict of one random task, with every leg's goal written out."""
    rng = np.random.default_rng(seed)
    model = str(rng.choice(list(JOINTS)))
    k = JOINTS[model]
    strata = STRATA[model]
    sequence: list[str] = []
    for _ in range(int(rng.integers(2, 5))):
        choices = [s for s in strata if not sequence or s != sequence[-1]]
        sequence.append(str(rng.choice(choices)))
    moved = set().union(*(set(range(k)) - locked_joints(s) for s in sequence))
    start = rng.uniform(-np.pi / 2, np.pi / 2, k + 1)
    change = np.zeros(k + 1)
    for j in sorted(moved):
        change[j] = rng.uniform(-MAX_JOINT_CHANGE, MAX_JOINT_CHANGE)
    change[k] = rng.uniform(-MAX_THETA_CHANGE, MAX_THETA_CHANGE)
    goal = start + change
    current = [float(x) for x in start]
    legs = []
    for i, stratum in enumerate(sequence):
        for j in set(range(k)) - locked_joints(stratum):
            current[j] = float(goal[j])  # conservative: as soon as a leg can move it
        via: list = list(current)
        if i == len(sequence) - 1 or theta_vias == "conservative":
            via[k] = float(goal[k])
        else:
            via[k] = "*"
        legs.append({"stratum": stratum, "goal": via})
    return {
        "name": f"random_{seed}",
        "model": {"kind": "preset", "name": model},
        "task": {"start": [float(x) for x in start], "goal": [float(x) for x in goal]},
        "planner": {"continuity": "lr-C1", "tolerance": TOLERANCE},
        "legs": legs,
    }


def verify(scenario: dict, doc: dict) -> str:
    """'' when the plan checks out under independent re-integration, else the first reason."""
    f = PRINTED[doc["model"]]
    replay = reintegrate(doc, lambda stratum, q, u: f(q, u))
    if len(doc["legs"]) != len(scenario["legs"]):
        return f"{len(doc['legs'])} legs planned, {len(scenario['legs'])} asked"
    previous = np.array(scenario["task"]["start"], dtype=float)
    for i, (asked, leg, again) in enumerate(
        zip(scenario["legs"], doc["legs"], replay, strict=True), start=1
    ):
        if not np.allclose(leg["start"], previous, rtol=0, atol=1e-9):
            return f"leg {i} does not start where leg {i - 1} ended"
        goal = np.array([np.nan if g == "*" else g for g in asked["goal"]], dtype=float)
        locked = sorted(locked_joints(asked["stratum"]))
        if np.max(np.abs(again["end"][locked] - again["start"][locked]), initial=0) > 1e-12:
            return f"leg {i} ({asked['stratum']}) moves a locked joint"
        if np.max(np.abs(np.asarray(leg["end"]) - again["end"])) > END_SLACK:
            gap = np.max(np.abs(np.asarray(leg["end"]) - again["end"]))
            return f"leg {i} recorded end is {gap:.1e} off the re-integrated one"
        targeted = ~np.isnan(goal)  # locked joints too: the via must equal where they stay
        error = float(np.linalg.norm(again["end"][targeted] - goal[targeted]))
        if error > TOLERANCE * (1 + 1e-6) + 1e-9:
            return f"leg {i} ({asked['stratum']}) re-integrated error {error:.2e} > {TOLERANCE}"
        previous = np.asarray(leg["end"], dtype=float)
    return ""


_WARM: set[str] = set()


def warm_up(model: str) -> None:
    """Plan a small one-leg task once per model and process: compilation stays out of timing."""
    if model in _WARM:
        return
    k = JOINTS[model]
    start = [0.0] * (k + 1)
    goal = [0.0] * k + [0.05]
    goal[k - 1] = 0.3
    stratcli.plan(
        {
            "name": "warm_up",
            "model": {"kind": "preset", "name": model},
            "task": {"start": start, "goal": goal},
            "legs": [{"stratum": "S1"}],
        },
        check=False,
    )
    _WARM.add(model)


def run_task(seed: int, theta_vias: str = "conservative") -> dict:
    """Plan and verify one task; never raises (an exception is a failure with its type)."""
    scenario = make_task(seed, theta_vias)
    model = scenario["model"]["name"]
    row = {
        "seed": seed,
        "model": model,
        "sequence": ", ".join(leg["stratum"] for leg in scenario["legs"]),
        "verified": False,
        "status": "",
        "message": "",
        "asks": "",
        "cpu": float("nan"),
    }
    warm_up(model)
    clock = time.process_time()
    try:
        plan = stratcli.plan(scenario, check=False)
    except Exception as exc:  # the benchmark reports, it does not stop
        row["cpu"] = time.process_time() - clock
        row["status"] = f"exception {type(exc).__name__}"
        row["message"] = str(exc)
        return row
    row["cpu"] = time.process_time() - clock
    row["status"] = plan.status.name.lower() if hasattr(plan.status, "name") else str(plan.status)
    row["message"] = plan.message
    if not plan.ok:
        row["asks"] = worst_leg(plan)
        return row
    try:
        reason = verify(scenario, plan.to_dict())
    except Exception as exc:
        reason = f"re-integration failed: {type(exc).__name__}: {exc}"
    if reason:
        row["status"] = "not verified"
        row["message"] = reason
    row["verified"] = not reason
    return row


def worst_leg(plan) -> str:
    """What the leg with the largest error was asked to do: its number, Δθ, largest |Δq|."""
    legs = [leg for leg in plan.legs if np.isfinite(leg.error)]
    if not legs:
        return ""
    leg = max(legs, key=lambda leg: leg.error)
    delta = np.asarray(leg.goal, dtype=float) - np.asarray(leg.start, dtype=float)
    joints = np.abs(np.nan_to_num(delta[:-1]))
    theta = "free" if np.isnan(delta[-1]) else f"{delta[-1]:+.2f}"
    return f"leg {leg.index + 1}: Δθ {theta}, max \\|Δq\\| {joints.max(initial=0):.2f}"


def task_seeds(master: int, n: int) -> list[int]:
    return [int(s) for s in np.random.default_rng(master).integers(0, 2**31, n)]


def run_pair(seed: int, theta_vias: str = "conservative") -> dict:
    """One task planned free and under the benchmark's [constraints] table."""
    return random_constraints.run_pair(seed, theta_vias, make_task, warm_up, verify)


def run_all(seeds: list[int], jobs: int, theta_vias: str, task=run_task) -> list[dict]:
    if jobs <= 1:
        return [task(s, theta_vias) for s in seeds]
    context = multiprocessing.get_context("fork")
    with ProcessPoolExecutor(jobs, mp_context=context) as pool:
        return list(pool.map(task, seeds, [theta_vias] * len(seeds)))


def _one_line(text: str, width: int = 120) -> str:
    text = " ".join(str(text).split()).replace("|", "\\|")
    return text if len(text) <= width else text[: width - 1] + "…"


def header(rows: list[dict], args, load_before, load_after, wall: float) -> list[str]:
    return [
        "# bench_random" + (" --constraints" if args.constraints else ""),
        "",
        f"`{shlex.join(['python', *sys.argv])}`",
        "",
        f"- {platform.node()}, {os.cpu_count()} cores, Python {platform.python_version()}; "
        f"load average (1/5/15 min) before {_load(load_before)}, after {_load(load_after)}",
        f"- master seed {args.seed}, {len(rows)} tasks, jobs {args.jobs}, θ on vias: "
        f"{args.theta_vias}, wall {wall:.1f} s",
    ]


def report(rows: list[dict], args, load_before, load_after, wall: float) -> str:
    out = [
        *header(rows, args, load_before, load_after, wall),
        "",
        "| model | tasks | verified | rate |",
        "|---|---:|---:|---:|",
    ]
    groups = {m: [r for r in rows if r["model"] == m] for m in JOINTS}
    groups = {m: g for m, g in groups.items() if g} | {"all": rows}
    for name, group in groups.items():
        ok = sum(r["verified"] for r in group)
        out.append(f"| {name} | {len(group)} | {ok} | {100 * ok / len(group):.1f} % |")
    failures = [r for r in rows if not r["verified"]]
    out += ["", f"## Failures ({len(failures)})", ""]
    if failures:
        out += [
            "| task seed | model | sequence | status | message | worst leg asks |",
            "|---:|---|---|---|---|---|",
        ]
        for r in failures:
            out.append(
                f"| {r['seed']} | {r['model']} | {r['sequence']} | {r['status']} "
                f"| {_one_line(r['message'])} | {r['asks']} |"
            )
    else:
        out.append("none")
    out += [
        "",
        "## Planning CPU time per task (s)",
        "",
        "| model | tasks | p50 | p90 | p99 | max | mean |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for name, group in groups.items():
        cpu = np.array([r["cpu"] for r in group])
        p50, p90, p99 = np.percentile(cpu, [50, 90, 99])
        out.append(
            f"| {name} | {len(group)} | {p50:.2f} | {p90:.2f} | {p99:.2f} | {cpu.max():.2f} "
            f"| {cpu.mean():.2f} |"
        )
    return "\n".join(out)


def _load(load) -> str:
    return " / ".join(f"{x:.2f}" for x in load)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", type=int, default=200, help="number of random tasks")
    parser.add_argument("--seed", type=int, default=0, help="master seed of the task seeds")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes")
    parser.add_argument("--only", type=int, help="run this task seed alone, print its scenario")
    parser.add_argument(
        "--theta-vias",
        choices=("conservative", "free"),
        default="conservative",
        help='θ on intermediate vias: the goal θ from the first leg on, or "*" (free)',
    )
    parser.add_argument(
        "--constraints",
        action="store_true",
        help="plan every task also under joint limits ±2.5 rad and self-collision (0.05)",
    )
    args = parser.parse_args(argv)
    if args.only is not None:
        print(json.dumps(make_task(args.only, args.theta_vias)))
        seeds = [args.only]
        args.jobs = 1
    else:
        seeds = task_seeds(args.seed, args.tasks)
    if args.constraints:
        return run_constrained(seeds, args)
    load_before = os.getloadavg()
    clock = time.perf_counter()
    rows = run_all(seeds, args.jobs, args.theta_vias)
    wall = time.perf_counter() - clock
    print(report(rows, args, load_before, os.getloadavg(), wall))
    return 0


def run_constrained(seeds: list[int], args) -> int:
    """`--constraints`: redraw tasks that break the table, plan each both ways, report."""
    if args.only is None:
        stream = task_seeds(args.seed, args.tasks * random_constraints.REDRAWS)
        seeds, rejected = random_constraints.feasible_seeds(
            stream, args.tasks, partial(make_task, theta_vias=args.theta_vias)
        )
    else:
        rejected = {}
        reason = random_constraints.pre_violation(make_task(args.only, args.theta_vias))
        if reason:
            print(f"task {args.only} breaks the table at its start, a via or the goal: {reason}")
            return 0
    load_before = os.getloadavg()
    clock = time.perf_counter()
    rows = run_all(seeds, args.jobs, args.theta_vias, task=run_pair)
    wall = time.perf_counter() - clock
    head = header(rows, args, load_before, os.getloadavg(), wall)
    print("\n".join([*head, *random_constraints.report(rows, rejected, _one_line)]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
