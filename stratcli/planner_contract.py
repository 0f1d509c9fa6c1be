"""A leg planner of a user's own (`planners.LegPlanner` outside stratcli) held to its contract.

stratplan's planners compute a leg's end with the leg's end-point map; a planner of a user's
own reports its end, error and status itself, and a plan was marked ok on its word (a new
user's planner returned zero controls with the goal as its end: "ok", error 0.00, while the
path ended 0.785 rad from the goal). Its outcome is checked here: a `LegOutcome`, pieces of
the leg's shape, and its end re-computed from its controls by the end-point map; a leg that
misses its goal is failed, saying so. Its own exceptions (a bug in it) are not read as a
numerical breakdown of the model: they propagate, with a note naming the planner and leg.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .planners.base import LegOutcome, LegPlanner, LegProblem
from .status import Status

__all__ = ["OWN", "PlannerContractError", "checked_outcome", "fault", "is_own", "noted"]

NUMERICAL = (ArithmeticError, np.linalg.LinAlgError)  # a model's, whoever's planner ran it
OWN = "leg planner "  # how its messages begin (`leg_failures` gives no advice of ours then)
RAISED_BY = f"raised by {OWN}"  # the note `noted` adds


class PlannerContractError(TypeError):
    """A planner of one's own returned what `LegPlanner.plan` may not (a TypeError)."""


def fault(exc: BaseException) -> str | None:
    """The line the command line prints where a planner of one's own broke (its exception,
    or its contract; its traceback shown above it), else None."""
    if isinstance(exc, PlannerContractError):
        return str(exc)
    note = next((n for n in getattr(exc, "__notes__", ()) if n.startswith(RAISED_BY)), None)
    if note is None:
        return None
    head = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    return f"{type(exc).__name__}{': ' + head if head else ''} ({note}; the traceback above is its)"


def is_own(planner: LegPlanner) -> bool:
    """Whether `planner` is a user's (its class defined outside stratcli)."""
    return not type(planner).__module__.startswith("stratcli.")


def _name(planner: LegPlanner, method: str) -> str:
    return f"{OWN}{method!r} ({type(planner).__name__}.plan)"


def noted(exc: BaseException, planner: LegPlanner, method: str, where: str) -> None:
    """Note on `exc`, raised by a user's planner, which planner and leg raised it."""
    exc.add_note(f"raised by {_name(planner, method)} planning {where}")


def checked_outcome(
    out, problem: LegProblem, planner: LegPlanner, method: str, tolerance: float
) -> LegOutcome:
    """`out` from a user's planner, its end re-computed from its controls.

    Raises
    ------
    PlannerContractError
        (a TypeError) Not a `LegOutcome`, or a piece whose coefficients are not (active
        inputs, basis size) or whose times do not tile the leg.
    """
    name = _name(planner, method)
    if not isinstance(out, LegOutcome):
        raise PlannerContractError(f"{name} returned {type(out).__name__}, not a LegOutcome")
    if not isinstance(out.strategy, str) or not out.strategy:
        raise PlannerContractError(f"{name}: strategy must be a non-empty string")
    if out.strategy == "newton" and method != "newton":  # the default: not what planned it
        out = replace(out, strategy=method)
    shape = (len(problem.stratum.active), problem.basis.size)
    t = 0.0
    for k, piece in enumerate(out.pieces):
        if np.shape(piece.coefficients) != shape:
            raise PlannerContractError(
                f"{name}: piece {k} has coefficients of shape {np.shape(piece.coefficients)}, "
                f"not {shape} (active inputs x basis functions)"
            )
        if abs(piece.t0 - t) > 1e-9 * max(1.0, t):
            raise PlannerContractError(f"{name}: piece {k} starts at {piece.t0:g} s, not {t:g} s")
        t += piece.duration
    if not out.pieces or not out.status.ok:
        return out
    q = np.asarray(problem.start, dtype=float)
    for piece in out.pieces:
        q = problem.endpoint(q, piece.duration)(np.ravel(piece.coefficients), False)[0]
    error = problem.error(q)
    if not np.all(np.isfinite(q)) or not error <= max(tolerance, 1e-9):
        message = (
            f"{name} reported its goal reached, but its controls end {error:.3g} from it "
            "(re-computed by the leg's end-point map)"
        )
        return replace(out, end=q, error=error, status=Status.NOT_CONVERGED, message=message)
    return replace(out, end=q, error=error)
