"""A leg planner of a user's own (`planners.LegPlanner` outside stratcli) held to its contract.

stratplan's planners compute a leg's end with the leg's end-point map; a planner of a user's
own reports its end, error and status itself, and a plan was marked ok on its word (a new
user's planner returned zero controls with the goal as its end: "ok", error 0.00, while the
path ended 0.785 rad from the goal). Its outcome is checked here: a `LegOutcome` with a
`Status`, pieces of the leg's shape, finite, tiling the leg; its end re-computed from its
controls by the end-point map, and its controls' boundary conditions (continuity with the legs
beside it, soft start, full stop) evaluated: a leg that misses its goal or breaks a condition
is failed, saying so (a plugin's discontinuous controls had been recorded ok). Its own
exceptions (a bug in it) are not read as a numerical breakdown of the model: they propagate,
with a note naming the planner and leg.
"""

from __future__ import annotations

import numbers
from dataclasses import replace

import numpy as np

from .controls import end_controls
from .planners.base import LegOutcome, LegPlanner, LegProblem
from .status import Status

__all__ = [
    "OWN",
    "PlannerContractError",
    "checked_duration",
    "checked_outcome",
    "fault",
    "is_own",
    "noted",
]

NUMERICAL = (ArithmeticError, np.linalg.LinAlgError)  # a model's, whoever's planner ran it
OWN = "leg planner "  # how its messages begin (`leg_failures` gives no advice of ours then)
RAISED_BY = f"raised by {OWN}"  # the note `noted` adds


class PlannerContractError(TypeError):
    """A planner of one's own returned what `LegPlanner.plan` may not (a TypeError)."""


def fault(exc: BaseException, traceback_shown: bool = True) -> str | None:
    """The line the command line prints where a planner of one's own broke (its exception,
    or its contract; its traceback shown above it, if it has frames of its own), else None."""
    if isinstance(exc, PlannerContractError):
        return str(exc)
    note = next((n for n in getattr(exc, "__notes__", ()) if n.startswith(RAISED_BY)), None)
    if note is None:
        return None
    head = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    above = "; the traceback above is its" if traceback_shown else ""
    return f"{type(exc).__name__}{': ' + head if head else ''} ({note}{above})"


def is_own(planner: LegPlanner | type) -> bool:
    """Whether `planner` (or a planner class) is a user's (defined outside stratcli)."""
    cls = planner if isinstance(planner, type) else type(planner)
    return not cls.__module__.startswith("stratcli.")


def _name(planner: LegPlanner | type, method: str, call: str = "plan") -> str:
    cls = planner if isinstance(planner, type) else type(planner)
    return f"{OWN}{method!r} ({cls.__name__}.{call})"


def noted(
    exc: BaseException, planner: LegPlanner | type, method: str, where: str, call: str = "plan"
) -> None:
    """Note on `exc`, raised by a user's planner (or its class, making one), which planner,
    which of its methods (`call`) and which leg (`where`: "planning leg 2 on S1")."""
    exc.add_note(f"raised by {_name(planner, method, call)} {where}")


def checked_duration(duration, planner: LegPlanner, method: str) -> None:
    """Raise `PlannerContractError` where a planner's `problem_duration` is not a positive,
    finite time (0 or NaN failed deep in the end-point map, blamed on its `plan`)."""
    real = isinstance(duration, numbers.Real) and not isinstance(duration, bool)  # (numpy's too)
    if not (real and np.isfinite(duration) and duration > 0):
        name = _name(planner, method, "problem_duration")
        raise PlannerContractError(f"{name} returned {duration!r}: a leg lasts a positive time")


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
    if not isinstance(out.status, Status):
        raise PlannerContractError(
            f"{name}: status must be a stratcli.Status (Status.SUCCESS, ...), not "
            f"{type(out.status).__name__} {out.status!r}"
        )
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
        if not np.all(np.isfinite(np.asarray(piece.coefficients, dtype=float))):
            raise PlannerContractError(f"{name}: piece {k} has coefficients that are not finite")
        if not (np.isfinite(piece.duration) and piece.duration > 0):
            raise PlannerContractError(
                f"{name}: piece {k} lasts {piece.duration:g} s: a piece lasts a positive time"
            )
        if abs(piece.t0 - t) > 1e-9 * max(1.0, t):
            raise PlannerContractError(f"{name}: piece {k} starts at {piece.t0:g} s, not {t:g} s")
        t += piece.duration
    if not out.pieces and out.status.ok:
        raise PlannerContractError(f"{name} reported its goal reached with no controls (pieces)")
    one_leg = type(planner).problem_duration is LegPlanner.problem_duration  # (not Lie-like)
    if out.pieces and one_leg and abs(t - problem.duration) > 1e-9 * max(1.0, t):
        raise PlannerContractError(
            f"{name}: its pieces last {t:g} s, not the leg's {problem.duration:g} s"
        )
    if not out.pieces or not out.status.ok:
        return out
    q = np.asarray(problem.start, dtype=float)
    for piece in out.pieces:
        q = problem.endpoint(q, piece.duration)(np.ravel(piece.coefficients), False)[0]
    error = problem.error(q)
    message = ""
    if not np.all(np.isfinite(q)) or not error <= max(tolerance, 1e-9):
        message = (
            f"{name} reported its goal reached, but its controls end {error:.3g} from it "
            "(re-computed by the leg's end-point map)"
        )
    elif broken := _boundary_break(out.pieces, problem):
        message = f"{name} returned controls that break the leg's boundary conditions: {broken}"
    if message:
        return replace(out, end=q, error=error, status=Status.NOT_CONVERGED, message=message)
    return replace(out, end=q, error=error)


def _boundary_break(pieces, problem: LegProblem) -> str:
    """The first boundary condition of the leg (`LegProblem.conditions`: continuing the
    previous leg's controls, soft start, full stop, inputs the next leg does not use ending
    at rest; between pieces, continuing the piece before) that `pieces` break by more than
    rounding, said with its size; "" when none."""
    previous = "leg"
    for k, piece in enumerate(pieces):
        rows = problem.conditions(
            piece.duration, previous, first_piece=k == 0, last_piece=k == len(pieces) - 1
        )
        lam = np.ravel(piece.coefficients)
        off = rows.C @ lam - rows.c if len(rows.c) else np.zeros(0)
        scale = max(1.0, float(np.abs(lam).max(initial=0.0)))
        if off.size and np.abs(off).max() > 1e-8 * scale:
            worst = int(np.argmax(np.abs(off)))
            where = f" (piece {k})" if len(pieces) > 1 else ""
            return f"{rows.labels[worst]}{where} is off by {off[worst]:.3g}"
        previous = end_controls(
            problem.basis, piece.coefficients, piece.duration, problem.stratum.active,
            problem.system.m,
        )  # fmt: skip
    return ""
