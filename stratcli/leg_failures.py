"""What a user reads when a leg fails (`failure_message`): which leg, how far off, what to try."""

from __future__ import annotations

from .planner_contract import OWN
from .planners.lie import DRIFTED
from .reachability import NOT_TRIED
from .results import LegPlan
from .settings import PlannerSettings
from .status import Status
from .wording import counted

__all__ = ["failure_message"]


def failure_message(leg: LegPlan, settings: PlannerSettings) -> str:
    """What a user reads when a leg fails: which leg, how far off, what to try (first the
    Newton budget, where the scenario set it below its default)."""
    tolerance = settings.tolerance
    head, _, advice = leg.status.value.partition("; ")
    where = f"leg {leg.index + 1} on {leg.stratum}"
    if leg.message.startswith(OWN):  # a planner of one's own missed: its advice is not ours
        return f"{where}: {leg.message}"
    if leg.status is Status.NUMERICAL_FAILURE and "boundary conditions are inconsistent" in (
        leg.message
    ):  # its own advice (the period) is the one: not "a via closer to the start"
        return f"{where} was {head} ({leg.message})"
    if leg.status is Status.NUMERICAL_FAILURE:
        return f"{where} was {head} ({leg.message}); {advice}"
    if leg.status is Status.DIVERGED:
        return f"{where} {head} ({leg.message}); {advice}"
    if leg.status is Status.LIE_NOT_CONVERGED:
        where += " (Lie-algebraic)"
        work = f"after {counted(leg.iterations, 'step')}"
        _, drift, how = leg.message.partition(DRIFTED)  # `lie._drifted`: the first thing to try
        if settings.lie.degree >= 3:  # (advised to a scenario that had set it)
            advice = advice.replace("lie.degree = 3, ", "")
        if drift:
            advice = f"{drift}{how}, or {advice}"
    else:
        work = f"after {counted(leg.iterations, 'iteration')} in {counted(leg.attempts, 'attempt')}"
        if leg.message:  # e.g. the continuation that followed them
            work += f" ({leg.message})"
        defaults = type(settings)()
        lowered = [
            f"planner.{name} (now {getattr(settings, name)}, default {getattr(defaults, name)})"
            for name in ("max_iterations", "restarts")
            if getattr(settings, name) < getattr(defaults, name)
        ]
        if lowered:
            advice = f"allow more {' and '.join(lowered)}, or {advice}"
        if leg.message.endswith(NOT_TRIED):  # its stratum cannot move that way: no tuning
            advice = (  # helps ("S1 cannot move rz ...; try more harmonics" contradicted it)
                "give the leg a via its stratum can reach, or other strata (stratplan "
                "compare-sequences, or auto mode: a [decompose] table instead of [[legs]])"
            )
    return f"{where} {head}: error {leg.error:.3g} > tolerance {tolerance:.3g} {work}; {advice}"
