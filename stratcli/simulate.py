"""Re-integration of a plan: dense samples on the real time axis (no I/O).

`sample` re-integrates every leg from its recorded start with the leg's own Fourier controls
(DOP853, `stratcli.odeint`: scipy's algorithm without importing scipy.integrate;
independent of the planner's end-point evaluator) on a uniform grid of
leg-local times, and places the samples on the real time axis (leg k spans
`[t0_k, t0_k + duration_k]`). Both ends of every leg are sampled, so a switch instant appears
twice: once as the end of the leg before it and once as the start of the leg after it.
Records (plots, MCAP) and `SequencePlan.sample` use it.

Re-integration is bounded: a leg (or a piece of a Lie leg) gets at most `MAX_EVALUATIONS`
evaluations of its vector field. A leg that exceeds them (e.g. `period = 1e-12` or a duration
of 1e300 s), whose integration fails, or whose start or duration is not finite is not
integrated further: its configurations are NaN and `Trajectory.notes` says so.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .odeint import OutOfSteps, dop853
from .results import LegPlan
from .values import ByValue

if TYPE_CHECKING:  # the plan type holds a sampler; only its annotations are needed here
    from .sequence import SequencePlan

__all__ = ["Trajectory", "integrate_leg", "sample"]

RTOL = 1e-10
ATOL = 1e-12
MAX_EVALUATIONS = 50_000  # per leg or Lie piece; DOP853 takes 12 per step


@dataclass(frozen=True, eq=False)
class Trajectory(ByValue):
    """Samples of a motion on the real time axis; unpacks as ``t, q, u = trajectory`` (and
    indexes so: ``trajectory[1]`` is q). A value: read-only arrays, equal by their samples.

    Attributes
    ----------
    t : (N,) times, non-decreasing; each leg contributes `samples_per_leg` samples including
        both its ends.
    q : (N, n) configurations (re-integrated).
    u : (N, m) controls; inputs inactive on a leg are exactly zero there.
    du : (N, m) time derivatives of the controls.
    leg : (N,) index of the leg each sample belongs to (0-based).
    strata : name of the stratum of each leg.
    notes : what could not be re-integrated (those legs' `q` are NaN), empty when all were.
    """

    t: np.ndarray
    q: np.ndarray
    u: np.ndarray
    du: np.ndarray
    leg: np.ndarray
    strata: tuple[str, ...]
    notes: tuple[str, ...] = ()
    _hashed = ("strata", "size")

    def __post_init__(self) -> None:
        self._read_only()

    def _read_only(self) -> None:
        for array in (self.t, self.q, self.u, self.du, self.leg):
            if isinstance(array, np.ndarray):
                array.setflags(write=False)

    def __iter__(self):
        return iter((self.t, self.q, self.u))

    def __getitem__(self, index):  # `sample()[1]` as `t, q, u = sample()` unpacks
        return (self.t, self.q, self.u)[index]

    def __repr__(self) -> str:  # the dataclass's prints every sample (kB)
        span = f"t {self.t[0]:g} to {self.t[-1]:g} s" if self.t.size else "no time"
        failed = f", {len(self.notes)} notes" if self.notes else ""
        return (
            f"Trajectory({self.t.size} samples, {span}, {self.q.shape[-1]} coordinates, "
            f"{self.u.shape[-1]} inputs, legs ({', '.join(self.strata)}){failed})"
        )

    @property
    def size(self) -> int:
        """Number of samples N."""
        return int(self.t.size)

    def leg_slice(self, k: int) -> slice:
        """Index range of a leg's samples (they are contiguous).

        Parameters
        ----------
        k : int
            The leg, counted from 0.

        Returns
        -------
        slice
            Into `t`, `q`, `u`, `du` and `leg`.

        Raises
        ------
        IndexError
            A leg the trajectory does not have.
        """
        legs = len(self.strata)
        if not 0 <= k < legs:
            raise IndexError(
                f"leg {k} out of range: the trajectory has {legs} legs (0 to {legs - 1})"
            )
        idx = np.flatnonzero(self.leg == k)
        return slice(int(idx[0]), int(idx[-1]) + 1) if idx.size else slice(0, 0)


class _Budget(Exception):
    """The vector field was evaluated more than MAX_EVALUATIONS times."""


def _field(G, basis, L) -> Callable[[float, np.ndarray], np.ndarray]:
    """`(t, y) -> G(y) @ (L @ basis.values(t))` with the same numbers at less cost per call.

    Re-integration costs a few thousand calls, each of a few microseconds of arithmetic and,
    done generically, tens of Python/numpy overhead: here φ(t) is written into one buffer
    (the products `t ω` and their sines and cosines are those of `basis.values`) and a
    generated `G` is evaluated at the single point by `ArrayFunction.at`.
    """
    at = getattr(G, "at", G)  # other models' G take one point as well
    L = np.asarray(L, dtype=float)
    omega = np.asarray(basis.omega, dtype=float)
    phi = np.ones(2 * omega.size + 1)
    sines, cosines = phi[1 : omega.size + 1], phi[omega.size + 1 :]

    def field(t: float, y: np.ndarray) -> np.ndarray:
        wt = t * omega
        np.sin(wt, out=sines)
        np.cos(wt, out=cosines)
        return at(y).dot(L.dot(phi))  # `.dot`: the products of `@`, less overhead

    return field


def _integrate(G, basis, L, q0, duration: float, t_eval: np.ndarray) -> np.ndarray | None:
    """States at `t_eval` (len, n), or None when out of budget, failed or not finite."""
    q0 = np.asarray(q0, dtype=float)
    duration = float(duration)
    if not (math.isfinite(duration) and duration >= 0 and np.all(np.isfinite(q0))):
        return None
    if duration == 0:
        return np.repeat(q0[None], len(t_eval), axis=0)
    field = _field(G, basis, L)
    calls = 0

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        nonlocal calls
        calls += 1
        if calls > MAX_EVALUATIONS:
            raise _Budget
        return field(t, y)

    try:
        with np.errstate(all="ignore"):
            y = dop853(rhs, duration, q0, t_eval, rtol=RTOL, atol=ATOL)
    except (_Budget, OutOfSteps, ArithmeticError, ValueError, np.linalg.LinAlgError):
        return None
    return y if np.all(np.isfinite(y)) else None


def integrate_leg(plan: SequencePlan, leg: LegPlan, tau: np.ndarray) -> np.ndarray:
    """Configurations of `leg` at leg-local times `tau` (sorted, within [0, duration]).

    Parameters
    ----------
    plan : SequencePlan
        The plan (its model is rebuilt if needed).
    leg : LegPlan
        One of its legs.
    tau : ndarray
        Leg-local times.

    Returns
    -------
    ndarray
        (len(tau), n) configurations; NaN where the integration failed or ran out of its
        `MAX_EVALUATIONS` budget.
    """
    system = plan.system
    G = system.compiled(leg.stratum).G
    tau = np.asarray(tau, dtype=float)
    out = np.empty((tau.size, system.n))
    q = np.asarray(leg.start, dtype=float)
    for k, piece in enumerate(leg.pieces):  # piece by piece, each in its local time
        last = k == len(leg.pieces) - 1
        inside = (tau >= piece.t0) & (True if last else (tau < piece.t0 + piece.duration))
        local = np.clip(tau[inside] - piece.t0, 0.0, piece.duration)
        t_eval = np.unique(np.append(local, float(piece.duration)))
        y = _integrate(G, leg.basis, piece.coefficients, q, piece.duration, t_eval)
        if y is None:
            y = np.full((t_eval.size, system.n), np.nan)
        out[inside] = y[np.searchsorted(t_eval, local)]
        q = y[-1]
    if not leg.pieces:
        out[:] = np.nan
    return out


def sample(plan: SequencePlan, samples_per_leg: int = 200) -> Trajectory:
    """Re-integrate every leg of `plan` on `samples_per_leg` uniform instants (ends included)."""
    if samples_per_leg < 2:
        raise ValueError("samples_per_leg must be at least 2")
    n, m = len(plan.coordinates), len(plan.inputs)
    if not plan.legs:
        empty = np.zeros(0)
        return Trajectory(
            empty, np.zeros((0, n)), np.zeros((0, m)), np.zeros((0, m)), np.zeros(0, int), ()
        )
    ts, qs, us, dus, legs, notes = [], [], [], [], [], []
    for leg in plan.legs:
        tau = np.linspace(0.0, float(leg.duration), samples_per_leg)
        ts.append(leg.t0 + tau)
        q = integrate_leg(plan, leg, tau)
        if not np.all(np.isfinite(q)):
            notes.append(
                f"leg {leg.index + 1}: the trajectory could not be re-integrated (not finite, "
                f"failed, or more than {MAX_EVALUATIONS} evaluations); its samples are NaN"
            )
        qs.append(q)
        us.append(leg.controls(tau))
        dus.append(leg.controls(tau, derivative=True))
        legs.append(np.full(tau.size, leg.index, dtype=int))
    # t0 + duration of one leg and t0 of the next are sums of the same floats: force equality
    # so that time never steps back at a switch.
    t = np.maximum.accumulate(np.concatenate(ts))
    return Trajectory(
        t=t,
        q=np.concatenate(qs),
        u=np.concatenate(us),
        du=np.concatenate(dus),
        leg=np.concatenate(legs),
        strata=tuple(leg.stratum for leg in plan.legs),
        notes=tuple(notes),
    )
