"""Dense samples of a planned motion, for plots and the MCAP log (no I/O).

`sample` re-integrates every leg from its recorded start with the leg's own Fourier controls
(scipy's DOP853, independent of the planner's end-point evaluator) on a uniform grid of
leg-local times, and places the samples on the real time axis (leg k spans
`[t0_k, t0_k + duration_k]`). Both ends of every leg are sampled, so a switch instant appears
twice: once as the end of the leg before it and once as the start of the leg after it.

Re-integration is bounded: a leg (or a piece of a Lie leg) gets at most `MAX_EVALUATIONS`
evaluations of its vector field. A leg that exceeds them (e.g. `period = 1e-12` or a duration
of 1e300 s), whose integration fails, or whose start or duration is not finite is not
integrated further: its configurations are NaN and `Trajectory.notes` says so.

`world_geometry` turns configurations of a planar manipulator (joints, then the base angle θ)
into inertial-frame drawings: base rectangle, joints and links. The inertial origin is the
fixed system CM; a base-frame point x is at `R(θ) (x − p_c)` (MODELS.md §1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from ..models.planar import PlanarManipulator, link_geometry
from ..stratified import LegResult, PlanResult

__all__ = ["Trajectory", "base_extent", "sample", "world_geometry"]

RTOL = 1e-10
ATOL = 1e-12
MAX_EVALUATIONS = 50_000  # per leg or Lie piece; DOP853 takes 12 per step


class _Budget(Exception):
    """The vector field was evaluated more than MAX_EVALUATIONS times."""


def _solve(rhs, duration: float, q0: np.ndarray, t_eval: np.ndarray) -> np.ndarray | None:
    """States at `t_eval` (len, n), or None when the integration is out of budget or fails."""
    q0 = np.asarray(q0, dtype=float)
    if not (math.isfinite(duration) and duration >= 0 and np.all(np.isfinite(q0))):
        return None
    if duration == 0:
        return np.repeat(q0[None], len(t_eval), axis=0)
    calls = 0

    def counted(t: float, y: np.ndarray) -> np.ndarray:
        nonlocal calls
        calls += 1
        if calls > MAX_EVALUATIONS:
            raise _Budget
        return rhs(t, y)

    try:
        with np.errstate(all="ignore"):
            sol = solve_ivp(
                counted,
                (0.0, duration),
                q0,
                method="DOP853",
                t_eval=t_eval,
                rtol=RTOL,
                atol=ATOL,
            )
    except (_Budget, ArithmeticError, ValueError, np.linalg.LinAlgError):
        return None
    if not sol.success or sol.y.shape[1] != len(t_eval):
        return None
    return sol.y.T


@dataclass(frozen=True)
class Trajectory:
    """Samples of a motion on the real time axis.

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

    def __len__(self) -> int:
        return int(self.t.size)

    def leg_slice(self, k: int) -> slice:
        """Index range of leg k's samples (they are contiguous)."""
        idx = np.flatnonzero(self.leg == k)
        return slice(int(idx[0]), int(idx[-1]) + 1) if idx.size else slice(0, 0)


def integrate_leg(plan: PlanResult, leg: LegResult, tau: np.ndarray) -> np.ndarray:
    """Configurations of `leg` at leg-local times `tau` (sorted, within [0, duration]).

    Parameters
    ----------
    plan : the plan (system and basis).
    leg : one of its legs.
    tau : leg-local times.

    Returns
    -------
    (len(tau), n) configurations; all NaN where the integration failed or ran out of its
    `MAX_EVALUATIONS` budget.
    """
    system, basis = plan.system, plan.settings.basis
    G = system.compiled(leg.stratum).G
    pieces = leg.piece_list() if hasattr(leg, "piece_list") else None
    if pieces is not None and len(pieces) > 1:  # a Lie leg: piece by piece, local times
        tau = np.asarray(tau, dtype=float)
        out = np.empty((tau.size, system.n))
        q = np.asarray(leg.start, dtype=float)
        for k, (t0, duration, coefficients) in enumerate(pieces):
            last = k == len(pieces) - 1
            inside = (tau >= t0) & (True if last else (tau < t0 + duration))
            L = np.asarray(coefficients, dtype=float)
            local = np.clip(tau[inside] - t0, 0.0, duration)
            t_eval = np.unique(np.append(local, float(duration)))
            y = _solve(lambda t, y, L=L: G(y) @ (L @ basis.values(t)), float(duration), q, t_eval)
            if y is None:
                y = np.full((t_eval.size, system.n), np.nan)
            out[inside] = y[np.searchsorted(t_eval, local)]
            q = y[-1]
        return out
    lam = np.asarray(leg.coefficients, dtype=float)

    def rhs(t: float, q: np.ndarray) -> np.ndarray:
        return G(q) @ (lam @ basis.values(t))

    y = _solve(rhs, float(leg.duration), leg.start, np.asarray(tau, dtype=float))
    return np.full((np.size(tau), system.n), np.nan) if y is None else y


def sample(plan: PlanResult, samples_per_leg: int = 200) -> Trajectory:
    """Re-integrate every leg of `plan` on `samples_per_leg` uniform instants (ends included)."""
    if samples_per_leg < 2:
        raise ValueError("samples_per_leg must be at least 2")
    system, basis = plan.system, plan.settings.basis
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
        us.append(leg.controls(basis, tau, system.m))
        dus.append(leg.controls(basis, tau, system.m, derivative=True))
        legs.append(np.full(tau.size, leg.index, dtype=int))
    if not plan.legs:
        empty = np.zeros(0)
        return Trajectory(
            empty,
            np.zeros((0, system.n)),
            np.zeros((0, system.m)),
            np.zeros((0, system.m)),
            np.zeros(0, dtype=int),
            (),
        )
    t = np.concatenate(ts)
    # t0 + duration of one leg and t0 of the next are sums of the same floats: force equality
    # so that time never steps back at a switch.
    t = np.maximum.accumulate(t)
    return Trajectory(
        t=t,
        q=np.concatenate(qs),
        u=np.concatenate(us),
        du=np.concatenate(dus),
        leg=np.concatenate(legs),
        strata=tuple(leg.stratum for leg in plan.legs),
        notes=tuple(notes),
    )


# --------------------------------------------------------------------------------------------
# Geometry of planar manipulators in the inertial frame
# --------------------------------------------------------------------------------------------


def base_extent(robot: PlanarManipulator) -> tuple[float, float]:
    """Half-extents (hx, hy) of the base rectangle along the base x and y axes.

    The base is `a × b` (MODELS.md §2) but which side lies along the base x axis is not part
    of the model. Choose the orientation that puts the arm mount points on the rectangle's
    boundary: model 1 (a = 1, b = 0.6, mount at 0.3 on x) gives (0.3, 0.5). Without a size,
    a square just reaching the farthest mount point is used.
    """
    mounts = np.array([arm.mount for arm in robot.arms], dtype=float)
    reach = float(np.max(np.abs(mounts))) if mounts.size else 0.0
    size = None
    if robot.base.a is not None and robot.base.b is not None:
        size = (robot.base.a, robot.base.b)
    if not size or min(size) <= 0:
        h = reach if reach > 0 else 0.25
        return h, h

    def misfit(hx: float, hy: float) -> float:
        # distance of each mount from the rectangle's boundary, in units of the rectangle
        r = np.maximum(np.abs(mounts[:, 0]) / hx, np.abs(mounts[:, 1]) / hy)
        return float(np.abs(r - 1.0).sum())

    a, b = size[0] / 2, size[1] / 2
    return (a, b) if misfit(a, b) <= misfit(b, a) else (b, a)


def _rotate(theta: np.ndarray, x: np.ndarray) -> np.ndarray:
    """R(θ) x for θ (N,) and x (N, ..., 2)."""
    c, s = np.cos(theta), np.sin(theta)
    shape = (-1,) + (1,) * (x.ndim - 2)
    c, s = c.reshape(shape), s.reshape(shape)
    return np.stack((c * x[..., 0] - s * x[..., 1], s * x[..., 0] + c * x[..., 1]), axis=-1)


def world_geometry(robot: PlanarManipulator, q: Any) -> dict[str, np.ndarray]:
    """Inertial-frame geometry of a planar manipulator at configurations q (N, k + 1).

    q holds the k joint angles then the base angle θ. Returns arrays over the N samples:

    * `theta` (N,), `base_center` (N, 2): base CM, `base_corners` (N, 4, 2).
    * `proximal`, `distal` (N, k, 2): the ends of each link (joint j is link j's proximal end).
    * `mount` (N, n_arms, 2), `arm_of_link` (k,).
    * base-frame quantities for the MCAP transforms: `base_proximal` (N, k, 2),
      `link_angle` (N, k) (link orientation relative to the base), `system_com` (N, 2).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    k = robot.n_joints
    if q.shape[-1] != k + 1:
        raise ValueError(f"q must have shape (N, {k + 1}) (joints, then theta), got {q.shape}")
    theta = q[:, k]
    geo = link_geometry(robot, q[:, :k])
    pc = geo["system_com"]  # (N, 2)
    hx, hy = base_extent(robot)
    corners = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])

    def world(x: np.ndarray) -> np.ndarray:
        return _rotate(theta, x - pc.reshape(pc.shape[0], *([1] * (x.ndim - 2)), 2))

    n = q.shape[0]
    mounts = np.broadcast_to(geo["mount"], (n, *geo["mount"].shape))
    return {
        "theta": theta,
        "base_center": world(np.zeros((n, 1, 2)))[:, 0],
        "base_corners": world(np.broadcast_to(corners, (n, 4, 2))),
        "proximal": world(geo["proximal"]),
        "distal": world(geo["distal"]),
        "mount": world(mounts),
        "arm_of_link": geo["arm_of_link"],
        "base_proximal": geo["proximal"],
        "link_angle": geo["angle"],
        "system_com": pc,
    }
