"""Energy-optimal planning (beyond the paper): min Σ ∫|u|² subject to reaching every via.

All legs are optimised together: the continuity conditions of the whole sequence are linear in
the stacked coefficients and eliminated once (`λ = λp + N z`, N whitened so that the energy is
`e0 + b·z + |z|²`); the goals are nonlinear equality constraints with exact Jacobians and
Hessians (the legs' quadrature end-point maps). The problem `min λᵀMλ s.t. k_i(λ_i) = goal_i`
is solved by a feasible-point SQP with the exact Hessian of the Lagrangian (`Descent`), from
several deterministic starts that are raced (`optimise_energy`), then from starts that move a
leg's loop onto a peak of the base's curvature (`loops`, by default) and, if asked, from the
legs' own minima joined (`legwise`).
"""

from __future__ import annotations

import numpy as np

from ..models.system import System
from ..results import EXACT_HESSIAN, SR1_UPDATES, Optimisation, StartOutcome
from ..wording import counted
from .base import (
    ENERGY_RUNAWAY,
    damped_gauss_newton,
    no_divergence_check,
    onto_goals,
)
from .legwise import legwise_start
from .loops import loop_starts
from .sqp import KEPT, MINIMUM, PG_TOL, Descent
from .stacked import StackedProblem

ABANDON_AFTER, ABANDON_RATIO = 4, 1.25  # drop a start this far above the best so far
MODEL_ABOVE = 1.05  # ... or whose Newton model's minimum is this far above it
SAME_MINIMUM = 1e-2  # relative energy-norm distance at which two starts share a minimum
SAME_ENERGY = 1e-9  # relative: a later start wins only if lower than this (`LATER`)
# the start of a URDF robot's legs made of each leg's lowest Newton plan
# (`stratcli.newton_starts.lowest_legs`)
LOWEST_LEGS = "lowest legs"
SEARCHED = ("loop", "legwise")  # the starts `[planner] search` adds (`loops`, `legwise`)
LATER = (*SEARCHED, LOWEST_LEGS)  # starts raced after the others
# why no loop start (`Optimisation.no_loop_start`), besides `loops.loop_starts`' reasons
NO_MINIMUM = "no start reached a minimum to begin them from"
NO_HESSIANS = "the legs have no exact second derivatives (URDF robots, ODE-path legs)"
# The pulled start (`pulled_start`): Gauss-Newton on |c(z)|² + w²|z - z*|² for each weight
# w in turn (z* the energy's unconstrained minimiser), each for at most PULL_ITERATIONS, then
# back onto the goals by minimum-norm Gauss-Newton (at most RESTORE_ITERATIONS, to RESTORED).
PULL_WEIGHTS = (0.316, 0.1, 0.0316)
PULL_ITERATIONS, RESTORE_ITERATIONS, RESTORED = 15, 30, 1e-9


def optimise_energy(
    system: System,
    starts: list[np.ndarray],
    legs,
    settings,
    targets: list[np.ndarray],
    seeds: list[tuple[str, np.ndarray]],
    constraints=None,
    progress=None,
    pg_tol: float = PG_TOL,
) -> tuple[list[np.ndarray] | None, Optimisation]:
    """Minimum energy over all legs from each of `seeds` ((kind, stacked feasible
    coefficients); the kind is recorded, e.g. "newton" or "warm start").

    Returns the best coefficients (flat, per leg; None if no start succeeded) and the record
    of the search (`newton_energy` is left for the caller).

    `starts` are the legs' nominal start configurations (the previous leg's via).

    The starts are raced, not run one after another: every start first takes
    `ABANDON_AFTER` iterations; then the starts still running are finished in the order of
    their energy, lowest first, so that the best energy is known early and a start still
    `ABANDON_RATIO` above it is dropped before it spends iterations on a worse minimum. A
    start whose energy is `ENERGY_RUNAWAY` times the first feasible start's is not run at all
    (stopped "diverged").

    `constraints` (`continuity.Constraints` on the stacked coefficients) replace the
    sequence's boundary conditions (`continuity.sequence_constraints` of `settings`), e.g. a
    relaxation of them (`stratcli.screen`).

    `progress(phase)` is told the starts that are raced, once they are known (the pulled
    start is made here), then the loop starts and the legwise start; default: silent.
    `pg_tol`: the relative projected gradient at which a start has converged (`sqp.PG_TOL`;
    a leg bound of the screen without exact Hessians needs less, `leg_bounds.BOUND_PG_TOL`).
    """
    say = progress or (lambda phase: None)
    problem = StackedProblem(system, starts, legs, settings, targets, constraints)
    if not problem.exact_hessians:  # URDF, ODE-path legs: first-order steps are slow
        # the first start (the warm start or the Newton plan) alone, as the search always
        # ran; then the starts that follow the Newton plan (a URDF robot's lowest legs, the
        # seeded Newton plans `starts` asks for), raced after it against its result, as the
        # loop starts are: never higher than it alone
        lead = 1 + next((k for k, (kind, _) in enumerate(seeds) if kind == "newton"), len(seeds))
        seeds, extra = seeds[:lead], seeds[lead:]
        say(f"energy search: minimum energy from {_starts(seeds[:1])}")
        runs = _first_kept(problem, seeds, settings.tolerance, pg_tol)
        seeds = seeds[: len(runs)]
        if extra:
            say(f"energy search: {_starts(extra)} more, raced after the first")
            kept = [run for run in runs if run.feasible and run.reason in KEPT]
            low = min((run.energy for run in kept), default=np.inf)
            minima = [run.z for run in kept if run.reason in MINIMUM]
            zs = [problem.project(lam) for _, lam in extra]
            runs += race(problem, zs, settings.tolerance, pg_tol, (low, minima))
            seeds = [*seeds, *extra]
    else:
        say("energy search: pulling the Newton plan toward low energy (a start)")
        seeds = _with_pulled_start(problem, seeds, settings.starts)
        say(f"energy search: minimum energy from {_starts(seeds)}")
        zs = [problem.project(lam) for _, lam in seeds]
        runs = race(problem, zs, settings.tolerance, pg_tol)
    # the later starts are raced on their own, after the others: the others' race (which
    # abandons a start that an earlier low one outruns) is the same with or without them, so
    # the result is never higher
    no_loops = ""  # why the loop starts made none (result.json optimisation.no_loop_start)
    if settings.search != "starts" and not problem.exact_hessians:
        no_loops = NO_HESSIANS
    elif settings.search != "starts":
        minima = [run for run in runs if run.feasible and run.reason in MINIMUM]
        lowest = min(minima, key=lambda run: run.energy, default=None)
        loops, no_loops = [], NO_MINIMUM
        if lowest is not None:  # from the lowest
            loops, no_loops = loop_starts(problem, lowest.z)
        if loops:
            say(
                f"energy search: {counted(len(loops), 'loop start')} (a leg's loop moved onto a "
                "peak of the base's curvature)"
            )
            seeds = [*seeds, *(("loop", problem.coefficients(z)) for z in loops)]
            # against the minima the other starts reached: a loop start well above them after
            # a few iterations is dropped, one heading for one of them stops there
            known = (lowest.energy, [run.z for run in minima])
            runs += race(problem, loops, settings.tolerance, pg_tol, known)
    if problem.exact_hessians and settings.search == "legwise":
        say(f"energy search: start {len(seeds) + 1}, made leg by leg (legwise)")
        z = legwise_start(problem, system, settings, *_newton_part(seeds))
        if z is not None:
            seeds = [*seeds, ("legwise", problem.coefficients(z))]
            runs += race(problem, [z], settings.tolerance, pg_tol)

    problem.set_accuracy(None)  # the results' goal errors: on the legs' own accuracy
    outcomes: list[StartOutcome] = []
    best_index, coefficients = None, None
    best_energy = np.inf
    for k, run in enumerate(runs):
        z = run.z
        err = float(np.abs(problem.constraint(z)).max()) if len(z) else 0.0
        energy = problem.energy(z)
        ok = bool(np.isfinite(energy) and err <= 0.1 * settings.tolerance)
        outcomes.append(
            StartOutcome(
                k,
                seeds[k][0],
                energy,
                err,
                run.pg if run.pg_at is z else problem.projected_gradient(z),
                run.iterations,
                ok and run.reason in MINIMUM,
                run.seconds,
                run.reason or "not started",
                feasible=ok,
            )
        )
        # a start stopped next to a minimum another start reached is not a candidate: its
        # energy can undercut that converged one only by rounding; nor is a later start at
        # the others' minimum (it changes a plan only where it finds a lower one)
        below = best_energy * (1.0 - SAME_ENERGY) if seeds[k][0] in LATER else best_energy
        if ok and run.reason != "same minimum" and energy < below:
            best_energy = energy
            best_index = k
            coefficients = problem.split(problem.coefficients(z))
    method = EXACT_HESSIAN if problem.exact_hessians else SR1_UPDATES  # (`sqp.Descent`'s)
    search = settings.search if problem.exact_hessians else "starts"  # (as run)
    optimisation = Optimisation(tuple(outcomes), best_index, None, method, search, no_loops)
    return coefficients, optimisation


def race(
    problem: StackedProblem,
    zs: list[np.ndarray],
    tolerance: float,
    pg_tol: float = PG_TOL,
    known: tuple[float, list[np.ndarray]] = (np.inf, []),
) -> list[Descent]:
    """The feasible SQP from each start `zs` (whitened), raced (`optimise_energy`); the runs,
    in the order of `zs`. `known`: the lowest energy and the minima an earlier race reached,
    which this one abandons against and stops at as the minima it finds itself."""
    runs = [Descent(problem, z, tolerance, pg_tol) for z in zs]
    found: list[np.ndarray] = list(known[1])  # minima reached by finished starts
    best = [known[0]]

    first = next((run.energy for run in runs if run.feasible), np.inf)

    def finish(run: Descent, iterations: int | None) -> None:
        while not run.done and (iterations is None or run.iterations < iterations):
            if run.energy > ENERGY_RUNAWAY * first:
                run.stop("diverged")  # ran away from the first feasible start's energy
            elif run.iterations >= ABANDON_AFTER and run.energy > ABANDON_RATIO * best[0]:
                run.stop("abandoned")  # energy only decreases: unlikely to beat the best
            elif run.iterations >= ABANDON_AFTER and (run.model_low or 0.0) > MODEL_ABOVE * best[0]:
                run.stop("abandoned")  # its own Newton model's minimum is well above the best
            elif any(
                np.linalg.norm(run.z - f) <= SAME_MINIMUM * np.sqrt(run.energy) for f in found
            ):
                run.stop("same minimum")  # converging to a minimum already found
            else:
                run.step()
        if run.done and run.feasible:
            best[0] = min(best[0], run.energy)
            if run.reason in MINIMUM:
                found.append(run.z)  # a minimum (not a start dropped on the way down)

    for run in runs:
        finish(run, ABANDON_AFTER)
    for run in sorted(runs, key=lambda r: r.energy if np.isfinite(r.energy) else np.inf):
        finish(run, None)
    return runs


def _first_kept(
    problem: StackedProblem, seeds: list, tolerance: float, pg_tol: float = PG_TOL
) -> list[Descent]:
    """The SQP from the first of `seeds` only, or while it ends off the goals (its start not
    restored onto them, or it ran away) from the next one: a leg's bound must come from a
    search, not from the Newton plan a failed one leaves (`leg_bounds.leg_minimum`)."""
    runs: list[Descent] = []
    for _, lam in seeds:
        runs += race(problem, [problem.project(lam)], tolerance, pg_tol)
        if runs[-1].feasible and runs[-1].reason in KEPT:
            break
    return runs


def pulled_start(problem: StackedProblem, z: np.ndarray) -> np.ndarray | None:
    """A start made from `z` by a quadratic-penalty continuation toward least energy, or None
    if it cannot be brought back onto the goals.

    Gauss-Newton on the residuals (c(z), w (z - z*)), z* the minimiser of the energy alone
    (which is |z - z*|² plus a constant in the whitened coordinates), for each weight of
    PULL_WEIGHTS in turn, then minimum-norm Gauss-Newton steps back onto the goals. The path
    leaves the goals on the way, which the feasible-point descent never does: from every
    plain Newton plan of the paper's scenarios it ends in the basin of the lowest minimum
    that the seeded Newton plans had found, or of a lower one.
    """
    target = -0.5 * problem._b
    eye = np.eye(z.size)
    for w in PULL_WEIGHTS:

        def pulled(x, jacobian, w=w):
            c, J = problem._evaluate(x, jacobian)
            r = np.concatenate([c, w * (x - target)])
            return -r, (None if J is None else np.vstack([J, w * eye])), None

        z = damped_gauss_newton(
            pulled,
            z,
            tolerance=0.0,
            max_iterations=PULL_ITERATIONS,
            mu=1e-3,
            stall_window=5,
            diverged=no_divergence_check,
            lazy=True,
        ).z

    return onto_goals(problem._evaluate, z, RESTORED, RESTORE_ITERATIONS)


def _with_pulled_start(problem: StackedProblem, seeds: list, count: int) -> list:
    """`seeds` with the pulled start of the first Newton plan before it (`pulled_start`);
    with a single start wanted (`count` 1) it replaces that plan. Unchanged if there is no
    Newton plan or its pulled start cannot be made."""
    k = next((i for i, (kind, _) in enumerate(seeds) if kind == "newton"), None)
    if k is None:
        return seeds
    with np.errstate(all="ignore"):
        z = pulled_start(problem, problem.project(seeds[k][1]))
    if z is None:
        return seeds
    pulled = ("pulled", problem.coefficients(z))
    return [*seeds[:k], pulled, *seeds[k + (1 if count <= 1 else 0) :]]


def _starts(seeds: list) -> str:
    """`2 starts (pulled, newton)`, `4 starts (pulled, newton ×3)`: how many, of which kinds."""
    kinds = [kind for kind, _ in seeds]
    counts = {kind: kinds.count(kind) for kind in kinds}  # in order of first appearance
    shown = ", ".join(kind if n == 1 else f"{kind} ×{n}" for kind, n in counts.items())
    return f"{counted(len(seeds), 'start')} ({shown})"


def _newton_part(seeds: list) -> tuple[np.ndarray, bool]:
    """The Newton plan among `seeds` (or its pulled start, or the first) for the legwise
    start (`legwise.legwise_start`), and whether it is the pulled start."""
    kind, lam = next((s for s in seeds if s[0] in ("newton", "pulled")), seeds[0])
    return lam, kind == "pulled"
