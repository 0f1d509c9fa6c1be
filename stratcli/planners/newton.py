"""Newton leg planner (paper §4.1, eq. 20) made robust.

`λ ← λ + γ J#(q_goal − k(λ))` on the targeted coordinates of the stratum, in the free
coefficients `z` left by the boundary conditions (eq. 28). Robustness:

* damped pseudo-inverse `Jᵀ(JJᵀ + μI)⁻¹` (Levenberg–Marquardt), μ adapted to progress;
* backtracking on γ: a step is accepted only if the error decreases, so it never grows;
* start from constant controls that move the explicit coordinates (the joints) straight to
  their goal, plus a small seeded perturbation: at λ = 0 the θ row of J is a combination of
  the joint rows, so a least-squares step would ignore θ;
* after two attempts stalled, a short continuation (`continuation.py`: intermediate goals
  along the straight line from the start to the goal, each solved from the previous
  solution; at most `EARLY_STEPS` steps and three attempts' iterations): where the line is
  easy it reaches the goal in a few steps, where blind restarts took up to ten more
  attempts and found plans of many times the energy (Sim 4 task A's Newton plan: 644
  instead of 8540 after six attempts on its second leg; of 77 random tasks' Newton plans 15
  are lower, one 1.6 % higher, and 6 of their energy-objective plans lower, up to 50x; with
  16 steps and one attempt's iterations 5 of those gained);
* then deterministic restarts with larger seeded perturbations, and when every attempt
  failed, the whole continuation (with its kicks at folds). The outcome's `strategy` says
  which reached the goal. The energy objective's extra seeded
  starts (a planner with its own `seed`) skip it: they are meant to be cheap, and a start
  that needs it is dropped as before. A URDF leg whose stratum's fields and brackets at its
  start leave a direction of its goal unspanned (`reachability.out_of_reach`) fails with that
  reason instead: the continuation could not reach it either.
"""

from __future__ import annotations

import numpy as np

from ..reachability import out_of_reach
from ..results import Piece
from ..settings import PlannerSettings
from ..status import Status
from ..wording import counted
from .base import LegOutcome, LegPlanner, LegProblem, damped_gauss_newton, goal_residual
from .continuation import MAX_STEPS, follow_line

__all__ = ["NewtonPlanner"]

DAMPING = (1e-2, 1e-4, 1e-10)  # initial relative damping, cycled over attempts
STALL_WINDOW = 10  # iterations over which the error must fall ...
STALL_RATIO = 0.5  # ... at least by this factor, or the attempt restarts
_DEFAULTS = PlannerSettings()  # the one place defaults live
BROKEN_STARTS = 3  # attempts whose very start cannot be evaluated before the leg gives up
CONTINUATION_BUDGET = 2.5  # continuation iterations, × Newton's own (attempts × iterations)
EARLY_CONTINUATION = 2  # failed attempts after which a short continuation comes before more
EARLY_STEPS = 32  # its steps (a fold's kick counts as one) ...
EARLY_BUDGET = 3  # ... and its iterations, x one attempt's


def _initial_coefficients(endpoint, goal: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Constant controls that drive the targeted explicit coordinates straight to the goal."""
    cs = endpoint.cs
    L = np.zeros((endpoint.m, endpoint.size))
    rows = [r for r, i in enumerate(cs.explicit) if i in set(targets.tolist())]
    if rows:
        E = np.array(cs.explicit)[rows]
        C = cs.C_explicit[rows]
        delta = goal[E] - endpoint.q0[E]
        L[:, 0] = np.linalg.lstsq(C, delta / endpoint.duration, rcond=None)[0]
    return L.ravel()


def _rank(error: float) -> float:
    """Errors compared with NaN (an end point that could not be computed) as the worst."""
    return error if np.isfinite(error) else np.inf


class NewtonPlanner(LegPlanner):
    """Damped Newton from deterministic seeded starts (the paper's method, made robust).

    Parameters
    ----------
    max_iterations : int
        Newton iterations per attempt.
    restarts : int
        Extra attempts after the first, each from a wider seeded perturbation.
    spread : float
        Relative size of the first attempt's perturbation.
    seed : int or None
        Overrides the problem's seed (the energy objective's extra starts).
    continuation : bool or None
        Follow a homotopy, a short one after two stalled attempts and a whole one when every
        attempt failed; default: unless `seed` is given (the energy objective's extra starts
        stay cheap and behave as before).
    budget : int or None
        Newton iterations allowed over all attempts of a leg (the energy objective's extra
        starts: a seed that needs more is dropped); default: no limit.
    """

    method = "newton"
    joint_optimisation = True

    @classmethod
    def from_settings(cls, settings, leg, **overrides) -> NewtonPlanner:
        options = {"max_iterations": settings.max_iterations, "restarts": settings.restarts}
        return cls(**(options | overrides))

    def __init__(
        self,
        max_iterations: int = _DEFAULTS.max_iterations,
        restarts: int = _DEFAULTS.restarts,
        spread: float = 0.02,
        seed: int | None = None,
        continuation: bool | None = None,
        budget: int | None = None,
    ):
        self.max_iterations = max_iterations
        self.budget = budget
        self.restarts = restarts
        self.spread = spread
        self.seed = seed
        self.continuation = seed is None if continuation is None else continuation

    def missing_coefficients(self, problem: LegProblem) -> tuple[int, int]:
        return problem.elimination().free, len(problem.targets)

    def plan(self, problem: LegProblem) -> LegOutcome:
        """Steer the leg with restarts; deterministic per (seed, leg index, attempt)."""
        endpoint = problem.endpoint()
        elimination = problem.elimination()
        goal = np.asarray(problem.goal, dtype=float)
        targets = np.array(problem.targets, dtype=int)
        N = elimination.null
        seed = problem.seed if self.seed is None else self.seed

        def evaluate_for(aim):
            def evaluate(z, jacobian):
                lam = elimination.coefficients(z)
                end, J = endpoint(lam, jacobian)
                r, Jt = goal_residual(endpoint, end, J, aim, targets)
                return -r, (None if Jt is None else Jt @ N), (lam, end)

            return evaluate

        evaluate = evaluate_for(goal[targets])
        jacobian_after = None
        if hasattr(endpoint, "jacobian_of_last"):  # the Jacobian only of steps kept (magnus)
            last = []  # the latest evaluation's λ
            plain = evaluate

            def evaluate(z, jacobian):
                out = plain(z, jacobian)
                last[:] = [out[2][0]]
                return out

            def jacobian_after():
                end, J = endpoint.jacobian_of_last(last[0])
                return goal_residual(endpoint, end, J, goal[targets], targets)[1] @ N

        z_line = elimination.project(_initial_coefficients(endpoint, goal, targets))
        scale = 1.0 + float(np.abs(goal[targets] - endpoint.q0[targets]).max(initial=0.0))
        best = None
        total = 0
        broken = 0
        strategy, message = "newton", ""
        # The homotopy solves many legs' worth of Newton problems: affordable with the
        # quadrature end point (all space manipulators), not on the general ODE path, where
        # one call can cost 10⁴ evaluations (a custom model would then run for minutes).
        cheap = endpoint.kind in ("quadrature", "magnus")
        reach: list[str | None] = []  # why no continuation can reach the goal, once asked

        def follow(budget: int, steps: int = MAX_STEPS):
            """The continuation from small controls (the feasible ones closest to zero) within
            `budget` iterations and `steps` steps, or None where it cannot apply; `message`
            says why a URDF leg is out of reach."""
            nonlocal message
            if not reach:  # asked once (URDF legs: the brackets at the leg's start)
                reach.append(
                    out_of_reach(
                        problem.system, problem.stratum.name, problem.start, goal, problem.tolerance
                    )
                )
            message = reach[0] or ""
            if not cheap or reach[0] is not None:
                return None
            return follow_line(
                evaluate_for,
                elimination.project(np.zeros_like(elimination.particular)),
                endpoint.q0[targets],
                goal[targets],
                problem.tolerance,
                rng=np.random.default_rng([seed, problem.index, self.restarts + 1]),
                scale=scale,
                max_steps=steps,
                max_iterations=budget,
            )

        def followed_to(path) -> bool:
            nonlocal best, strategy, message, total
            if path is None:
                return False
            total += path.iterations
            if path.reached:
                best, strategy, message = path.result, "continuation", ""
                return True
            message = (
                f"the last {counted(path.iterations, 'iteration')} were a continuation "
                "along the line to the goal, which did not reach it either"
            )
            return False

        for attempt in range(self.restarts + 1):
            rng = np.random.default_rng([seed, problem.index, attempt])
            cycle, mu0 = divmod(attempt, len(DAMPING))
            spread = (self.spread if cycle == 0 else 0.25 * cycle) * scale
            z0 = z_line + rng.normal(0.0, spread, elimination.free)
            if attempt == 0 and problem.initial is not None:
                z0 = elimination.project(np.asarray(problem.initial, dtype=float))
            left = self.max_iterations if self.budget is None else self.budget - total
            result = damped_gauss_newton(
                evaluate,
                z0,
                tolerance=problem.tolerance,
                max_iterations=min(self.max_iterations, left),
                mu=DAMPING[mu0],
                stall_window=STALL_WINDOW,
                stall_ratio=STALL_RATIO,
                jacobian_after=jacobian_after,
                lazy=endpoint.kind == "quadrature",
            )
            total += result.iterations
            if best is None or _rank(result.error) < _rank(best.error):
                best = result
            if result.error <= problem.tolerance:
                break
            broken = broken + 1 if not np.isfinite(result.error) else 0
            if broken >= BROKEN_STARTS:
                break  # the model cannot even be evaluated here: more starts will not help
            if self.budget is not None and total >= self.budget:
                break  # the iterations allowed are spent: a seed this costly is dropped
            if attempt + 1 == EARLY_CONTINUATION and self.continuation and np.isfinite(best.error):
                # two attempts stalled: a short continuation before blind restarts (an easy
                # one takes 4 steps and 20-30 iterations; one that must jump many folds is
                # left for after the restarts, which are cheaper then)
                if followed_to(follow(EARLY_BUDGET * self.max_iterations, EARLY_STEPS)):
                    break
        if best.error > problem.tolerance and np.isfinite(best.error) and self.continuation:
            budget = CONTINUATION_BUDGET * (self.restarts + 1) * self.max_iterations
            followed_to(follow(int(budget)))  # the whole continuation, kicks and all
        lam, end = best.extra
        error = best.error
        refined = getattr(endpoint, "refined", None)  # a map that evaluates coarsely far away
        if refined is not None and np.all(np.isfinite(end)):
            end = refined(lam)
            r, _ = goal_residual(endpoint, end, None, goal[targets], targets)
            error = float(np.linalg.norm(r))
        ok = error <= problem.tolerance
        return LegOutcome(
            pieces=(Piece(0.0, problem.duration, lam.reshape(endpoint.m, endpoint.size)),),
            end=np.array(end, dtype=float),
            error=error,
            iterations=total,
            attempts=attempt + 1,
            status=Status.SUCCESS if ok else Status.NOT_CONVERGED,
            free_coefficients=elimination.free,
            evaluator=endpoint.kind,
            message="" if ok else message,
            strategy=strategy,
        )
