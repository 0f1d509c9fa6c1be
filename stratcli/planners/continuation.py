"""Continuation for legs damped Newton cannot reach (issue 14, item 1).

Damped Newton from a few starts fails on some large legs: the error stalls in a local minimum
far from the goal. The endogenous configuration space approach the paper's Newton method
comes from is a continuation method, and so is this fallback: the goal is moved along the
straight line from the leg's start to its goal in configuration space (on the targeted
coordinates), `g(s) = start + s (goal − start)`, and each intermediate goal is solved by damped
Newton from the previous solution's coefficients. Near s = 0 the goal is close to where small
controls already lead, and each solution is a good start for the next goal.

The step in `s` is adaptive: halved when a step fails, grown when it was easy, never below a
minimum; the number of steps and the total iterations are bounded, so a leg that cannot be
reached this way still fails in bounded time. The last step is always the real goal at the
leg's tolerance; intermediate goals need only be reached to a looser tolerance.

Where the followed branch of solutions folds (the θ row of the Jacobian becomes a combination
of the joint rows, so no small change of the controls moves the goal further: the step shrinks
to its minimum), the next goal is tried from the last solution plus a seeded perturbation of
growing size (`KICKS`): a jump to a nearby branch that goes on. Deterministic per seed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .base import GaussNewtonResult, damped_gauss_newton

__all__ = ["ContinuationResult", "follow_line"]

FIRST_STEP = 0.25  # first step along the line (fraction of the start-to-goal displacement)
MIN_STEP = 1.0 / 64.0  # a step that must shrink below this ends the continuation
GROW = 1.5  # step growth after an easy step ...
EASY = 8  # ... one that needed at most this many iterations
MAX_STEPS = 80  # continuation steps (successful or not) before giving up
MAX_ITERATIONS = 3000  # Newton iterations over all steps before giving up
STEP_ITERATIONS = 40  # Newton iterations per step
LOOSE = 10.0  # intermediate goals are reached to LOOSE × the leg's tolerance
MU = 1e-4  # initial relative damping of every step
KICKS = (0.4, 0.8, 1.6, 3.2)  # perturbations tried at a fold, × the leg's displacement scale
KICK_STEP = 1.0 / 16.0  # the step a kick tries (and the step after a successful kick)


@dataclass(frozen=True)
class ContinuationResult:
    """Where a continuation ended.

    Attributes
    ----------
    reached : bool
        True when the last step reached the real goal (s = 1) within tolerance.
    s : float
        The fraction of the line solved last (1.0 when `reached`).
    result : GaussNewtonResult or None
        Damped Newton's result on the last goal solved (None when no step succeeded).
    iterations : int
        Newton iterations over all steps.
    steps : int
        Continuation steps taken, successful or not (a kick counts as one).
    kicks : int
        Folds met: times the step reached its minimum and perturbations were tried.
    """

    reached: bool
    s: float
    result: GaussNewtonResult | None
    iterations: int
    steps: int
    kicks: int = 0


def follow_line(
    evaluate_for: Callable[[np.ndarray], Callable],
    z0: np.ndarray,
    start: np.ndarray,
    goal: np.ndarray,
    tolerance: float,
    *,
    rng: np.random.Generator,
    scale: float = 1.0,
    max_steps: int = MAX_STEPS,
    max_iterations: int = MAX_ITERATIONS,
) -> ContinuationResult:
    """Follow the goals `start + s (goal − start)` from s = 0 to s = 1.

    Parameters
    ----------
    evaluate_for : callable
        `evaluate_for(g)` returns the residual function `evaluate(z, jacobian)` of
        `damped_gauss_newton` for the (targeted) goal `g`.
    z0 : ndarray
        Free coefficients to start from (those of small controls, near s = 0).
    start, goal : ndarray
        The targeted coordinates at the leg's start and at its goal.
    tolerance : float
        The leg's tolerance (the real goal's); intermediate goals use `LOOSE` × it.
    rng : numpy.random.Generator
        The seeded stream of the perturbations tried at a fold.
    scale : float, optional
        Size of the leg's displacement; the perturbations are `KICKS` × it.
    max_steps : int, optional
        Continuation steps before giving up.
    max_iterations : int, optional
        Newton iterations over all steps before giving up.

    Returns
    -------
    ContinuationResult
        `reached` says whether the real goal was reached within `tolerance`.
    """
    start = np.asarray(start, dtype=float)
    goal = np.asarray(goal, dtype=float)
    z, s, step = np.asarray(z0, dtype=float), 0.0, FIRST_STEP
    best: GaussNewtonResult | None = None
    iterations = steps = kicks = 0

    def solve(target: float, z_from: np.ndarray) -> tuple[GaussNewtonResult, bool]:
        nonlocal iterations, steps
        steps += 1
        tol = tolerance if target >= 1.0 else LOOSE * tolerance
        result = damped_gauss_newton(
            evaluate_for(start + target * (goal - start)),
            z_from,
            tolerance=tol,
            max_iterations=min(STEP_ITERATIONS, max_iterations - iterations),
            mu=MU,
        )
        iterations += result.iterations
        return result, result.error <= tol

    while steps < max_steps and iterations < max_iterations:
        target = min(1.0, s + step)
        result, ok = solve(target, z)
        if not ok and step * 0.5 < MIN_STEP:  # a fold: jump to a nearby branch
            kicks += 1
            target = min(1.0, s + KICK_STEP)
            for size in KICKS:
                if steps >= max_steps or iterations >= max_iterations:
                    break
                result, ok = solve(target, z + rng.normal(0.0, size * scale, len(z)))
                if ok:
                    break
            step = KICK_STEP * 2.0  # halved below when the kicks failed too
        if ok:
            z, s, best = result.z, target, result
            if s >= 1.0:
                return ContinuationResult(True, 1.0, best, iterations, steps, kicks)
            if result.iterations <= EASY:
                step *= GROW
        else:
            step = max(step * 0.5, MIN_STEP)
    return ContinuationResult(False, s, best, iterations, steps, kicks)
