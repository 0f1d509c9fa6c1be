"""A constrained plan against the limits that depend on its speed: rate and acceleration limits
met by slowing it (`enforce`, time scaling exact for a driftless system), a budget of
optimised durations, and the verification again after a caller re-timed it
(`verified_again`, `time_scaling.time_scaled`), with the factor that meets them (rounded to
3 digits so that the advice holds).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

from .constraints import KEPT_FREE, VIOLATION_TOL, Constraints, ConstraintsSpec, resolve, verify
from .controls import MAX_PERIOD
from .errors import InputError, Problem
from .time_scaling import rate_limited, scale_time
from .urdf_limits import violation_advice

__all__ = ["enforce", "verified_again"]

ROUNDING = 1e-12  # relative: what advice rounded to 3 digits forgives (`_three_digits`)


def verified_again(plan, s: float | None = None):
    """`plan` with its [constraints] report measured again on its own controls (after
    re-timing, `time_scaled`), the limits resolved from the report's table; not slowed, so
    a violation fails it, its message naming the limit, leg and time, and the factor that
    meets it: for the plan the caller re-timed by `s` (within its limits, or failed only by
    an earlier re-timing) and for `plan` itself. No limit set its duration any more
    (`duration_set_by` is empty): the caller's re-timing did."""
    c = resolve(ConstraintsSpec.model_validate(plan.constraints.spec), plan.system)
    report = verify(plan, c)
    over = _past_budget(plan) if report.ok else None  # re-timed past it: a limit too
    if over is not None:
        budget, violation = over
        violated = (
            f"the plan runs {plan.duration:.4g} s, more than planner.total_duration = {budget:g} s"
        )
        report = replace(report, violated=violated, violation=violation)
    out = replace(plan, constraints=report)
    if not report.ok and (plan.ok or _failed_by_timing(plan)):  # too fast, or too slow for
        # its budget (a plan failed so by an earlier re-timing gets the advice of this one)
        if over is not None:
            advice = _retimed("too slow for its budget", plan.duration / over[0], s, "more fits it")
        else:
            factor, which = rate_limited(out, c)
            advice = _retimed(f"too fast for {which}", factor, s, "less meets every rate and "
                              "acceleration limit")  # fmt: skip
        out = replace(out, message=f"{report.violated}; {advice}")
    elif out.ok and not plan.ok:  # slowed back within its limits: the violation is gone
        out = replace(out, message="")
    return out


def _failed_by_timing(plan) -> bool:
    """Whether `plan` reached every goal inside its joint limits and clearances and failed
    only a rate, acceleration or duration limit (which re-timing changes)."""
    report = plan.constraints
    reached = len(plan.legs) == plan.planned_legs and all(leg.status.ok for leg in plan.legs)
    timed = (report.violation or {}).get("limit") in ("rate", "acceleration", "total_duration")
    geometric = ("joint_limit", "self_clearance", "obstacle_clearance")
    inside = all(
        getattr(m, key) is None or getattr(m, key) >= -VIOLATION_TOL
        for m in report.legs
        for key in geometric
    )
    return reached and timed and inside


def _three_digits(x: float, up: bool) -> float:
    """`x` to 3 significant digits, rounded up (or down): advice that still holds. Rounding
    error is forgiven first (1e-12 relative, far inside `VIOLATION_TOL`): an exact 0.5
    computed as 0.49999999999999994 read "0.499 or less" to a new user."""
    x *= 1.0 - ROUNDING if up else 1.0 + ROUNDING
    k = 10.0 ** (2 - math.floor(math.log10(x)))
    return (math.ceil(x * k) if up else math.floor(x * k)) / k


def _retimed(why: str, factor: float, s: float | None, meets: str) -> str:
    """The advice for a plan re-timed `why` (too slow for its budget, too fast for a rate
    or acceleration limit; joint limits and clearances do not depend on the speed): the
    re-timing `factor` of this plan that meets it, "at least" / "at most" (`meets` begins
    with which), rounded to stay true; first, where the call's speed-up `s` is known, that
    of the plan given it (a user re-times that plan again, not the failed one)."""
    up = meets.startswith("more")
    bound, verb = "at least" if up else "at most", meets.split(" ", 1)[1]
    this = f"time_scaled by {bound} {_three_digits(factor, up=up):g}"
    if s is None:
        return f"re-timed {why}: this plan {this} {verb}"
    limit = _three_digits(s * factor, up=up)
    given = next((f"{s:.{d}g}" for d in range(6, 17) if f"{s:.{d}g}" != f"{limit:g}"), repr(s))
    first = f"time_scaled by {given}, where {bound} {limit:g} {verb}"  # (1.000001 is not "1")
    return f"re-timed {why}: {first} (this plan {this.replace('by', 'again by', 1)})"


def enforce(plan, c: Constraints):
    """The plan slowed down to its rate and acceleration limits (time scaling, exact for a
    driftless system) and verified against every limit; a violation fails the plan."""
    s, which = rate_limited(plan, c)
    if s < 1.0 and plan.settings.basis.period / s > MAX_PERIOD:
        key = "max_rate" if which.startswith("the rate") else "max_acceleration"
        raise InputError(
            [
                Problem(
                    f"constraints.{key}",
                    f"meeting {which} needs the plan {1 / s:.3g}x slower, more than the "
                    f"{MAX_PERIOD / plan.settings.basis.period:.3g}x it can be slowed (its "
                    f"basis period would pass {MAX_PERIOD:g} s)",
                )
            ]
        )
    if s < 1.0:
        plan = scale_time(plan, s)
        plan = replace(plan, notes=(*plan.notes, f"slowed {1 / s:.4g}x to meet {which}"))
    past = _past_budget(plan) if s < 1.0 else None  # broken besides a failure: said too
    also = (
        () if past is None else (f"planner.total_duration ({plan.duration:.4g} s > {past[0]:g} s)",)
    )
    report = replace(verify(plan, c, also=also), duration_set_by=which if s < 1.0 else "")
    over = _over_budget(plan, which) if s < 1.0 and report.ok else None
    if over is not None:
        report = replace(report, violated=over[0], violation=over[1])
    plan = replace(plan, constraints=report)
    if not report.ok and plan.legs and all(leg.converged for leg in plan.legs):
        violated = report.violated
        if plan.message:  # where the search stalled: the plan is the one found without limits
            violated = (  # the stall is the search's; the violation, the kept plan's
                f"{plan.message}; {KEPT_FREE}, in which {violated}"
            )
        advice = over[2] if over is not None else violation_advice(plan, report.violated)
        plan = replace(plan, message=f"{violated}; {advice}")
    return plan


def _past_budget(plan) -> tuple[float, dict[str, Any]] | None:
    """(budget, violation) when a plan of optimised durations takes longer than the budget
    its scenario gave (`planner.total_duration`), else None: the budget is a limit too."""
    budget = plan.settings.total_duration if plan.settings.durations == "optimise" else None
    if budget is None or plan.duration <= budget * (1.0 + 1e-9):
        return None
    return budget, {
        "leg": None, "limit": "total_duration",  # (the whole plan's, no leg's)
        "what": f"planner.total_duration ({budget:g} s)", "by": plan.duration - budget,
        "t": plan.duration,
    }  # fmt: skip


def _over_budget(plan, which: str) -> tuple[str, dict[str, Any], str] | None:
    """(violated, violation, advice) when `which` (a rate or acceleration limit) slowed a plan
    of optimised durations past its budget (`_past_budget`); None otherwise. A budget of at
    least the slowed duration meets the limit with the basis period scaled alike: that plans
    the same path (time scaling), slower than the limit; with the period unchanged a longer
    budget fits more of the period's waves into each leg, another path."""
    over = _past_budget(plan)
    if over is None:
        return None
    budget, violation = over
    needed = plan.duration
    at_least = _three_digits(needed, up=True)
    violated = (
        f"the plan needs {needed:.4g} s to meet {which}, more than planner.total_duration = "
        f"{budget:g} s"
    )
    factor = needed / budget if which.startswith("the rate") else (needed / budget) ** 2
    period = plan.settings.basis.period * plan.time_scale * at_least / budget  # as given
    advice = (
        f"raise planner.total_duration to at least {at_least:g} s and planner.basis.period "
        f"alike, to {period:.6g} s (the same path, slower), or relax that limit: in "
        f"{budget:g} s this path needs {factor:.3g}x it"
    )
    return violated, violation, advice
