"""How hard a leg is for its stratum, estimated before planning from the bracket structure.

At the leg's nominal start `q`, let `B` be the stratum's generators and Lie brackets (Hall
basis, degree 2, or 3 where 2 does not span) restricted to the coordinates the leg steers,
`δ` the asked displacement on them, `σ` the smallest singular value of `B` (the one the
check reports) and `u` its left singular vector: the direction that is hardest to move,
named by its largest component. `k` is the lowest bracket degree whose fields span the
steered coordinates at `q`.

A degree-`k` bracket moves the system along its field by about `(aT)^k / (4π)^(k-1)` when
the inputs have amplitude `a` over the leg's duration `T` (one loop of two sinusoids sweeps an
area `a²T²/4π`); moving `|u·δ|` along a direction whose fields have strength `σ` thus takes
`a ≈ ((4π)^(k-1) |u·δ| / σ)^(1/k) / T` and the energy `∫|u|² ≈ m T a²` with `m` inputs:

    predicted energy = (m / T) · ((4π)^(k-1) · |u·δ| / σ)^(2/k).

It is an order of magnitude, not a bound. A leg is flagged as expected to be ill-conditioned
when its predicted energy exceeds `WARN_ENERGY`, or when it needs third-order brackets at its
start (its degree-2 fields leave the hard direction unreachable to first order there, so the
Newton Jacobian starts out nearly singular) and must move more than `WARN_LEVERAGE` along it
(`|u·δ| / σ`). Calibration: every leg of the shipped scenarios predicts at most 3.2e3 and
needs at most degree 2. Issue 14's 4-link arm turning its base 10° at q = 0 needs degree 3
on every stratum; on S12 (the two light distal links) `|u·δ| / σ` is 53 (plain Newton runs
seconds and ends at energy 2.2e3 after the energy search, or fails), on S34 (the two heavy
proximal links) it is 3.1 and the leg plans at energy 28: S13 and S23 (32, 34) are flagged
too, the other strata (2.5-8.4) are not.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .controllability import _rank_and_sigma
from .liealgebra import MAX_DEGREE, lie_basis
from .models.system import System

__all__ = ["WARN_ENERGY", "WARN_LEVERAGE", "Reach", "better_strata", "out_of_reach", "reach"]

# how `out_of_reach` ends: tuning the search cannot help such a leg (`leg_failures` advises)
NOT_TRIED = "(no continuation tried)"

WARN_ENERGY = 1e4  # predicted energy above which a leg is flagged
WARN_LEVERAGE = 10.0  # |u·δ| / σ above which a leg needing third-order brackets is flagged
LOOP_GAIN = 4.0 * np.pi  # a degree-k bracket moves (aT)^k / LOOP_GAIN^(k-1)


@dataclass(frozen=True)
class Reach:
    """The reachability estimate of one leg on one stratum (see the module docstring)."""

    stratum: str
    targets: tuple[int, ...]
    degree: int  # lowest bracket degree spanning the steered coordinates at the start
    sigma: float  # smallest singular value of the fields and brackets on them
    hard: int  # the coordinate hardest to move (largest component of the weakest direction)
    displacement: float  # |u·δ|: the asked displacement along the weakest direction
    energy: float  # predicted energy

    @property
    def leverage(self) -> float:
        """|u·δ| / σ: how far the weakest fields must be pushed."""
        return self.displacement / max(self.sigma, 1e-300)

    @property
    def weak(self) -> bool:
        """Expected to be ill-conditioned (the thresholds of the module docstring)."""
        third = self.degree >= MAX_DEGREE and self.leverage > WARN_LEVERAGE
        return bool(third or self.energy > WARN_ENERGY)


def _degree(element) -> int:
    return 1 if isinstance(element, int) else _degree(element[0]) + _degree(element[1])


def reach(
    system: System, stratum: str, q: np.ndarray, goal: np.ndarray, duration: float
) -> Reach | None:
    """The estimate of steering `q` to `goal` (NaN: free) on `stratum` in `duration`; None
    when the leg steers nothing or its stratum does not span what it steers at `q`."""
    s = system.stratum(stratum)
    q, goal = np.asarray(q, dtype=float), np.asarray(goal, dtype=float)
    targets = tuple(j for j in s.free(system.n) if not np.isnan(goal[j]))
    if not targets:
        return None
    for degree in range(2, MAX_DEGREE + 1):
        lb = lie_basis(system, s, degree)
        B = lb.evaluate(q)[[lb.free.index(j) for j in targets]]
        if _rank_and_sigma(B[None], len(targets))[0][0] == len(targets):
            break
    else:
        return None
    degrees = np.array([_degree(h) for h in lb.elements])
    k = next(
        d
        for d in range(1, degree + 1)
        if _rank_and_sigma(B[:, degrees <= d][None], len(targets))[0][0] == len(targets)
    )
    U, S, _ = np.linalg.svd(B)
    sigma, u = float(S[len(targets) - 1]), U[:, len(targets) - 1]
    along = float(abs(u @ (goal[list(targets)] - q[list(targets)])))
    energy = len(s.active) / duration * (LOOP_GAIN ** (k - 1) * along / sigma) ** (2.0 / k)
    hard = targets[int(np.argmax(np.abs(u)))]
    return Reach(s.name, targets, k, sigma, hard, along, float(energy))


def better_strata(
    system: System, q: np.ndarray, goal: np.ndarray, duration: float, than: Reach
) -> list[Reach]:
    """The model's other strata that can do the same leg (they lock nothing the leg moves)
    and are not flagged, cheapest predicted energy first, cheaper than `than` or not
    needing its degree."""
    q, goal = np.asarray(q, dtype=float), np.asarray(goal, dtype=float)
    out = []
    for name in system.strata:
        s = system.stratum(name)
        moved = [k for k in s.locked if not np.isnan(goal[k]) and abs(goal[k] - q[k]) > 1e-9]
        if name == than.stratum or moved:
            continue
        r = reach(system, name, q, goal, duration)
        if r is not None and not r.weak and (r.energy < than.energy or r.degree < than.degree):
            out.append(r)
    return sorted(out, key=lambda r: r.energy)


UNSPANNED_RTOL = 1e-7  # singular values below this × the largest: a direction not spanned


def out_of_reach(
    system: System, stratum: str, q: np.ndarray, goal: np.ndarray, tolerance: float
) -> str | None:
    """Why a URDF leg cannot reach `goal` (NaN: free) from `q` on `stratum`, or None.

    The leg's fields and Lie brackets (degree 2, else 3) at `q`, restricted to the
    coordinates it steers, leave some directions unspanned, and the goal lies more than
    `tolerance` off the spanned ones (the attitude's displacement in the body frame at `q`,
    the brackets' own frame). Analytic fields whose brackets miss a direction everywhere on
    the stratum cannot move along it (S1 of robots/arm3.urdf at j1 = 0 turns the base about
    y only); the newton planner asks this once two of its attempts failed, instead of a
    continuation that would fail too (tens of seconds on a URDF leg). Other models: None
    (their continuation runs as before).
    """
    if getattr(system, "spatial", None) is None:
        return None
    from . import so3

    s = system.stratum(stratum)
    q, goal = np.asarray(q, dtype=float), np.asarray(goal, dtype=float)
    targets = [j for j in s.free(system.n) if not np.isnan(goal[j])]
    if not targets:
        return None
    delta = goal[targets] - q[targets]
    k = system.spatial.n_joints
    attitude = [r for r, j in enumerate(targets) if j >= k]
    if len(attitude) == 3:  # on the group: log(R0ᵀ R_goal), the body-frame displacement
        delta[attitude] = so3.log(so3.exp(q[k:]).T @ so3.exp(goal[k:]))
    for degree in range(2, MAX_DEGREE + 1):
        lb = lie_basis(system, s, degree)
        with np.errstate(all="ignore"):
            B = lb.evaluate(q)[[lb.free.index(j) for j in targets]]
        if not np.isfinite(B).all():
            return None
        U, S, _ = np.linalg.svd(B)
        rank = int(np.sum(S > UNSPANNED_RTOL * max(S[0] if S.size else 0.0, 1e-300)))
        if rank == len(targets):
            return None
    missing = U[:, rank:]
    off = missing.T @ delta
    if float(np.linalg.norm(off)) <= tolerance:
        return None
    worst = missing @ off  # the part of the displacement no field or bracket moves along
    name = system.states[targets[int(np.argmax(np.abs(worst)))]]
    return (
        f"{s.name} cannot move {name} from the leg's start: its fields and Lie brackets up to "
        f"degree {degree} span {rank} of the {len(targets)} coordinates the leg steers there, "
        f"and its goal lies {float(np.linalg.norm(off)):.3g} off them {NOT_TRIED}"
    )
