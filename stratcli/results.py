"""The parts of a plan: frozen, picklable values (legs → pieces; switches; the energy search).

`stratcli.sequence.SequencePlan` holds them.

Numbering (the same in the CLI, `result.json` and the MCAP log): legs are numbered from 1 in
everything a person reads (tables, messages, figure labels) and from 0 in everything a program
reads (`LegPlan.index`, the position in `result.json["legs"]`, `after_leg` of a switch, the
`leg` field of MCAP messages). A switch `after_leg = k` joins leg k and leg k + 1 (0-based).

Times: a piece's controls use its own local time from 0; a leg's pieces start at leg-local
`t0`; a leg starts at `t0` on the plan's time axis. A Newton leg is one piece, a Lie leg one
piece per step.

A plan refers to its model (`ModelRef`: the name and the scenario's `[model]` table); it does
not hold compiled functions, so it pickles small and a record can be loaded back without a
compile.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .arguments import flag
from .controls import FourierBasis, energy
from .status import Status
from .time_axis import checked_times
from .values import ByValue
from .wording import counted

__all__ = [
    "EXACT_HESSIAN",
    "SCHEMA",
    "SR1_UPDATES",
    "LegPlan",
    "ModelRef",
    "Optimisation",
    "Piece",
    "StartOutcome",
    "Switch",
    "Timings",
    "finite_or_none",
    "make_leg",
    "nan_to_none",
    "none_to_nan",
]

SCHEMA = "stratplan.result/1"


def frozen_array(x: Any) -> np.ndarray:
    """`x` as a new read-only float array (a value's field: no one can change it in place)."""
    a = np.array(x, dtype=float)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Piece(ByValue):
    """Controls of one piece: Fourier coefficients (m_active, 2H+1) on [0, duration].

    Attributes
    ----------
    t0 : float
        The piece's start, s, from its leg's start.
    duration : float
        Its length, s.
    coefficients : ndarray
        Shape (m_active, 2H+1): per active input, the constant, then sin and cos of each
        harmonic (`FourierBasis`).
    """

    _hashed = ("t0", "duration")

    t0: float  # leg-local start time
    duration: float
    coefficients: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "coefficients", frozen_array(self.coefficients))

    def __repr__(self) -> str:  # the dataclass's printed every coefficient
        rows, cols = np.shape(self.coefficients)
        return f"Piece(t0 {self.t0:g} s, {self.duration:g} s, coefficients {rows} inputs x {cols})"


@dataclass(frozen=True, eq=False)
class LegPlan(ByValue):
    """One planned (or failed) leg; legs compare by value (every field).

    Attributes
    ----------
    index : 0-based position in the sequence (legs are "leg index + 1" to people).
    stratum, method, evaluator : names, as in result.json.
    active, locked, targets : input / coordinate indices (active inputs, locked coordinates,
        coordinates steered to the goal).
    t0, duration : start on the plan's time axis and length, s.
    start, goal, end : configurations (goal is NaN where not prescribed).
    pieces : the controls; one piece for a Newton leg.
    error, iterations, attempts, energy, free_coefficients : as in result.json.
    status : how the leg ended.
    basis : the Fourier basis of every piece.
    n_inputs : number of inputs of the model (inactive ones are 0).
    message : the numerical failure, if any (added to the status' advice).
    strategy : what reached the goal: "newton" (damped Newton and its restarts),
        "continuation" (a homotopy along the line to the goal, after two of Newton's attempts
        stalled, or all of them) or
        "constrained" (the constrained search over all legs together: `iterations` and
        `attempts` are then its iterations, plus any Newton polish of the leg, and starts).
    """

    _hashed = ("index", "stratum", "duration")
    index: int
    stratum: str
    method: str
    evaluator: str
    active: tuple[int, ...]
    locked: tuple[int, ...]
    targets: tuple[int, ...]
    t0: float
    duration: float
    start: np.ndarray
    goal: np.ndarray
    end: np.ndarray
    pieces: tuple[Piece, ...]
    error: float
    iterations: int
    attempts: int
    energy: float
    free_coefficients: int
    status: Status
    basis: FourierBasis
    n_inputs: int
    message: str = ""
    strategy: str = "newton"

    def __post_init__(self) -> None:
        for name in ("start", "goal", "end"):
            object.__setattr__(self, name, frozen_array(getattr(self, name)))
        object.__setattr__(self, "pieces", tuple(self.pieces))

    def __repr__(self) -> str:  # the dataclass's prints every piece's coefficients (kB)
        return (
            f"LegPlan(leg {self.index + 1} on {self.stratum}, {self.method}: "
            f"{self.status.name}, error {self.error:.2g}, energy {self.energy:.6g}, "
            f"t {self.t0:g} to {self.t0 + self.duration:g} s, "
            f"{counted(len(self.pieces), 'piece')})"
        )

    @property
    def converged(self) -> bool:
        """True when the leg reached its goal within tolerance."""
        return self.status.ok

    @property
    def coefficients(self) -> np.ndarray:
        """(m_active, 2H+1) for a one-piece leg; (pieces, m_active, 2H+1) otherwise."""
        if len(self.pieces) == 1:
            return self.pieces[0].coefficients
        return np.stack([p.coefficients for p in self.pieces])

    def controls(self, t: np.ndarray | float, derivative: bool = False) -> np.ndarray:
        """All inputs (or their derivatives) at leg-local times `t`.

        Inputs inactive on the leg are zero. At a joint between two pieces the later piece is
        used (they join as the continuity mode promises); at the leg's end, the last piece.

        Parameters
        ----------
        t : float or array of float
            Times from the leg's start, s, from 0 to `duration` (`SequencePlan.controls`
            takes the plan's time).
        derivative : bool
            The inputs' time derivatives instead of their values.

        Returns
        -------
        ndarray
            Shape (len(t), m), or (m,) for a single time (as `SequencePlan.controls`).

        Raises
        ------
        InputError
            A time outside [0, duration] (beyond rounding, `TIME_ROUNDING` of it): the Fourier
            series would be extrapolated, not the leg.
        TypeError
            `t` not a number or array of numbers, `derivative` not True or False.
        """
        flag("derivative", derivative)
        t, single = checked_times(t, self.duration, "the leg (times from its start: "
                                  "plan.controls takes the plan's)")  # fmt: skip
        out = np.zeros((t.size, self.n_inputs))
        starts = np.array([p.t0 for p in self.pieces])
        which = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.pieces) - 1)
        for k, piece in enumerate(self.pieces):
            sel = which == k
            if sel.any():
                local = t[sel] - piece.t0
                phi = self.basis.derivatives(local) if derivative else self.basis.values(local)
                out[np.ix_(sel, list(self.active))] = np.atleast_2d(phi) @ piece.coefficients.T
        return out[0] if single else out

    def end_controls(self) -> tuple[np.ndarray, np.ndarray]:
        """Values and derivatives of all inputs at the leg's end (the next leg's start).

        Returns
        -------
        tuple of ndarray
            (u, u'), each of shape (m,).
        """
        T = np.array([self.duration])
        return self.controls(T)[0], self.controls(T, True)[0]


@dataclass(frozen=True, eq=False)
class Switch(ByValue):
    """The instant between leg `after_leg` and the next (0-based), with the control jumps
    `u_next(0) − u_prev(T)` of all inputs and of their derivatives.

    Attributes
    ----------
    time : float
        When it happens, s from the plan's start.
    after_leg : int
        The leg it ends (0-based).
    jump, jump_derivative : ndarray
        Shape (m,): the jumps of every input and of its time derivative.
    """

    _hashed = ("time", "after_leg")

    time: float
    after_leg: int
    jump: np.ndarray
    jump_derivative: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "jump", frozen_array(self.jump))
        object.__setattr__(self, "jump_derivative", frozen_array(self.jump_derivative))


@dataclass(frozen=True)
class StartOutcome:
    """One start of the energy objective's multi-start search, as in result.json.

    Attributes
    ----------
    index : int
        Its place among the starts, from 0.
    kind : str
        Where it came from: "pulled", "newton", "warm start", "loop", "legwise" or
        "lowest legs" (README: result.json, `optimisation`).
    energy, goal_error, projected_gradient : float
        Where its search ended.
    iterations : int
        Of its search.
    converged : bool
        Its search reached a minimum (`stopped` "converged" or "noise floor").
    seconds : float
        Wall time of its search.
    stopped : str
        Why its search ended.
    feasible : bool
        It ends on the goals (a candidate for the plan).
    """

    index: int
    kind: str  # where the start came from: "pulled" (the Newton plan pulled toward least
    # energy), "newton" (a Newton plan, seeded or not), "warm start", "loop" (a leg's loop
    # moved onto a curvature peak, `planners.loops`), "legwise" (the legs' own minima
    # joined, `planners.legwise`) or "lowest legs" (each leg's lowest of several Newton
    # plans, `newton_starts.lowest_legs`: URDF robots)
    energy: float
    goal_error: float
    projected_gradient: float
    iterations: int
    converged: bool  # the search from it reached a minimum (`stopped` converged or noise floor)
    seconds: float
    stopped: str = ""
    feasible: bool = True  # it ends on the goals (a candidate for the plan)


EXACT_HESSIAN = "feasible SQP, exact Hessian of the Lagrangian"  # `Optimisation.method`
SR1_UPDATES = "feasible SQP, the goals' curvature by symmetric-rank-one updates"


@dataclass(frozen=True)
class Optimisation:
    """The energy objective's search: every start, which won, and plain Newton's energy.

    Attributes
    ----------
    starts : tuple of StartOutcome
        Every start, in the order searched.
    best : int or None
        The winning start's index in `starts` (None: none ended on the goals).
    newton_energy : float or None
        The energy of plain Newton's plan.
    method : str
        The search, in words (exact Hessians, or SR1 updates where the legs have no second
        derivatives).
    search : str
        `[planner] search` as run: "loops", "starts" or "legwise".
    no_loop_start : str
        Why the loop search made no loop start ("" where it made some).
    """

    starts: tuple[StartOutcome, ...]
    best: int | None
    newton_energy: float | None
    method: str = EXACT_HESSIAN  # or SR1_UPDATES (legs without second derivatives)
    search: str = ""  # as run: "loops", "starts" or "legwise" ("": a record made before it)
    no_loop_start: str = ""  # why the loop search made no loop start ("" where it made some)

    def __repr__(self) -> str:  # the dataclass's ran to 700 characters for two starts
        ends = ", ".join(
            f"{s.kind} {s.energy:.6g}" + ("" if s.converged else f" ({s.stopped or 'stopped'})")
            for s in self.starts
        )
        best = "none" if self.best is None else f"start {self.best + 1}"
        return f"Optimisation({len(self.starts)} starts: {ends}; best {best})"


@dataclass(frozen=True)
class Timings:
    """When planning started (UTC, ISO 8601) and how long it took, s (for manifest.json).

    Attributes
    ----------
    started : str
        UTC, ISO 8601 ("" where not known).
    compile_s, planning_s : float
        Seconds generating the model's numeric functions (not the check), and planning.
    """

    started: str = ""
    compile_s: float = float("nan")  # generating numeric functions (not the check)
    planning_s: float = float("nan")


@dataclass(frozen=True)
class ModelRef:
    """Which model a plan is for: its name (result.json `model`) and, when it came from a
    scenario, the `[model]` table it is built from (so the model can be rebuilt).

    Attributes
    ----------
    name : str
        As result.json's `model`.
    spec : model table or None
        The validated `[model]` table (None: not known).
    """

    name: str
    spec: Any = None

    def __repr__(self) -> str:  # the dataclass's printed the whole [model] table
        path = getattr(self.spec, "path", None)
        return f"ModelRef({self.name!r}" + (f", {path!r})" if path else ")")


def make_leg(**values: Any) -> LegPlan:
    """A `LegPlan` whose energy is computed from its pieces when not given."""
    if "energy" not in values:
        basis = values["basis"]
        values["energy"] = float(
            sum(energy(basis, p.duration, p.coefficients) for p in values["pieces"])
        )
    return LegPlan(**values)


def nan_to_none(x: Any) -> list[float | None]:
    """A vector for JSON: NaN (not prescribed) and other non-finite values become null."""
    return [float(v) if math.isfinite(v) else None for v in np.asarray(x, dtype=float)]


def none_to_nan(values: Any) -> np.ndarray:
    """A vector from JSON or a scenario's tables: null ("*", not prescribed) becomes NaN (the
    inverse of `nan_to_none`)."""
    return np.array([np.nan if v is None else v for v in values], dtype=float)


def finite_or_none(x: float | None) -> float | None:
    """A number for JSON: non-finite values (a leg stopped by overflow) become null."""
    return None if x is None or not math.isfinite(x) else float(x)
