"""Energy and planning time of stratplan against the free-control lower bound (CasADi/IPOPT).

Usage: python benchmarks/bench_energy.py [--repeats N] [--starts K] [--no-bound]
       [--search loops|starts|legwise] [SCENARIO ...]

One table, every row from the same run, for the paper's scenarios: the paper's energy; the
plain Newton plan's; the energy-optimal plan's with H = 3 harmonics (the default) and with
H = 8 (warm-started from the H = 3 optimum); the lower bound over free controls with the same
dynamics, durations, boundary configurations and control conditions
(benchmarks/casadi_baseline.py: direct collocation, IPOPT, multi-start); the energy ratios to
the bound; stratplan's planning time (energy objective, H = 3, its multi-start included: CPU
time, median of --repeats runs after a warm-up run that compiles the model) and its end-point
evaluations; IPOPT's time for its whole multi-start (NLP construction excluded, as model
compilation is for stratplan); and the time ratio (a different, much larger problem: for the
time comparison on stratplan's own problem see benchmarks/bench_peer.py). The bound is the
best local optimum IPOPT finds from its own deterministic starts and from starts seeded by
stratplan's H = 3 and H = 8 plans (marked † when one of those won; its unseeded best is then
given below the table). Without casadi (or with --no-bound) the bound columns are left empty:
pip install -e '.[bench]'.
"""

from __future__ import annotations

import os

# as the stratplan command does (stratcli/__main__.py): no BLAS threads for small matrices
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import platform
import statistics
import sys
import time
from collections import Counter
from dataclasses import replace

import numpy as np
from casadi_baseline import (
    NODES,
    PAPER_SCENARIOS,
    STARTS,
    casadi_available,
    machine,
    scenario_paths,
    solve_bound,
)

from stratcli import endpoint
from stratcli.controls import FourierBasis, embed
from stratcli.objectives import plan_sequence
from stratcli.scenario import load_scenario
from stratcli.settings import SEARCHES

MORE_HARMONICS = 8
MORE_STARTS = 12  # the richer basis has more minima: twice the default starts
# The prototype bounds (IPOPT, free controls), for reference only.
PROTOTYPE_BOUND = {
    "sim1_l_c1": 364.77,
    "sim1_lr_c1": 361.67,
    "sim4_task_a": 352.70,
    "sim4_task_b": 542.23,
    "sim4_task_c": 104.88,
    "sim4_task_d": 79.31,
}


EVALUATIONS: Counter = Counter()  # end-point calls of one plan: with Jacobian, value only, Hessian


def _count_evaluations() -> None:
    """Count every end-point evaluation (both evaluators) in EVALUATIONS."""
    for cls in (endpoint.QuadratureEndpoint, endpoint.OdeEndpoint):
        call = cls.__call__

        def counted(self, lam, jacobian=True, _call=call):
            EVALUATIONS["jacobian" if jacobian else "value"] += 1
            return _call(self, lam, jacobian)

        cls.__call__ = counted
    hessian = endpoint.QuadratureEndpoint.hessian

    def counted_hessian(self, lam, weights, _hessian=hessian):
        EVALUATIONS["hessian"] += 1
        return _hessian(self, lam, weights)

    endpoint.QuadratureEndpoint.hessian = counted_hessian


def _plan(task, settings, **kwargs):
    return plan_sequence(task.system, task.start, task.legs, settings, **kwargs)


def bench(path, repeats: int, starts: int, with_bound: bool, search: str | None = None) -> dict:
    task = load_scenario(path)
    settings = task.settings if search is None else replace(task.settings, search=search)
    row: dict = {
        "scenario": task.scenario.name,
        "paper": task.scenario.reference.energy if task.scenario.reference else None,
    }
    for leg in task.legs:
        task.system.compiled(leg.stratum)
    newton = _plan(task, replace(settings, objective="newton"))
    row["newton"] = newton.total_energy if newton.ok else None
    try:
        h3 = _plan(task, settings)  # warm-up
        times = []
        for _ in range(repeats):
            EVALUATIONS.clear()
            clock = time.process_time()
            h3 = _plan(task, settings)
            times.append(time.process_time() - clock)
        row["h3"] = h3.total_energy if h3.ok else None
        row["seconds"] = statistics.median(times)
        row["evaluations"] = dict(EVALUATIONS)  # of the last timed run
        H = settings.basis.harmonics
        more = replace(
            settings,
            basis=FourierBasis(MORE_HARMONICS, settings.basis.period),
            starts=MORE_STARTS,
        )
        warm = [embed(leg.coefficients, H, MORE_HARMONICS) for leg in h3.legs]
        clock = time.perf_counter()
        h8 = _plan(task, more, warm_start=warm)
        row["h8_seconds"] = time.perf_counter() - clock
        row["h8"] = h8.total_energy if h8.ok else None
        row["pg"] = [_best_pg(p) for p in (h3, h8)]
        plans = [(f"H={n}", p) for n, p in ((H, h3), (MORE_HARMONICS, h8)) if p.ok]
    except Exception as exc:  # the energy planner is being tuned: report, don't hide
        row["error"] = f"{type(exc).__name__}: {exc}"
        plans = []
    if with_bound:
        bound = solve_bound(task, NODES, starts, plans=tuple(plans))
        row["bound"] = bound["energy"] if bound["success"] else None
        # seeded only if a stratplan-seeded start found a lower optimum, not the same one
        row["bound_seeded"] = bound["best_start"].startswith("stratplan") and not (
            bound["cold_energy"] <= bound["energy"] * (1 + 1e-4)
        )
        row["bound_cold"] = bound["cold_energy"]
        row["bound_start"] = bound["best_start"]
        row["casadi_seconds"] = bound["seconds"]
        row["goal_error"] = bound["goal_error"]
    return row


def _best_pg(plan) -> float | None:
    """Relative projected gradient at the start the plan came from."""
    opt = plan.optimisation
    if not plan.ok or opt is None or opt.best is None:
        return None
    return opt.starts[opt.best].projected_gradient


def _num(value, fmt: str = ".2f") -> str:
    return "–" if value is None or not np.isfinite(value) else format(value, fmt)


def _ratio(a, b, fmt: str = ".3f") -> str:
    if a is None or b is None or not (np.isfinite(a) and np.isfinite(b)) or b == 0:
        return "–"
    return format(a / b, fmt)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenarios", nargs="*", help=f"default: {' '.join(PAPER_SCENARIOS)}")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs (median)")
    parser.add_argument("--starts", type=int, default=STARTS, help="IPOPT starts")
    parser.add_argument("--no-bound", action="store_true", help="skip the CasADi bound")
    parser.add_argument(
        "--search",
        choices=SEARCHES,
        default=None,
        help="stratplan's energy search (default: the scenario's)",
    )
    args = parser.parse_args(argv)
    with_bound = casadi_available() and not args.no_bound
    _count_evaluations()
    argv_text = " ".join(argv if argv is not None else sys.argv[1:])
    print(f"$ python benchmarks/bench_energy.py {argv_text}".rstrip())
    print(f"{machine()}, Python {platform.python_version()}", end="")
    if with_bound:
        import casadi

        print(f", CasADi {casadi.__version__}", end="")
    print(f"; median of {args.repeats} timed runs after a warm-up\n")
    if not with_bound and not args.no_bound:
        print("casadi is not installed, so there is no bound: pip install -e '.[bench]'\n")

    clock = time.perf_counter()
    rows = [
        bench(p, args.repeats, args.starts, with_bound, args.search)
        for p in scenario_paths(args.scenarios)
    ]
    print(
        "| scenario | paper | Newton | H=3 | H=8 | bound | H=3 ÷ bound | H=8 ÷ bound "
        "| stratplan CPU s | end-point evaluations | CasADi s | stratplan ÷ CasADi time |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        bound = r.get("bound")
        cells = [
            r["scenario"],
            _num(r["paper"]),
            _num(r["newton"]),
            _num(r.get("h3")),
            _num(r.get("h8")),
            _num(bound) + (" †" if r.get("bound_seeded") else ""),
            _ratio(r.get("h3"), bound),
            _ratio(r.get("h8"), bound),
            _num(r.get("seconds"), ".3f"),
            _evaluations(r.get("evaluations")),
            _num(r.get("casadi_seconds"), ".2f"),
            _ratio(r.get("seconds"), r.get("casadi_seconds"), ".2f"),
        ]
        print("| " + " | ".join(cells) + " |")
    print()
    if with_bound:
        print(
            f"Bound: Radau collocation (degree 3), graded mesh of {NODES} intervals per leg, "
            f"{args.starts} IPOPT starts (see benchmarks/casadi_baseline.py)."
        )
    print(
        "stratplan CPU s: energy objective, H = 3, multi-start included (end-point evaluations "
        "of one run: with Jacobian + value only + Hessians = total). H = "
        f"{MORE_HARMONICS}: "
        f"warm-started from the H = 3 optimum, plus {MORE_STARTS} starts of its own."
    )
    for r in rows:
        if "error" in r:
            print(f"{r['scenario']}: energy planner failed: {r['error']}")
        if r.get("bound_seeded"):
            print(
                f"† {r['scenario']}: the bound came from IPOPT started at stratplan's "
                f"{r['bound_start'].split()[-1]} plan; IPOPT's own starts gave "
                f"{_num(r['bound_cold'])}"
            )
    if with_bound:
        worst = max(r.get("goal_error", 0.0) for r in rows)
        print(f"Bound solutions re-integrated with solve_ivp: largest goal error {worst:.1e}.")
        h8_ok = all(
            r.get("h8") is not None and r.get("bound") and r["h8"] <= 1.05 * r["bound"]
            for r in rows
        )
        faster = all(
            r.get("seconds") is not None and r["seconds"] < r["casadi_seconds"] for r in rows
        )
        print(f"H = {MORE_HARMONICS} within 1.05x of the bound on every row: {_yes(h8_ok)}.")
        print(f"stratplan (H = 3, multi-start) faster than IPOPT on every row: {_yes(faster)}.")
        known = [r for r in rows if r["scenario"] in PROTOTYPE_BOUND and r.get("bound")]
        if known:
            print(
                "Prototype bounds (issue): "
                + ", ".join(
                    f"{r['scenario']} {PROTOTYPE_BOUND[r['scenario']]:.2f} (here {r['bound']:.2f})"
                    for r in known
                )
                + "."
            )
    pgs = [(r["scenario"], r["pg"]) for r in rows if r.get("pg")]
    if pgs:
        print(
            "Relative projected gradient at the optimum (H = 3 / H = "
            f"{MORE_HARMONICS}; the issue asks ≤ 1e-8): "
            + ", ".join(f"{name} {_num(a, '.1e')} / {_num(b, '.1e')}" for name, (a, b) in pgs)
            + "."
        )
    sim4 = [r for r in rows if r["scenario"].startswith("sim4") and "seconds" in r]
    if sim4:
        times = [1e3 * r["seconds"] for r in sim4]
        counts = [sum(r["evaluations"].values()) for r in sim4]
        print(
            f"Sim 4 tasks, energy objective at H = 3: CPU {min(times):.0f}–{max(times):.0f} ms "
            f"(median over the tasks {statistics.median(times):.0f} ms; target ≤ 70 ms), "
            f"{min(counts)}–{max(counts)} end-point evaluations per task."
        )
    print(f"Whole benchmark: {time.perf_counter() - clock:.0f} s.")


def _evaluations(counts: dict | None) -> str:
    if not counts:
        return "–"
    j, v, h = (counts.get(k, 0) for k in ("jacobian", "value", "hessian"))
    return f"{j} + {v} + {h} = {j + v + h}"


def _yes(flag: bool) -> str:
    return "yes" if flag else "no"


if __name__ == "__main__":
    main()
