"""Stratified planning: a sequence of legs, each on its stratum, concatenated (paper §5.1-5.2).

`chain_legs` is the only loop over legs: each leg starts at the configuration the previous
one actually reached, and its boundary conditions take the previous leg's final control
values. `plan_next_leg` is its body, also used by the comparison trie (which plans
shared prefixes once); `assemble` builds the plan value from planned legs (switches, status,
message). `objectives.plan_sequence` applies the objective over a whole sequence.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np

from .interrupts import checkpoint
from .leg_failures import failure_message
from .models.system import System
from .planner_contract import (
    NUMERICAL,
    PlannerContractError,
    checked_outcome,
    is_own,
    noted,
)
from .planners import PLANNERS, LegPlanner, LegProblem
from .planners.base import SearchDiverged
from .results import LegPlan, ModelRef, Switch, make_leg
from .sequence import SequencePlan
from .settings import LieSettings, PlannerSettings
from .status import Status
from .values import MadeAgainOnUnpickling

__all__ = [
    "LegSpec",
    "LegStart",
    "assemble",
    "chain_legs",
    "held_vias",
    "leg_problem",
    "nominal_starts",
    "plan_next_leg",
    "seeded",
]

# Exceptions that mean "the numbers broke down" inside a leg's search; they end the leg with
# Status.NUMERICAL_FAILURE instead of escaping (a model can overflow, a matrix be singular).
NUMERICAL_ERRORS = (
    ArithmeticError,  # OverflowError, ZeroDivisionError, FloatingPointError
    np.linalg.LinAlgError,
    ValueError,  # e.g. scipy refusing non-finite arrays
    RuntimeError,  # e.g. a failed ODE integration
)
# Newton restarts allowed for the extra, seeded starts (`chain_legs` with a `seed`): the
# energy objective's, the constrained search's and the screen's leg bounds'
SEED_RESTARTS = 2


def seeded(settings: PlannerSettings, k: int, spread: float | None = None) -> dict:
    """The Newton planner's options (`planner_for`) of the k-th seeded start (k ≥ 1): few
    restarts (`SEED_RESTARTS`), seed `settings.seed + 7919 k`, a perturbation of `spread`
    times the goal's scale (default 0.02 + 0.3 k: wider as k grows, other basins)."""
    return {
        "restarts": min(settings.restarts, SEED_RESTARTS),
        "seed": settings.seed + 7919 * k,
        "spread": 0.02 + 0.3 * k if spread is None else spread,
    }


@dataclass(frozen=True, eq=False)
class LegSpec(MadeAgainOnUnpickling):
    """One leg of a task: the stratum, the method and the configuration to reach.

    `goal` is NaN where the end value is not prescribed ("*" in a scenario); `lie` overrides
    the planner's Lie settings for a leg with ``method = "lie"``.

    Attributes
    ----------
    stratum : str
        The stratum's name (e.g. "S1").
    goal : ndarray
        The configuration to reach (NaN: free).
    method : str
        The leg planner: "newton", "lie" or a registered one.
    duration : float
        The leg's duration, s.
    lie : LieSettings or None
        This leg's Lie settings, where they differ from the planner's.
    """

    stratum: str
    goal: np.ndarray
    method: str = "newton"
    duration: float = PlannerSettings().leg_duration
    lie: LieSettings | None = None

    def __post_init__(self) -> None:  # its hash is of the goal: a goal changed in place
        goal = np.array(self.goal, dtype=float)  # moved it in every dict and set holding it
        goal.setflags(write=False)
        object.__setattr__(self, "goal", goal)

    @property
    def unprescribed(self) -> tuple[int, ...]:
        """Coordinates whose end value is left to the planner ("*" goals)."""
        return tuple(np.flatnonzero(np.isnan(self.goal)).tolist())

    def __eq__(self, other: object) -> bool:  # a value: the same leg, "*" goals alike
        if not isinstance(other, LegSpec):
            return NotImplemented
        return (self.stratum, self.method, self.duration, self.lie) == (
            other.stratum, other.method, other.duration, other.lie
        ) and np.array_equal(self.goal, other.goal, equal_nan=True)  # fmt: skip

    def __hash__(self) -> int:
        goal = np.asarray(self.goal, dtype=float)
        # + 0.0: -0.0 and 0.0 are equal goals (`np.array_equal`), so they must hash alike
        return hash(
            (self.stratum, self.method, self.duration, (np.nan_to_num(goal) + 0.0).tobytes())
        )

    def __repr__(self) -> str:  # as a Task's: 4 digits, "*" where any value will do
        goal = ", ".join("*" if v != v else f"{v:.4g}" for v in np.asarray(self.goal, float))
        return f"LegSpec({self.stratum} to [{goal}], {self.method}, {self.duration:g} s)"


@dataclass(frozen=True, eq=False)
class LegStart:
    """Where a leg starts: configuration, previous leg's final controls (None for the first
    leg), time on the plan's axis and the leg's 0-based index."""

    q: np.ndarray
    previous: tuple[np.ndarray, np.ndarray] | None = None
    t0: float = 0.0
    index: int = 0


def planner_for(leg: LegSpec, settings: PlannerSettings, **overrides) -> LegPlanner:
    """The planner of `leg.method` (see `planners.PLANNERS`); `overrides` reach the Newton
    planner (restarts, seed, spread of the energy objective's extra starts)."""
    return PLANNERS[leg.method].from_settings(settings, leg, **overrides)


def _targets(system: System, leg: LegSpec) -> tuple[int, ...]:
    stratum = system.stratum(leg.stratum)
    return tuple(i for i in stratum.free(system.n) if i not in leg.unprescribed)


def leg_problem(
    system: System,
    settings: PlannerSettings,
    leg: LegSpec,
    at: LegStart,
    next_leg: LegSpec | None,
    planner: LegPlanner,
    initial: np.ndarray | None = None,
) -> LegProblem:
    """The `LegProblem` of `leg` started at `at`, followed by `next_leg` (None: last)."""
    next_active = None if next_leg is None else system.stratum(next_leg.stratum).active
    return LegProblem(
        system=system,
        stratum=system.stratum(leg.stratum),
        start=np.asarray(at.q, dtype=float),
        goal=np.asarray(leg.goal, dtype=float),
        targets=_targets(system, leg),
        duration=planner.problem_duration(leg.duration),
        basis=settings.basis,
        continuity=settings.continuity,
        previous=at.previous,
        next_active=next_active,
        soft_start=settings.soft_start and at.previous is None,
        full_stop=settings.full_stop and next_leg is None,
        tolerance=settings.tolerance,
        evaluator=settings.evaluator,
        seed=settings.seed,
        index=at.index,
        initial=initial,
    )


def plan_next_leg(
    system: System,
    settings: PlannerSettings,
    leg: LegSpec,
    at: LegStart,
    next_leg: LegSpec | None,
    planner: LegPlanner,
    initial: np.ndarray | None = None,
) -> LegPlan:
    """Plan one leg; a numerical breakdown makes it a failed leg, never an exception."""
    checkpoint()  # a Ctrl-C that Python dropped inside a finaliser stops at the next leg
    problem = leg_problem(system, settings, leg, at, next_leg, planner, initial)
    common = {
        "index": at.index,
        "stratum": leg.stratum,
        "method": leg.method,
        "active": problem.stratum.active,
        "locked": problem.stratum.locked,
        "targets": problem.targets,
        "t0": at.t0,
        "start": problem.start,
        "goal": problem.goal,
        "basis": settings.basis,
        "n_inputs": system.m,
    }
    own = is_own(planner)  # a user's: its bugs propagate, its outcome is checked
    where = f"leg {at.index + 1} on {leg.stratum}"
    try:
        with np.errstate(all="ignore"):  # overflow shows as a non-finite error, handled below
            out = planner.plan(problem)
    except (SearchDiverged, *NUMERICAL_ERRORS) as exc:
        if own and not isinstance(exc, NUMERICAL):
            noted(exc, planner, leg.method, f"planning {where}")
            raise
        diverged = isinstance(exc, SearchDiverged)
        return make_leg(
            **common,
            evaluator=_evaluator_kind(problem),
            duration=problem.duration,
            end=np.full(system.n, np.nan),
            pieces=(),
            error=float("inf"),
            iterations=getattr(exc, "iterations", 0),
            attempts=1,
            energy=float("nan"),  # no plan: not the zero controls' 0
            free_coefficients=0,
            status=Status.DIVERGED if diverged else Status.NUMERICAL_FAILURE,
            message=(
                f"{system.states[exc.coordinate]} {exc.detail}"
                if diverged
                else f"{type(exc).__name__}: {exc}"
            )[:300],
        )
    except Exception as exc:
        if own:
            noted(exc, planner, leg.method, f"planning {where}")
        raise
    if own:
        with np.errstate(all="ignore"):
            try:
                out = checked_outcome(out, problem, planner, leg.method, settings.tolerance)
            except PlannerContractError as exc:  # (which leg: one planner may plan several)
                raise PlannerContractError(f"{exc} (planning {where})") from None
    status, message = out.status, out.message
    if not (np.all(np.isfinite(out.end)) and np.isfinite(out.error)):
        status = Status.NUMERICAL_FAILURE
        message = message or "the end point could not be computed (not finite)"
    return make_leg(
        **common,
        evaluator=out.evaluator,
        duration=out.duration,
        end=out.end,
        pieces=out.pieces,
        error=out.error,
        iterations=out.iterations,
        attempts=out.attempts,
        free_coefficients=out.free_coefficients,
        status=status,
        message=message,
        strategy=out.strategy,
    )


def _evaluator_kind(problem: LegProblem) -> str:
    """The end-point evaluator a leg uses (or was to use, when it failed)."""
    if problem.evaluator != "auto":
        return problem.evaluator
    cs = problem.system.compiled(problem.stratum)
    if getattr(cs, "endpoint", None) is not None:  # a URDF model's attitude on SO(3)
        return "magnus"
    return "quadrature" if cs.supports_quadrature else "ode"


def assemble(
    system: System,
    settings: PlannerSettings,
    start: np.ndarray,
    legs: list[LegSpec],
    planned: list[LegPlan],
    notes: tuple[str, ...] = (),
) -> SequencePlan:
    """The plan value of `planned` legs (a prefix of `legs` if one failed): switches with
    their control jumps, and the failure message of the first leg that failed."""
    switches = []
    for before, after in itertools.pairwise(planned):
        if not (before.pieces and after.pieces):  # a leg that failed with no controls: no
            none = np.full(len(system.inputs), np.nan)  # jump to measure (it read as one)
            switches.append(Switch(after.t0, before.index, none, none.copy()))
            continue
        u, du = before.end_controls()
        zero = np.array([0.0])
        switches.append(
            Switch(
                after.t0,
                before.index,
                after.controls(zero)[0] - u,
                after.controls(zero, True)[0] - du,
            )
        )
    failed = next((leg for leg in planned if not leg.converged), None)
    plan = SequencePlan(
        scenario="",
        model=ModelRef(system.name, getattr(system, "spec", None)),
        coordinates=tuple(system.states),
        inputs=tuple(system.inputs),
        settings=settings,
        start=np.asarray(start, dtype=float),
        goal=np.asarray(legs[-1].goal, dtype=float),
        legs=tuple(planned),
        switches=tuple(switches),
        planned_legs=len(legs),
        message="" if failed is None else failure_message(failed, settings),
        notes=notes,
    )
    return plan.with_system(system)


def nominal_starts(start, legs: list[LegSpec], planned: SequencePlan) -> list[np.ndarray]:
    """Each leg's start as the stacked searches take it: `start`, then each via with its
    free ("*") coordinates where `planned` (a plan of `legs` reaching every goal) put them."""
    return [
        np.asarray(start, dtype=float),
        *(
            np.where(np.isnan(leg.goal), done.end, leg.goal)
            for leg, done in zip(legs[:-1], planned.legs[:-1], strict=True)
        ),
    ]


def held_vias(system: System, start, legs: list[LegSpec], planned: SequencePlan):
    """What the stacked searches (the energy objective's, the constrained one) plan: `legs`
    with each via's "*" coordinates held where `planned` (a plan of `legs` reaching every
    goal) put them, their targets (every coordinate a leg moves, but on the last leg) and
    each leg's start (`nominal_starts`). A stacked problem starts every leg at its nominal
    start: left free at a via, a coordinate could end leg k elsewhere than where leg k + 1
    starts, and the plan re-chained from the search's controls would re-plan leg k + 1 from
    there (a plan found inside the limits then ended outside them)."""
    nominal = nominal_starts(start, legs, planned)
    held = [replace(leg, goal=via) for leg, via in zip(legs[:-1], nominal[1:], strict=True)]
    held.append(legs[-1])
    targets = [np.array(_targets(system, leg), dtype=int) for leg in held[:-1]]
    targets.append(np.array(planned.legs[-1].targets, dtype=int))
    return held, targets, nominal


def chain_legs(
    system: System,
    start: np.ndarray,
    legs: list[LegSpec],
    settings: PlannerSettings,
    *,
    initial: list[np.ndarray] | None = None,
    **newton,
) -> SequencePlan:
    """Plan all legs in order with the concatenation conditions of `settings.continuity`.

    `initial` (flat coefficients per leg) seeds each leg's first Newton start: a leg already
    within tolerance then takes no iteration. `newton` overrides the Newton planner's options
    (`restarts`, `seed`, `spread`: the energy objective's extra starts). Stops at the first
    leg that fails.
    """
    at = LegStart(np.asarray(start, dtype=float))
    planned: list[LegPlan] = []
    for i, leg in enumerate(legs):
        next_leg = legs[i + 1] if i + 1 < len(legs) else None
        planner = planner_for(leg, settings, **newton)
        result = plan_next_leg(
            system, settings, leg, at, next_leg, planner, None if initial is None else initial[i]
        )
        planned.append(result)
        if not result.converged:
            break
        at = LegStart(result.end, result.end_controls(), at.t0 + result.duration, i + 1)
    return assemble(system, settings, start, legs, planned)
