"""What planning returns: frozen, picklable values (a sequence plan → legs → pieces; switches).

Numbering (the same in the CLI, `result.json` and the MCAP log): legs are numbered from 1 in
everything a person reads (tables, messages, figure labels) and from 0 in everything a program
reads (`LegPlan.index`, the position in `result.json["legs"]`, `after_leg` of a switch, the
`leg` field of MCAP messages). A switch `after_leg = k` joins leg k and leg k + 1 (0-based).

Times: a piece's controls use its own local time from 0; a leg's pieces start at leg-local
`t0`; a leg starts at `t0` on the plan's time axis. A Newton leg is one piece, a Lie leg one
piece per step.

A plan refers to its model (`ModelRef`: the name and the scenario's `[model]` table); it does
not hold compiled functions, so it pickles small and a record can be loaded back without a
compile (`SequencePlan.from_dict`). `sample` rebuilds the model when it needs to integrate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .controls import FourierBasis, energy
from .settings import PlannerSettings
from .status import Status

__all__ = [
    "SCHEMA",
    "LegPlan",
    "ModelRef",
    "Optimisation",
    "Piece",
    "SequencePlan",
    "StartOutcome",
    "Switch",
    "Timings",
]

SCHEMA = "stratplan.result/1"


def _frozen(x: Any) -> np.ndarray:
    a = np.array(x, dtype=float)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Piece:
    """Controls of one piece: Fourier coefficients (m_active, 2H+1) on [0, duration]."""

    t0: float  # leg-local start time
    duration: float
    coefficients: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "coefficients", _frozen(self.coefficients))


@dataclass(frozen=True, eq=False)
class LegPlan:
    """One planned (or failed) leg.

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
    """

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

    def __post_init__(self) -> None:
        for name in ("start", "goal", "end"):
            object.__setattr__(self, name, _frozen(getattr(self, name)))
        object.__setattr__(self, "pieces", tuple(self.pieces))

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
        """All inputs (or their derivatives) at leg-local times `t`, shape (len(t), m).

        Inputs inactive on the leg are zero. At a joint between two pieces the later piece is
        used (they join as the continuity mode promises); at the leg's end, the last piece.
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.zeros((t.size, self.n_inputs))
        starts = np.array([p.t0 for p in self.pieces])
        which = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.pieces) - 1)
        for k, piece in enumerate(self.pieces):
            sel = which == k
            if sel.any():
                local = t[sel] - piece.t0
                phi = self.basis.derivatives(local) if derivative else self.basis.values(local)
                out[np.ix_(sel, list(self.active))] = np.atleast_2d(phi) @ piece.coefficients.T
        return out

    def end_controls(self) -> tuple[np.ndarray, np.ndarray]:
        """Values and derivatives of all inputs at the leg's end (the next leg's start)."""
        T = np.array([self.duration])
        return self.controls(T)[0], self.controls(T, True)[0]


@dataclass(frozen=True, eq=False)
class Switch:
    """The instant between leg `after_leg` and the next (0-based), with the control jumps
    `u_next(0) − u_prev(T)` of all inputs and of their derivatives."""

    time: float
    after_leg: int
    jump: np.ndarray
    jump_derivative: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "jump", _frozen(self.jump))
        object.__setattr__(self, "jump_derivative", _frozen(self.jump_derivative))


@dataclass(frozen=True)
class StartOutcome:
    """One start of the energy objective's multi-start search, as in result.json."""

    index: int
    kind: str  # where the start came from: "newton" (a seeded Newton plan) or "warm start"
    energy: float
    goal_error: float
    projected_gradient: float
    iterations: int
    converged: bool
    seconds: float
    stopped: str = ""


@dataclass(frozen=True)
class Optimisation:
    """The energy objective's search: every start, which won, and plain Newton's energy."""

    starts: tuple[StartOutcome, ...]
    best: int | None
    newton_energy: float | None
    method: str = "feasible SQP, exact Hessian of the Lagrangian"


@dataclass(frozen=True)
class Timings:
    """When planning started (UTC, ISO 8601) and how long it took, s (for manifest.json)."""

    started: str = ""
    compile_s: float = float("nan")  # generating numeric functions (and the check)
    planning_s: float = float("nan")


@dataclass(frozen=True)
class ModelRef:
    """Which model a plan is for: its name (result.json `model`) and, when it came from a
    scenario, the `[model]` table it is built from (so the model can be rebuilt)."""

    name: str
    spec: Any = None


@dataclass(frozen=True, eq=False)
class SequencePlan:
    """A planned sequence of legs (or how far it got).

    Build one with `stratcli.plan`; read one back with `stratcli.load_run`. `ok` is True when
    every leg reached its goal; `message` says which leg failed and what to try.
    """

    scenario: str
    model: ModelRef
    coordinates: tuple[str, ...]
    inputs: tuple[str, ...]
    settings: PlannerSettings
    start: np.ndarray
    goal: np.ndarray
    legs: tuple[LegPlan, ...]
    switches: tuple[Switch, ...]
    planned_legs: int
    message: str = ""
    optimisation: Optimisation | None = None
    time_scale: float = 1.0
    notes: tuple[str, ...] = ()
    reference_energy: float | None = None
    scenario_text: str = field(default="", repr=False)  # the scenario it was planned from
    timings: Timings = Timings()
    _system: Any = field(default=None, repr=False, compare=False)  # not pickled

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", _frozen(self.start))
        object.__setattr__(self, "goal", _frozen(self.goal))
        object.__setattr__(self, "legs", tuple(self.legs))
        object.__setattr__(self, "switches", tuple(self.switches))
        object.__setattr__(self, "notes", tuple(self.notes))

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_system"] = None  # the model is referenced, never pickled
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)

    # ---- summary -------------------------------------------------------------------------
    @property
    def ok(self) -> bool:
        """Every planned leg reached its goal, and every leg was planned."""
        return (
            self.planned_legs > 0
            and len(self.legs) == self.planned_legs
            and all(leg.converged for leg in self.legs)
        )

    @property
    def status(self) -> Status:
        """`SUCCESS`, or the status of the first leg that failed (`NOT_PLANNED` if missing)."""
        for leg in self.legs:
            if not leg.converged:
                return leg.status
        return Status.SUCCESS if self.ok else Status.NOT_PLANNED

    @property
    def total_energy(self) -> float:
        """Σ over legs of ∫|u|² dt (exact Gram-matrix energies)."""
        return float(sum(leg.energy for leg in self.legs))

    @property
    def duration(self) -> float:
        """Total duration, s."""
        return float(sum(leg.duration for leg in self.legs))

    @property
    def end(self) -> np.ndarray | None:
        """Where the last planned leg ended."""
        return self.legs[-1].end if self.legs else None

    @property
    def system(self):
        """The model (rebuilt from its reference, and cached, when the plan was loaded)."""
        if self._system is None:
            from .models.specs import system_from_ref

            object.__setattr__(self, "_system", system_from_ref(self.model))
        return self._system

    def with_system(self, system) -> SequencePlan:
        """The same plan bound to an already built model (no rebuild on `sample`)."""
        out = replace(self)
        object.__setattr__(out, "_system", system)
        return out

    # ---- controls and trajectory ---------------------------------------------------------
    def controls(self, t: np.ndarray | float, derivative: bool = False) -> np.ndarray:
        """All inputs at plan times `t`, shape (len(t), m); at a switch the later leg."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.zeros((t.size, len(self.inputs)))
        if not self.legs:
            return out
        starts = np.array([leg.t0 for leg in self.legs])
        which = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.legs) - 1)
        for k, leg in enumerate(self.legs):
            sel = which == k
            if sel.any():
                out[sel] = leg.controls(t[sel] - leg.t0, derivative)
        return out

    def sample(self, samples_per_leg: int = 200):
        """Re-integrate the plan (independently of the planner) on the real time axis.

        Parameters
        ----------
        samples_per_leg : int
            Uniform instants per leg, both ends included (a switch appears twice).

        Returns
        -------
        Trajectory
            With arrays `t` (N,), `q` (N, n), `u` (N, m), `du` (N, m) and `leg` (N,);
            unpacks as ``t, q, u = plan.sample()``.
        """
        from .simulate import sample

        return sample(self, samples_per_leg)

    # ---- result.json ---------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The `result.json` document (schema "stratplan.result/1")."""
        from .resultdoc import plan_document

        return plan_document(self)

    @classmethod
    def from_dict(cls, doc: dict[str, Any], settings: PlannerSettings | None = None, model=None):
        """A plan read back from a `result.json` document (nothing is re-planned).

        `settings` (e.g. the record's scenario) fill what result.json does not hold; `model`
        is the `ModelRef` to rebuild the model from.
        """
        from .resultdoc import plan_from_document

        return plan_from_document(cls, doc, settings, model)


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


def finite_or_none(x: float | None) -> float | None:
    """A number for JSON: non-finite values (a leg stopped by overflow) become null."""
    return None if x is None or not math.isfinite(x) else float(x)
