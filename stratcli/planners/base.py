"""The leg-planner interface: a leg problem in, a leg outcome out (ARCHITECTURE.md).

A `LegProblem` is everything one leg needs: the stratum, where it starts, what it must reach,
its boundary conditions (the previous leg's final controls, the next leg's inputs, soft start
and full stop), the basis, its duration and its seed. A `LegPlanner` turns it into a
`LegOutcome` (one or more pieces of controls, where they end, how well). Newton (`newton.py`)
and the Lie-algebraic method (`lie.py`) implement it; a third planner is one more class that
sets `method` (it registers itself in `PLANNERS`), in this package or in a user's own module
(README "Your own leg planner").

`damped_gauss_newton` (`gauss_newton`, re-exported here) is the one Levenberg–Marquardt loop
with backtracking that both use.
"""

from __future__ import annotations

import abc
import re
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..continuity import Constraints, Elimination, eliminate, leg_constraints
from ..controls import FourierBasis
from ..endpoint import make_endpoint
from ..models.system import Stratum, System
from ..results import Piece
from ..status import Status
from .gauss_newton import (
    COORDINATE_RUNAWAY,
    ENERGY_RUNAWAY,
    GaussNewtonResult,
    SearchDiverged,
    damped_gauss_newton,
    no_divergence_check,
    onto_goals,
    runaway,
)

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
_METHOD_NAME = re.compile(r"[a-z][a-z0-9_-]*")


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
    continuity : concatenation mode.
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

    def conditions(
        self,
        duration: float | None = None,
        previous: tuple[np.ndarray, np.ndarray] | str | None = "leg",
        rest: bool = False,
        first_piece: bool = True,
        last_piece: bool = True,
    ) -> Constraints:
        """The leg's boundary conditions `C λ = c` with their labels (eq. 26-29), or those
        of one piece of a multi-piece leg: its `duration`, its `previous` controls, `rest`
        (it ends with u = u' = 0 instead of the leg's end conditions), whether it is the
        `first_piece` (the only one a soft start applies to) and the `last_piece` (the only
        one the leg's end conditions bind, unless every piece is to meet them: `elimination`
        of a Lie step, any of which may be the last)."""
        ends = last_piece and not rest
        return leg_constraints(
            self.basis,
            self.duration if duration is None else duration,
            self.stratum.active,
            self.system.inputs,
            self.continuity,
            previous=self.previous if previous == "leg" else previous,
            next_active=self.next_active if ends else None,
            soft_start=self.soft_start and first_piece,
            full_stop=rest or (self.full_stop and last_piece),
        )

    def elimination(
        self,
        duration: float | None = None,
        previous: tuple[np.ndarray, np.ndarray] | str | None = "leg",
        rest: bool = False,
        first_piece: bool = True,
    ) -> Elimination:
        """The boundary conditions (`conditions`, of the leg or of one piece), eliminated
        (`λ = λp + N z`, eq. 26-29).

        Returns
        -------
        Elimination
            Every flat coefficient vector that meets the leg's continuity conditions is
            `particular + null @ z` for free `z` (`coefficients(z)`; `project(lam)` is the
            `z` nearest a given `lam`): search over `z` and the switches stay continuous.
        """
        return eliminate(self.conditions(duration, previous, rest, first_piece))

    def endpoint(self, q: np.ndarray | None = None, duration: float | None = None):
        """The end-point map of the leg's stratum from `q` (default: the leg's start).

        Parameters
        ----------
        q : ndarray, optional
            Where the controls start, shape (n,).
        duration : float, optional
            How long they run (default: the leg's).

        Returns
        -------
        callable
            `F(lam, jacobian=True)` -> `(q_end, J)`: the configuration the controls of flat
            coefficients `lam` lead to, shape (n,), and `J = ∂q_end/∂lam`, shape
            (n, lam.size) (None when `jacobian` is False). `lam` is a piece's coefficients
            (active inputs, `basis.size`) flattened row by row: an input's constant, then
            the sine and cosine of each harmonic (`Piece.coefficients`).
        """
        return make_endpoint(
            self.system.compiled(self.stratum),
            self.start if q is None else q,
            self.basis,
            self.duration if duration is None else duration,
            self.evaluator,
            self.tolerance,
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
    """What a leg planner returns; `stratified` turns it into a `LegPlan`.

    Attributes
    ----------
    pieces : tuple of Piece
        The leg's controls: one piece (a Newton leg) or one per step (a Lie leg), each with
        coefficients (active inputs, basis size) and times tiling the leg from 0.
    end : numpy.ndarray
        The configuration its controls reach (n,) (a planner of one's own: re-computed).
    error : float
        The distance of `end` from the leg's goal, in the leg's targets.
    iterations, attempts : int
        What the search took (reported; 0 and 1 where that means nothing).
    status : Status
        `Status.SUCCESS` where the goal is reached within the tolerance, else why not.
    free_coefficients : int
        The coefficients left free by the continuity conditions.
    evaluator : str
        How the end point was computed ("quadrature", "ode", "magnus", ...).
    message : str
        Why it failed ("" when it did not).
    strategy : str
        What reached the goal: "newton", "continuation" or "constrained" for stratplan's
        own; a planner of one's own that leaves the default gets its method name.
    """

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
        check made before planning (a leg with fewer free than needed cannot be planned).

        "Free" is `problem.elimination().free` for a planner that searches one piece; "needed"
        is how many equations its search solves: `len(problem.targets)` for an end-point
        search such as Newton's (one per steered coordinate), the Hall coordinates of its
        degree for a Lie step."""
