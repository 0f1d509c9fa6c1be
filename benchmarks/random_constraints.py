"""`bench_random.py --constraints`: the random tasks planned under a [constraints] table.

Every task gets joint limits ±2.5 rad on every joint, `self_collision = true` and
`clearance = 0.05` (as scenarios/sim4_task_*_constrained.toml). A task whose start, vias or
goal already break them (the check `stratcli.load_scenario` makes, `InputError` on
`task.start`, `legs[i].goal` or `task.goal`) has no plan; it is *redrawn*: the next seed of
the master stream is drawn instead, and the rejected seeds are counted per reason.

Each task is planned twice with `stratcli.plan(..., check=False)` and the default (energy)
objective, with and without the table, each timed with `time.process_time()` after an
untimed warm-up per model and process both ways. A constrained plan is *ok* when `plan.ok`;
its record's `constraints.legs[*]` margins must then all be ≥ -1e-6 and it is re-integrated
as in bench_random (`verify`). Any Python exception is a bug: its traceback's last lines are kept.
"""

from __future__ import annotations

import copy
import time
import traceback

import numpy as np

import stratcli

CONSTRAINTS = {"joint_limits": [-2.5, 2.5], "self_collision": True, "clearance": 0.05}
MARGIN_SLACK = 1e-6  # a recorded margin below -this on an ok plan is a bug
REDRAWS = 50  # at most this many seeds drawn per task asked


def constrained(scenario: dict) -> dict:
    """A copy of `scenario` carrying the benchmark's [constraints] table."""
    out = copy.deepcopy(scenario)
    out["constraints"] = dict(CONSTRAINTS)
    return out


def pre_violation(scenario: dict) -> str:
    """'' if the constrained task loads, else why its start/vias/goal break the table.

    Raises the `InputError` if any of its problems is about something else (a bug of the
    generator or of the loader).
    """
    try:
        stratcli.load_scenario(constrained(scenario))
    except stratcli.InputError as exc:
        reasons = set()
        for p in exc.problems:
            where = p.path.split("[")[0].split(".")[0]
            if where not in ("task", "legs") or not p.path.endswith(("start", "goal")):
                raise
            # the loader's wording since a6128aa: "q1 = -3.31 is outside its limits [...]
            # (constraints.joint_limits)"; before it, "joint limits"
            if "outside its limits" in p.message or "joint limits" in p.message:
                reasons.add("joint limits")
            elif "with itself" in p.message or "clearance of itself" in p.message:
                reasons.add("self-collision")
            else:
                raise
        return " and ".join(sorted(reasons))
    return ""


def feasible_seeds(seed_stream, n: int, make_task) -> tuple[list[int], dict[str, list[int]]]:
    """The first `n` seeds of `seed_stream` whose tasks load under the table, and the
    rejected seeds by reason ("joint limits", "self-collision", both joined by "and")."""
    seeds: list[int] = []
    rejected: dict[str, list[int]] = {}
    for seed in seed_stream:
        if len(seeds) == n:
            break
        reason = pre_violation(make_task(seed))
        if reason:
            rejected.setdefault(reason, []).append(seed)
        else:
            seeds.append(seed)
    return seeds, rejected


def _tail(exc: BaseException, lines: int = 3) -> str:
    text = "".join(traceback.format_exception(exc)).strip().splitlines()
    return " ⏎ ".join(line.strip() for line in text[-lines:])


def _timed_plan(scenario: dict) -> tuple[object | None, float, str]:
    clock = time.process_time()
    try:
        plan = stratcli.plan(scenario, check=False)
    except Exception as exc:  # the benchmark reports, it does not stop
        return None, time.process_time() - clock, _tail(exc)
    return plan, time.process_time() - clock, ""


def _status(plan) -> str:
    if plan.ok:
        return "ok"
    return "constraint_violated" if plan.status.key == "constraint_violated" else "failed"


_WARM: set[str] = set()


def warm_up_constrained(model: str, joints: int) -> None:
    """Plan a small constrained one-leg task once per model and process (untimed)."""
    if model in _WARM:
        return
    goal = [0.0] * joints + [0.05]
    goal[joints - 1] = 0.3
    task = {
        "name": "warm_up",
        "model": {"kind": "preset", "name": model},
        "task": {"start": [0.0] * (joints + 1), "goal": goal},
        "legs": [{"stratum": "S1"}],
    }
    stratcli.plan(constrained(task), check=False)
    _WARM.add(model)


def run_pair(seed: int, theta_vias: str, make_task, warm_up, verify) -> dict:
    """Plan one task free and constrained; never raises."""
    free = make_task(seed, theta_vias)
    model = free["model"]["name"]
    row = {
        "seed": seed,
        "model": model,
        "sequence": ", ".join(leg["stratum"] for leg in free["legs"]),
        "status": "",
        "detail": "",  # the plan's status key when failed
        "message": "",
        "min_margin": float("nan"),
        "margin_ok": True,
        "verified": "",
        "energy": float("nan"),
        "free_energy": float("nan"),
        "free_ok": False,
        "cpu": float("nan"),
        "free_cpu": float("nan"),
    }
    warm_up(model)
    warm_up_constrained(model, len(free["task"]["start"]) - 1)
    plan, row["free_cpu"], trace = _timed_plan(free)
    if plan is not None:
        row["free_ok"], row["free_energy"] = plan.ok, plan.total_energy
    elif trace:
        row["free_message"] = trace
    scenario = constrained(free)
    plan, row["cpu"], trace = _timed_plan(scenario)
    if plan is None:
        row["status"], row["message"] = "exception", trace
        return row
    row["status"], row["detail"], row["message"] = _status(plan), plan.status.key, plan.message
    row["energy"] = plan.total_energy
    doc = plan.to_dict()
    margins = [v for leg in (doc.get("constraints") or {}).get("legs", []) for v in leg.values()]
    margins = [v for v in margins if v is not None]
    row["min_margin"] = min(margins) if margins else float("nan")
    if row["status"] == "ok":
        row["margin_ok"] = bool(margins) and row["min_margin"] >= -MARGIN_SLACK
        try:
            row["verified"] = verify(scenario, doc) or "yes"
        except Exception as exc:
            row["verified"] = f"re-integration failed: {_tail(exc, 1)}"
    return row


def _pct(values) -> str:
    v = np.asarray([x for x in values if np.isfinite(x)])
    if not len(v):
        return "– | –"
    p50, p90 = np.percentile(v, [50, 90])
    return f"{p50:.2f} | {p90:.2f}"


def report(rows: list[dict], rejected: dict[str, list[int]], one_line) -> list[str]:
    """Markdown lines: statuses, margins, energy ratios, CPU times, every non-ok task."""
    spec = ", ".join(f"{k} = {v}" for k, v in CONSTRAINTS.items()).replace("True", "true")
    n_rej = sum(len(s) for s in rejected.values())
    by = "; ".join(f"{reason}: {len(s)}" for reason, s in sorted(rejected.items())) or "none"
    out = [
        f"- constraints: {spec}",
        f"- redrawn: {n_rej} drawn tasks broke the table at their start, a via or the goal "
        f"and were replaced by the next seed ({by})",
        "",
        "| model | tasks | ok | constraint_violated | failed | exception | free ok |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    groups = {m: [r for r in rows if r["model"] == m] for m in ("one-arm", "two-arm")}
    groups = {m: g for m, g in groups.items() if g} | {"all": rows}
    for name, g in groups.items():
        count = {s: sum(r["status"] == s for r in g) for s in
                 ("ok", "constraint_violated", "failed", "exception")}  # fmt: skip
        out.append(
            f"| {name} | {len(g)} | {count['ok']} | {count['constraint_violated']} "
            f"| {count['failed']} | {count['exception']} | {sum(r['free_ok'] for r in g)} |"
        )
    ok = [r for r in rows if r["status"] == "ok"]
    bad_margin = [r for r in ok if not r["margin_ok"]]
    unverified = [r for r in ok if r["verified"] != "yes"]
    least = min((r["min_margin"] for r in ok), default=float("nan"))
    out += [
        "",
        f"- ok plans whose record has a margin < -{MARGIN_SLACK:g}: {len(bad_margin)} of "
        f"{len(ok)} (smallest margin over all ok plans {least:.3g}); ok plans not verified "
        f"by re-integration: {len(unverified)}",
    ]
    both = [r for r in ok if r["free_ok"] and r["free_energy"] > 0]
    ratio = np.array([r["energy"] / r["free_energy"] for r in both])
    if len(ratio):
        p50, p90 = np.percentile(ratio, [50, 90])
        out.append(
            f"- energy constrained/free over the {len(both)} tasks ok both ways: min "
            f"{ratio.min():.3f}, median {p50:.3f}, p90 {p90:.3f}, max {ratio.max():.3f}"
        )
    out += [
        "",
        "## Planning CPU time per task (s), constrained vs free",
        "",
        "| model | tasks | constrained p50 | p90 | free p50 | p90 |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name, g in groups.items():
        out.append(
            f"| {name} | {len(g)} | {_pct(r['cpu'] for r in g)} "
            f"| {_pct(r['free_cpu'] for r in g)} |"
        )
    odd = [r for r in rows if r["status"] != "ok" or not r["margin_ok"] or r["verified"] != "yes"]
    out += ["", f"## Constrained tasks not ok, or ok but off the record ({len(odd)})", ""]
    if odd:
        out += [
            "| task seed | model | sequence | status | min margin | free | message |",
            "|---:|---|---|---|---:|---|---|",
        ]
        for r in odd:
            status = r["status"] + (f" ({r['detail']})" if r["status"] == "failed" else "")
            if r["status"] == "ok":
                status += f", margins {'ok' if r['margin_ok'] else 'VIOLATED'}, "
                status += f"verified: {r['verified']}"
            free = "ok" if r["free_ok"] else "not ok"
            out.append(
                f"| {r['seed']} | {r['model']} | {r['sequence']} | {status} "
                f"| {r['min_margin']:.3g} | {free} | {one_line(r['message'], 400)} |"
            )
    else:
        out.append("none")
    free_bugs = [r for r in rows if "free_message" in r]
    if free_bugs:
        out += ["", "Exceptions planning the same tasks without the table:", ""]
        out += [f"- {r['seed']}: {one_line(r['free_message'], 400)}" for r in free_bugs]
    return out
