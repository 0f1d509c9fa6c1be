"""The legwise start of the energy search: each leg's lowest minimum alone, then joined.

The stacked problem of the energy objective (`stacked.StackedProblem`) has many local minima, and
the feasible-point SQP ends in the basin of its start. Most of that multiplicity is a product:
each leg has a few minima of its own (on the paper's strata: how many loops the joints run,
on which side and in which sense, to turn the base), and the legs are tied together only by
the linear continuity rows at their switches. So the search is split:

1. **Each leg alone** (`leg_minima`): the leg's own problem, with the rows that tie it to
   another leg dropped (its via is fixed either way), from its part of the stacked pulled
   start (the Newton plan pulled toward least energy, `energy.pulled_start`, which meets the
   leg's own rows and goals already) and from its *loop modes* (`mode_starts`): near the
   energy's minimiser the base's attitude is reached only at second order, by loops of the
   joints, so the eigenvectors of that goal's curvature (on the directions that keep the
   other goals) are the shapes of the loops - one turn, two turns, this side or that - and
   each, scaled to the attitude still missing, is a start. They are brought onto the goals
   by minimum-norm Gauss-Newton and raced as the stacked search's starts are.
2. **Joined by continuation in the switches** (`join`): the legs' lowest minima, stacked,
   meet every row except the switch rows, which they miss by `r0`. The rows' right-hand side
   `c + (1 - s) r0` is moved from `s = 0` (where the stacked minima are feasible and a
   minimum) to `s = 1` (the real conditions) in `JOIN_STEPS`, following the minimum with a few
   SQP iterations per step. Only the right-hand side moves, so the whitened coordinates stay
   the same along the way.

The joined point is one more start of the stacked search (`energy.optimise_energy`, kind
"legwise"), raced on its own after the others, so the result is never higher than without it.
"""

from __future__ import annotations

import itertools

import numpy as np

from ..continuity import Constraints
from .base import onto_goals

MODES = 5  # loop modes per leg (each with both signs)
FIRST_ORDER = 1e-6  # singular values of the goals' Jacobian below this (relative) are nil
MET = 1e-9  # goals this close (relative to the residual) are met to first order already
RESTORE_ITERATIONS, RESTORED = 20, 1e-9
JOIN_STEPS = (0.25, 0.5, 0.75, 1.0)
JOIN_ITERATIONS = 3  # SQP iterations per continuation step (the race finishes the last)
# numbers that break down make no legwise start, the search goes on without it (the same
# exceptions as `stratified.NUMERICAL_ERRORS`, which this package cannot import)
BROKE_DOWN = (ArithmeticError, np.linalg.LinAlgError, ValueError, RuntimeError)


def tied_rows(constraints: Constraints, offsets: np.ndarray) -> np.ndarray:
    """Mask of the rows of the stacked `constraints` that involve more than one leg."""
    used = np.abs(constraints.C) > 0
    legs = np.stack([used[:, a:b].any(axis=1) for a, b in itertools.pairwise(offsets)])
    return legs.sum(axis=0) > 1


def leg_constraints(constraints: Constraints, offsets: np.ndarray, i: int) -> Constraints:
    """Leg `i`'s own rows of the stacked `constraints` (those that tie it to no other leg)."""
    a, b = offsets[i], offsets[i + 1]
    own = ~tied_rows(constraints, offsets) & (np.abs(constraints.C[:, a:b]) > 0).any(axis=1)
    labels = tuple(label for label, k in zip(constraints.labels, own, strict=True) if k)
    return Constraints(constraints.C[own][:, a:b], constraints.c[own], labels)


def restore(problem, z: np.ndarray) -> np.ndarray | None:
    """`z` brought onto the goals by minimum-norm (whitened: least-energy) Gauss-Newton."""
    return onto_goals(problem._evaluate, z, RESTORED, RESTORE_ITERATIONS)


def mode_starts(leg_problem) -> list[np.ndarray]:
    """One leg's loop modes (whitened z, not yet on the goals; module docstring).

    At z1, the least-energy point meeting the goals to first order from the energy's
    minimiser, the goals that stay unmet are those the controls reach only at second order
    (the base's attitude: a loop of the joints turns it by about its area times the
    curvature there). Their model along the directions that keep the met goals is quadratic,
    `½ δᵀ H δ` in the direction of the residual: an eigenvector e of H with eigenvalue h > 0,
    scaled to `t = sqrt(2 |r| / h)`, meets it, at energy t² above z1. The `MODES` largest
    such h, each with both signs, are the starts: loops of different shapes and turns."""
    from .stacked import null_space

    centre = -0.5 * leg_problem._b  # the energy's minimiser in the whitened coordinates
    r, J = leg_problem._evaluate(centre, True)
    if r.size == 0 or centre.size == 0:
        return [centre]
    U, S, Vt = np.linalg.svd(J)
    rank = int(np.sum(S > FIRST_ORDER * S[0])) if S.size and S[0] > 0 else 0
    z1 = centre - Vt[:rank].T @ ((U[:, :rank].T @ r) / S[:rank])
    r1, J1 = leg_problem._evaluate(z1, True)
    size = float(np.linalg.norm(r1))
    if not np.isfinite(size) or size == 0.0:
        return [z1]
    met = np.abs(r1) <= MET * size
    Z = null_space(J1[met]) if met.any() else np.eye(z1.size)
    h, E = np.linalg.eigh(Z.T @ leg_problem.constraint_hessian(z1, -r1 / size) @ Z)
    starts = []
    for k in np.argsort(-h)[:MODES]:
        if h[k] <= 0.0:
            break
        step = np.sqrt(2.0 * size / h[k]) * (Z @ E[:, k])
        starts += [z1 + step, z1 - step]
    return starts


def leg_minimum(own, settings, newton, pulled: bool = False) -> np.ndarray | None:
    """The lowest minimum of one leg's own problem `own` (whitened z) from its Newton part
    pulled toward least energy and its loop modes (`mode_starts`), raced; None if no start
    reaches the goals. With `pulled` the part is pulled already (the stacked pulled start's)
    and is the start as it is: pulling the leg alone again found no lower minimum on the
    paper's scenarios and cost 6-12 % of the legwise start's end-point evaluations."""
    from .energy import pulled_start, race

    with np.errstate(all="ignore"):
        first = own.project(newton) if pulled else pulled_start(own, own.project(newton))
        starts = ([] if first is None else [first]) + mode_starts(own)
        zs = [z for z in (restore(own, z) for z in starts) if z is not None]
    runs = [r for r in race(own, zs, settings.tolerance) if r.feasible]
    best = min(runs, key=lambda r: r.energy, default=None)
    return None if best is None else best.z


def leg_minima(problem, system, settings, newton, pulled: bool = False) -> list[np.ndarray] | None:
    """Each leg's lowest minimum of its own problem (flat coefficients per leg), or None if
    a leg has no start that reaches its goals; `pulled`: `newton` is the stacked pulled
    start (`leg_minimum`)."""
    from .stacked import StackedProblem

    out = []
    for i, part in enumerate(problem.split(newton)):
        own = StackedProblem(
            system,
            [problem.endpoints[i].q0],
            [problem.legs[i]],  # (its free via coordinates held as the problem holds them)
            settings,
            [problem.targets[i]],
            leg_constraints(problem.constraints, problem.offsets, i),
        )
        z = leg_minimum(own, settings, part, pulled)
        if z is None:
            return None
        out.append(own.coefficients(z))
    return out


def join(problem, parts: list[np.ndarray], tolerance: float) -> np.ndarray | None:
    """The stacked legs `parts` carried onto the real switch conditions by continuation in
    their right-hand side (module docstring); whitened z of the full problem, or None."""
    from .sqp import Descent

    lam = np.concatenate(parts)
    cons = problem.constraints
    miss = cons.C @ lam - cons.c
    current = problem.with_rhs(cons.c + miss)
    z = current.project(lam)
    for s in JOIN_STEPS:
        step = problem if s >= 1.0 else problem.with_rhs(cons.c + (1.0 - s) * miss)
        with np.errstate(all="ignore"):
            z = restore(step, z)
            if z is None:
                return None
            run = Descent(step, z, tolerance)
            while not run.done and run.iterations < JOIN_ITERATIONS:
                run.step()
        if not run.feasible:
            return None
        z = run.z
    return z


def legwise_start(problem, system, settings, newton, pulled=False) -> np.ndarray | None:
    """The legwise start (module docstring) as whitened z of `problem`, or None; `pulled`:
    `newton` is the stacked pulled start (`leg_minimum`)."""
    try:
        with np.errstate(all="ignore"):
            parts = leg_minima(problem, system, settings, newton, pulled)
            if parts is None:
                return None
            if not tied_rows(problem.constraints, problem.offsets).any():
                return problem.project(np.concatenate(parts))  # nothing ties the legs
            return join(problem, parts, settings.tolerance)
    except BROKE_DOWN:
        return None
