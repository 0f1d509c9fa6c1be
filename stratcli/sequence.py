"""A planned sequence of legs: the value `stratcli.plan` returns and `load_run` reads back.

Frozen and picklable (the model is referenced, never pickled); `to_dict` is `result.json`
(`stratcli.resultdoc`), `sample` the independent re-integration (`stratcli.simulate`). Leg and
switch numbering is documented in `stratcli.results`.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .arguments import flag, integer
from .constraint_report import ConstraintReport
from .errors import InputError
from .models.specs import system_from_ref
from .resultdoc import plan_document, plan_from_document
from .results import (
    LegPlan,
    ModelRef,
    Optimisation,
    Switch,
    Timings,
    frozen_array,
)
from .settings import PlannerSettings
from .simulate import Trajectory, integrate_leg, sample
from .status import Status
from .time_axis import checked_times
from .values import MadeAgainOnUnpickling

__all__ = ["SequencePlan"]


@dataclass(frozen=True, eq=False, repr=False)  # == below: by value (the fields hold arrays)
class SequencePlan(MadeAgainOnUnpickling):
    """A planned sequence of legs (or how far it got).

    Build one with `stratcli.plan`; read one back with `stratcli.load_run`. `ok` is True when
    every leg reached its goal; `message` says which leg failed and what to try. Two plans
    are equal when their result.json documents and scenarios are (a plan and its pickle, or
    its record read back, are equal, and so are two plans of one scenario: times are left out).

    Attributes
    ----------
    scenario : the scenario's name.
    model : what the model is (`ModelRef`: its result.json name and [model] table).
    coordinates, inputs : the model's names (q1, ..., theta; u1, ...), in order.
    settings : the planner settings it was planned with (`PlannerSettings`).
    start, goal : configurations (goal is NaN where left free).
    legs : the planned legs (`LegPlan`); fewer than `planned_legs` if one failed.
    switches : the joints between legs and their control jumps (`Switch`).
    planned_legs : how many legs the sequence has.
    message : why it failed ("" if it did not).
    optimisation : the energy search (`Optimisation`: its starts and where each ended);
        None under the Newton objective.
    time_scale : how many times faster than planned it runs (`time_scaled`, rate limits).
    notes : what a user should know of it (the lines `stratplan plan` prints as `note:`).
    reference_energy : the paper's energy for the task, if the scenario gives one.
    scenario_text : the scenario as TOML (the record's scenario.toml).
    timings : when it was planned and how long that took (`Timings`).
    constraints : the [constraints] table and each leg's smallest margins on a dense
        re-integration (`ConstraintReport`); None without the table.

    Derived: `ok`, `status`, `total_energy`, `duration`, `end`, `sample()`, `controls(t)`,
    `to_dict()` (result.json).
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
    constraints: ConstraintReport | None = None  # the [constraints] table and the margins
    _system: Any = field(default=None, repr=False, compare=False)  # pickled for URDF only

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", frozen_array(self.start))
        object.__setattr__(self, "goal", frozen_array(self.goal))
        object.__setattr__(self, "legs", tuple(self.legs))
        object.__setattr__(self, "switches", tuple(self.switches))
        object.__setattr__(self, "notes", tuple(self.notes))

    def __repr__(self) -> str:  # the fields' reprs run to many kB (settings, legs' arrays)
        legs = ", ".join(leg.stratum for leg in self.legs)
        count = len(self.legs)  # a failed plan stops at its first failed leg: say of how many
        of = f" of {self.planned_legs}" if self.planned_legs > count else ""
        noun = "leg" if count == 1 and not of else "legs"
        return (
            f"SequencePlan({self.scenario!r}: {self.status.name}, energy "
            f"{self.total_energy:.6g}, {count}{of} {noun} ({legs}), {self.duration:g} s)"
        )

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        system = state.get("_system")
        if getattr(system, "spatial", None) is None:
            state["_system"] = None  # rebuilt from the [model] table it references, exactly
        # a URDF model pickles as its URDF text (`SpatialRobot`, a few kB): its [model] table
        # names only a file, which may have changed or gone where the plan is unpickled
        return state  # (`MadeAgainOnUnpickling`: its arrays read-only again when unpickled)

    # ---- summary -------------------------------------------------------------------------
    @property
    def ok(self) -> bool:
        """Every leg was planned and reached its goal, within the constraints if any."""
        return (
            self.planned_legs > 0
            and len(self.legs) == self.planned_legs
            and all(leg.converged for leg in self.legs)
            and (self.constraints is None or self.constraints.ok)
        )

    @property
    def status(self) -> Status:
        """`SUCCESS`, the status of the first leg that failed (`NOT_PLANNED` if missing), or
        `CONSTRAINT_VIOLATED`."""
        for leg in self.legs:
            if not leg.converged:
                return leg.status
        if self.constraints is not None and not self.constraints.ok:
            return Status.CONSTRAINT_VIOLATED
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
            object.__setattr__(self, "_system", system_from_ref(self.model))
        return self._system

    def with_system(self, system) -> SequencePlan:
        """The same plan bound to an already built model (no rebuild on `sample`).

        Parameters
        ----------
        system : System
            The model the plan's `ModelRef` describes (it is not checked against it).

        Returns
        -------
        SequencePlan
            A copy that uses `system` instead of rebuilding it.
        """
        out = replace(self)
        object.__setattr__(out, "_system", system)
        return out

    # ---- controls and trajectory ---------------------------------------------------------
    def controls(self, t: np.ndarray | float, derivative: bool = False) -> np.ndarray:
        """All inputs at plan times `t`; at a switch the later leg.

        Parameters
        ----------
        t : float or array of float
            Times on the plan's axis, s, from 0 to `duration`.
        derivative : bool
            The inputs' time derivatives instead of their values.

        Returns
        -------
        ndarray
            Shape (len(t), m), or (m,) for a single time; inputs inactive on a leg are 0.

        Raises
        ------
        InputError
            A time outside [0, duration] (beyond rounding, `TIME_ROUNDING` of the duration):
            the Fourier series would be extrapolated, not the plan.
        """
        flag("derivative", derivative)
        t, single = checked_times(t, self.duration, "the plan")
        out = np.zeros((t.size, len(self.inputs)))
        if not self.legs:
            return out[0] if single else out
        starts = np.array([leg.t0 for leg in self.legs])
        which = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.legs) - 1)
        for k, leg in enumerate(self.legs):
            sel = which == k
            if sel.any():
                local = np.clip(t[sel] - leg.t0, 0.0, leg.duration)  # (rounding: its own)
                out[sel] = leg.controls(local, derivative)
        return out[0] if single else out

    def states(self, t: np.ndarray | float) -> np.ndarray:
        """Configurations at plan times `t`, re-integrated from each leg's start as `sample`
        does (independently of the planner); at a switch the later leg's start.

        Parameters
        ----------
        t : float or array of float
            Times on the plan's axis, s, from 0 to `duration`, in any order.

        Returns
        -------
        ndarray
            Shape (len(t), n), or (n,) for a single time; NaN where a leg could not be
            re-integrated (as in `sample`).

        Raises
        ------
        InputError
            A time outside [0, duration] (beyond rounding).
        """
        t, single = checked_times(t, self.duration, "the plan")
        out = np.full((t.size, len(self.coordinates)), np.nan)
        if not self.legs:
            return out[0] if single else out
        starts = np.array([leg.t0 for leg in self.legs])
        which = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.legs) - 1)
        for k, leg in enumerate(self.legs):
            rows = np.flatnonzero(which == k)
            if rows.size:
                local = np.clip(t[rows] - leg.t0, 0.0, leg.duration)
                order = np.argsort(local, kind="stable")  # (integrated forward in time)
                out[rows[order]] = integrate_leg(self, leg, local[order])
        return out[0] if single else out

    def sample(self, samples_per_leg: int = 200) -> Trajectory:
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
        integer(2)("samples_per_leg", samples_per_leg)
        return sample(self, int(samples_per_leg))

    # ---- result.json ---------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The `result.json` document.

        Returns
        -------
        dict
            Schema "stratplan.result/1" (`stratcli.record_schema("result")`); plain JSON
            values, non-finite numbers as None.
        """
        return plan_document(self)

    def __eq__(self, other: object) -> bool:
        if self is other:
            return True
        if not isinstance(other, SequencePlan):
            return NotImplemented
        return _scenario_of(self) == _scenario_of(other) and _timeless(self.to_dict()) == _timeless(
            other.to_dict()
        )

    def __hash__(self) -> int:  # of what equal plans share, cheaply
        return hash((self.scenario, self.planned_legs, len(self.legs)))

    @classmethod
    def from_dict(cls, doc: dict[str, Any], settings: PlannerSettings | None = None, model=None):
        """A plan read back from a `result.json` document (nothing is re-planned).

        The document holds no scenario text, so the plan equals the one it came from only
        in its `to_dict()` (plans compare their scenarios too: `load_run` reads a record's
        scenario.toml as well, and that plan is equal).

        Parameters
        ----------
        doc : dict
            The document (`to_dict`, or a record's result.json).
        settings : PlannerSettings, optional
            What result.json does not hold (e.g. from the record's scenario).
        model : ModelRef, optional
            The model to rebuild (default: the one the document names).

        Returns
        -------
        SequencePlan

        Raises
        ------
        InputError
            `doc` is not a result document (a key missing, a value of the wrong type).
        """
        if not isinstance(doc, dict):
            raise InputError(f"a result document is a dict, not {type(doc).__name__}")
        try:
            return plan_from_document(cls, doc, settings, model)
        except InputError:
            raise
        except KeyError as exc:  # (the others: their own message says what was wrong)
            raise InputError(f"not a result document: no {exc.args[0]!r}") from None
        except (TypeError, ValueError, IndexError, AttributeError) as exc:
            raise InputError(f"not a result document ({type(exc).__name__}: {exc})") from None


def _timeless(doc: Any) -> Any:
    """A result document without how long its parts took (each energy-search start's
    `seconds`): the same task planned twice is the same plan."""
    if isinstance(doc, dict):
        return {k: _timeless(v) for k, v in doc.items() if k != "seconds"}
    if isinstance(doc, list):
        return [_timeless(v) for v in doc]
    return doc


def _scenario_of(plan: SequencePlan) -> Any:
    """What plans compare of their scenarios: its tables (the file's comments and layout
    aside: a scenario from a file and the same from a dict plan the same), a URDF robot's
    without the [model] path and with the URDF's own text: a record names its copy of the
    URDF (`records.model_files`), so a plan read back with `load_run` differed from the plan."""
    try:
        tables = tomllib.loads(plan.scenario_text)
    except tomllib.TOMLDecodeError:
        return plan.scenario_text
    if plan.model.name != "urdf":
        return tables
    model = {k: v for k, v in (tables.get("model") or {}).items() if k != "path"}
    robot = getattr(plan.system, "spatial", None)
    return {**tables, "model": model}, getattr(robot, "text", None)
