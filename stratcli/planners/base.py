"""The leg-planner interface: a leg problem in, a leg outcome out (ARCHITECTURE.md).

A `LegProblem` is everything one leg needs: the stratum, where it starts, what it must reach,
its boundary conditions (the previous leg's final controls, the next leg's inputs, soft start
and full stop), the basis, its duration and its seed. A `LegPlanner` turns it into a
`LegOutcome` (one or more pieces of controls, where they end, how well). Newton (`newton.py`)
and the Lie-algebraic method (`lie.py`) implement it; a third planner is one more class that
sets `method` (it registers itself in `PLANNERS`), in this package or in a user's own module
(README "Your own leg planner").

`damped_gauss_newton` is the one Levenberg–Marquardt loop with backtracking that both use.
It watches for a runaway search (`SearchDiverged`): coordinates that fly off, coefficients
that blow up.
"""

from __future__ import annotations

import abc
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..continuity import Elimination, eliminate, leg_constraints
from ..controls import FourierBasis
from ..endpoint import make_endpoint
from ..models.system import Stratum, System
from ..results import Piece
from ..status import Status

__all__ = [
    "COORDINATE_RUNAWAY",
    "ENERGY_RUNAWAY",
    "PLANNERS",
    "GaussNewtonResult",
    "LegOutcome",
    "LegPlanner",
    "LegProblem",
    "SearchDiverged",
    "damped_gauss_newton",
    "goal_residual",
    "no_divergence_check",
    "onto_goals",
    "runaway",
]

PLANNERS: dict[str, type[LegPlanner]] = {}
PLUGINS = "STRATPLAN_PLANNERS"  # modules to import for planners of one's own (comma-separated)
ENTRY_POINTS = "stratplan.planners"  # the entry-point group of installed packages' planners
_plugins_loaded: list = []  # problems of the one loading (`load_plugins`), once done
_METHOD_NAME = re.compile(r"[a-z][a-z0-9_-]*")

# A Newton search is abandoned as diverged when, after an accepted step that did not reach the
# goal, a coordinate of its end point is COORDINATE_RUNAWAY (rad, or the model's unit) farther
# from 0 than where the first evaluation ended (a start can begin far out and come back: one
# of Sim 3's hybrid starts ends at q3 = 185 and plans). Not 10 rad: correct plans of weak legs
# with free joints ("*") wind a distal joint 7-53 rad (the 4-link arm of issue 14 turning its
# base 10-40° on S12); a runaway search winds it by hundreds or thousands. A start of the
# energy search is abandoned when its energy is ENERGY_RUNAWAY times the first feasible one's.
COORDINATE_RUNAWAY = 100.0
ENERGY_RUNAWAY = 1e4


@dataclass(frozen=True, eq=False)
class LegProblem:
    """One leg to plan.

    Attributes
    ----------
    system, stratum : the model and the leg's stratum.
    start, goal : configurations (goal NaN where not prescribed).
    targets : coordinates steered to the goal (unlocked and prescribed).
    duration : leg length, s (a Lie leg: length of one step).
    basis : Fourier control basis.
    continuity : concatenation mode (DESIGN §3).
    previous : values and derivatives of all inputs at the previous leg's end; None for the
        first leg.
    next_active : inputs of the next leg; None for the last leg.
    soft_start, full_stop : ``u = u' = 0`` at the leg's start / end (first / last leg only).
    tolerance, evaluator, seed : as in `PlannerSettings`.
    index : 0-based position of the leg (also its random stream).
    initial : flat coefficients to start from (projected onto the boundary conditions).
    """

    system: System
    stratum: Stratum
    start: np.ndarray
    goal: np.ndarray
    targets: tuple[int, ...]
    duration: float
    basis: FourierBasis
    continuity: str
    previous: tuple[np.ndarray, np.ndarray] | None
    next_active: tuple[int, ...] | None
    soft_start: bool
    full_stop: bool
    tolerance: float
    evaluator: str
    seed: int
    index: int
    initial: np.ndarray | None = None

    def elimination(
        self,
        duration: float | None = None,
        previous: tuple[np.ndarray, np.ndarray] | str | None = "leg",
        rest: bool = False,
        first_piece: bool = True,
    ) -> Elimination:
        """The boundary conditions, eliminated (`λ = λp + N z`, eq. 26-29).

        For a piece of a multi-piece leg: its `duration`, its `previous` controls, `rest`
        (it ends with u = u' = 0 instead of the leg's end conditions) and whether it is the
        `first_piece` (the only one a soft start applies to).
        """
        return eliminate(
            leg_constraints(
                self.basis,
                self.duration if duration is None else duration,
                self.stratum.active,
                self.system.inputs,
                self.continuity,
                previous=self.previous if previous == "leg" else previous,
                next_active=None if rest else self.next_active,
                soft_start=self.soft_start and first_piece,
                full_stop=self.full_stop or rest,
            )
        )

    def endpoint(self, q: np.ndarray | None = None, duration: float | None = None):
        """The end-point map (and its Jacobian) from `q` (default: the leg's start)."""
        return make_endpoint(
            self.system.compiled(self.stratum),
            self.start if q is None else q,
            self.basis,
            self.duration if duration is None else duration,
            self.evaluator,
        )

    def error(self, q: np.ndarray) -> float:
        """Euclidean goal error over the targeted coordinates (a spatial model's attitude
        measured on the group, `goal_residual`)."""
        t = np.array(self.targets, dtype=int)
        cs = self.system.compiled(self.stratum)
        r, _ = goal_residual(cs, np.asarray(q, dtype=float), None, self.goal[t], t)
        return float(np.linalg.norm(r))


def goal_residual(endpoint, end, J, aim, targets):
    """`end − goal` on `targets` (`aim`: the goal there) and its Jacobian rows `J[targets]`;
    an end-point map (or compiled stratum) with its own `residual` measures it its way (a
    spatial model: the attitude on SO(3), `magnus.residual_on_group`)."""
    own = getattr(endpoint, "residual", None)
    if own is not None:
        return own(end, J, aim, targets)
    return end[targets] - aim, (None if J is None else J[targets])


@dataclass(frozen=True, eq=False)
class LegOutcome:
    """What a leg planner returns; `stratified` turns it into a `LegPlan`."""

    pieces: tuple[Piece, ...]
    end: np.ndarray
    error: float
    iterations: int
    attempts: int
    status: Status
    free_coefficients: int
    evaluator: str
    message: str = ""
    strategy: str = "newton"  # what reached the goal: "newton" or "continuation" (newton.py)

    @property
    def duration(self) -> float:
        return float(sum(p.duration for p in self.pieces))


class LegPlanner(abc.ABC):
    """A method that plans one leg: the extension point for a planner of your own.

    A subclass sets `method` and implements `plan` and `missing_coefficients`. Defining the
    class registers it in `PLANNERS` under `method`, the name a scenario's legs give as
    ``method = "..."`` (a subclass without `method` registers nothing). Registration is per
    process: workers that do not import the defining module (a sweep's spawned or Dask
    workers) do not know the name, and refuse a task that uses it.

    Attributes
    ----------
    method : str
        The name legs use: lowercase letters, digits, `_` or `-`. Defining a second class
        with the same name replaces the first (a notebook cell run again); stratplan's own
        names ("newton", "lie") are refused.
    joint_optimisation : bool
        Whether the energy objective may optimise its legs jointly with the others. Only for
        a Newton-like planner: one `Piece` per leg on the leg's duration, `problem.initial`
        honoured as the first start, and `from_settings` taking `NewtonPlanner`'s options
        (`restarts`, `budget`, `seed`, `spread`) as overrides. Default False: a sequence
        with such a leg is planned leg by leg (`objectives`), as with Lie legs.
    """

    method: ClassVar[str]
    joint_optimisation: ClassVar[bool] = False  # its legs can be optimised jointly (energy)

    def __init_subclass__(cls, **kwargs) -> None:
        """Register a class that sets its own `method`: a lowercase name (letters, digits,
        `_`, `-`) not taken by stratplan's own planners (a user's "newton" had replaced the
        built-in silently for the whole process, and a subclass of `NewtonPlanner` without
        a name of its own replaced it under the name it inherited)."""
        super().__init_subclass__(**kwargs)
        method = cls.__dict__.get("method")
        if method is None:
            return
        if not isinstance(method, str) or not _METHOD_NAME.fullmatch(method):
            raise TypeError(
                f"{cls.__name__}.method: must be a lowercase name (letters, digits, _ or -, "
                f"starting with a letter), not {method!r}"
            )
        taken = PLANNERS.get(method)
        if (
            taken is not None
            and taken.__module__.startswith("stratcli.")
            and (taken.__module__ != cls.__module__)
        ):
            raise ValueError(
                f"{cls.__name__}.method: {method!r} is stratplan's own planner "
                f"({taken.__name__}); give yours another name"
            )
        PLANNERS[method] = cls  # (a user's class defined again, in a notebook: replaced)

    @classmethod
    def from_settings(cls, settings, leg, **overrides) -> LegPlanner:
        """The planner for `leg` (a `LegSpec`) under the planner `settings` (a
        `PlannerSettings`); `overrides` are `NewtonPlanner` options (the energy objective's
        extra starts). Default: ``cls(**overrides)``."""
        return cls(**overrides)

    def problem_duration(self, leg_duration: float) -> float:
        """The duration its `LegProblem` has (a Lie leg's problem is one step)."""
        return leg_duration

    def shortfall(self, where: str, settings, free: int, needed: int) -> str:
        """The message when the boundary conditions leave too few free coefficients."""
        extras = (", soft start" if settings.soft_start else "") + (
            ", full stop" if settings.full_stop else ""
        )
        return (
            f"{where}: the boundary conditions ({settings.continuity}{extras}) leave {free} "
            f"free coefficients for {needed} goal coordinates: {needed - free} missing; raise "
            "planner.basis.harmonics"
        )

    @abc.abstractmethod
    def plan(self, problem: LegProblem) -> LegOutcome:
        """Steer `problem.start` to `problem.goal` on `problem.targets`; never raises for a
        numerical failure of the search (the outcome says so)."""

    @abc.abstractmethod
    def missing_coefficients(self, problem: LegProblem) -> tuple[int, int]:
        """(free coefficients left by the boundary conditions, coefficients needed): the
        check made before planning (a leg with fewer free than needed cannot be planned)."""


class SearchDiverged(Exception):
    """A search ran away: coordinate `coordinate` (0-based) `detail`; `stratified` ends the
    leg with `Status.DIVERGED`. Raised by `damped_gauss_newton` when the caller passes no
    `diverged` check of its own."""

    def __init__(self, coordinate: int, detail: str):
        super().__init__(f"coordinate {coordinate + 1} {detail}")
        self.coordinate, self.detail = coordinate, detail


@dataclass(frozen=True)
class GaussNewtonResult:
    z: np.ndarray
    error: float
    iterations: int
    extra: object  # the last accepted evaluation's payload (e.g. coefficients and end point)
    diverged: str = ""  # why the search was abandoned as diverged ("" if it was not)


def runaway(payload: object, first: object) -> tuple[int, str] | None:
    """The built-in divergence check of a Newton payload `(λ, end point)` against the first
    evaluation's: (the coordinate that ran away, how far), or None (other payloads: never).

    Coordinates only: the first start's controls can be almost zero (a leg whose joints end
    where they start), so their growth says nothing; a planner that knows the leg's energy
    passes its own `diverged` check to `damped_gauss_newton`."""
    pairs = (payload, first)
    if not all(isinstance(p, tuple) and len(p) == 2 for p in pairs):
        return None  # not a Newton payload: no built-in check
    end, end0 = (np.asarray(p[1], dtype=float) for p in pairs)
    if end.ndim != 1 or end.shape != end0.shape or not np.all(np.isfinite(end)):
        return None  # a non-finite end is the numerical-failure path's
    farther = np.abs(end) - np.abs(end0)  # a search coming back from a far start is fine
    k = int(np.argmax(farther)) if farther.size else 0
    if farther.size and farther[k] > COORDINATE_RUNAWAY:
        return k, (
            f"reached {end[k]:.4g}, {farther[k]:.3g} farther out than where the first start "
            f"ended (limit {COORDINATE_RUNAWAY:g})"
        )
    return None


def damped_gauss_newton(
    evaluate: Callable[[np.ndarray, bool], tuple[np.ndarray, np.ndarray | None, object]],
    z: np.ndarray,
    *,
    tolerance: float,
    max_iterations: int,
    mu: float,
    min_step: float = 1e-6,
    stall_window: int | None = None,
    stall_ratio: float = 0.5,
    diverged: Callable[[object], str | None] | None = None,
    jacobian_after: Callable[[], np.ndarray] | None = None,
    lazy: bool = False,
) -> GaussNewtonResult:
    """Drive the residual `e(z)` to zero: damped pseudo-inverse steps with backtracking.

    `evaluate(z, jacobian)` returns `(e, J, payload)` with `J = −∂e/∂z` (or None when not
    asked). Steps `Jᵀ(JJᵀ + μ tr(JJᵀ)/k · I)⁻¹ e` (Levenberg–Marquardt, paper eq. 20 and 24);
    a step is accepted only if it lowers |e| (halving down to `min_step`); μ falls after a
    full step and rises after a failure. It stops at `tolerance`, after `max_iterations`,
    when no damping makes progress, or, with `stall_window`, when |e| did not fall by
    `stall_ratio` over that many iterations (a fresh start is cheaper than crawling on).

    After every accepted step short of the tolerance, `diverged(payload)` says whether the
    search ran away (a reason) or not (None): the loop then stops with the reason in the
    result's `diverged`. Without `diverged`, the built-in check `runaway` (payloads
    ``(λ, end)`` only) raises `SearchDiverged` instead: the whole leg is abandoned.

    With `jacobian_after` (the Jacobian of the latest `evaluate`, added to it afterwards:
    an end-point map that keeps its last evaluation), the full step too is evaluated without
    its Jacobian, which is added only once the step is accepted short of the tolerance (the
    same numbers, without the Jacobians of rejected and of final steps).

    With `lazy` (maps whose value is much cheaper than the Jacobian and the same with or
    without it: quadrature legs and stacked problems), a full step after a refused one is
    evaluated without its Jacobian, which is asked for once the step is accepted: a search
    crawling on a curved residual refuses many full steps, each throwing a Jacobian away.
    Not for maps whose evaluation depends on what was asked before (Magnus legs choose their
    steps from the last error) or whose value and Jacobian come from different solves (the
    ODE path): the value and the Jacobian might then not match.
    """
    e, J, payload = evaluate(z, True)
    first = payload
    err = float(np.linalg.norm(e))
    iterations = 0
    history = [err]
    # the full step's Jacobian comes with its evaluation (usually accepted: little extra
    # cost), but with `lazy` not after a full step was refused
    eager = jacobian_after is None
    while err > tolerance and iterations < max_iterations:
        if stall_window and len(history) > stall_window:
            if err > stall_ratio * history[-stall_window - 1]:
                break
        iterations += 1
        A = J @ J.T
        damping = mu * max(float(np.trace(A)) / max(len(e), 1), 1e-300)
        try:
            step = J.T @ np.linalg.solve(A + damping * np.eye(len(e)), e)
        except np.linalg.LinAlgError:
            mu = max(mu * 100.0, 1e-8)
            continue
        gamma, accepted = 1.0, False
        while gamma > min_step:
            z_new = z + gamma * step
            e_new, J_new, payload_new = evaluate(z_new, gamma == 1.0 and eager)
            err_new = float(np.linalg.norm(e_new))
            if np.isfinite(err_new) and err_new < err:
                accepted = True
                break
            gamma *= 0.5
        eager = jacobian_after is None and (gamma == 1.0 or not lazy)
        if not accepted:
            mu *= 100.0
            if mu > 1e8:
                break  # stalled: no damping makes progress
            continue
        z, e, err, payload = z_new, e_new, err_new, payload_new
        if err > tolerance:
            if diverged is None:
                ran = runaway(payload, first)
                if ran:
                    raise SearchDiverged(ran[0], f"{ran[1]} after {iterations} iterations")
            elif reason := diverged(payload):
                return GaussNewtonResult(z, err, iterations, payload, reason)
            if J_new is None:
                later = jacobian_after is not None and gamma == 1.0
                J_new = jacobian_after() if later else evaluate(z, True)[1]
            J = J_new
        mu = max(mu / 10.0, 1e-12) if gamma == 1.0 else min(mu * 2.0, 1.0)
        history.append(err)
    return GaussNewtonResult(z, err, iterations, payload)


def onto_goals(evaluate, z: np.ndarray, tolerance: float, max_iterations: int):
    """`z` brought onto the goals by minimum-norm (in whitened coordinates: least-energy)
    Gauss-Newton steps, or None if they do not get within `tolerance`.

    `evaluate(z, jacobian)` gives the goal residuals c(z) and, if asked, their Jacobian."""

    def residual(x, jacobian):
        c, J = evaluate(x, jacobian)
        return -c, J, None

    back = damped_gauss_newton(
        residual,
        z,
        tolerance=tolerance,
        max_iterations=max_iterations,
        mu=1e-2,
        diverged=no_divergence_check,
        lazy=True,  # (stacked problems: a Jacobian after the value is the same march's)
    )
    return back.z if back.error <= tolerance and np.all(np.isfinite(back.z)) else None


def no_divergence_check(payload) -> None:
    """For searches whose payloads carry nothing to check for runaway."""
    return None


def load_plugins() -> list[tuple[str, str]]:
    """Import the modules of planners of one's own, once: those named in the environment
    variable `STRATPLAN_PLANNERS` (comma-separated, on the path) and the entry points of the
    group `stratplan.planners` (an installed package's). Defining a `LegPlanner` registers
    it; so a scenario file names it on the command line. Returns a problem per module that
    could not be imported, (where, what), every time: the scenario's check reports them."""
    if _plugins_loaded:
        return _plugins_loaded[1:]
    import importlib
    import os
    from importlib.metadata import entry_points

    problems: list = [None]  # (a first entry marks the loading done)
    for module in filter(None, (m.strip() for m in os.environ.get(PLUGINS, "").split(","))):
        try:
            importlib.import_module(module)
        except Exception as exc:  # a user's module: whatever it raises, said in one line
            problems.append((PLUGINS, f"cannot import {module!r} ({type(exc).__name__}: {exc})"))
    for point in entry_points(group=ENTRY_POINTS):
        try:
            point.load()
        except Exception as exc:
            what = f"cannot load {point.value!r} ({type(exc).__name__}: {exc})"
            problems.append((f"entry point {point.name!r} of {ENTRY_POINTS}", what))
    _plugins_loaded[:] = problems
    return problems[1:]
