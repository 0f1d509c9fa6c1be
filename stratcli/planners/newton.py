"""Newton leg planner (paper §4.1, eq. 20) made robust.

`λ ← λ + γ J#(q_goal − k(λ))` on the targeted coordinates of the stratum, in the free
coefficients `z` left by the boundary conditions (eq. 28). Robustness:

* damped pseudo-inverse `Jᵀ(JJᵀ + μI)⁻¹` (Levenberg–Marquardt), μ adapted to progress;
* backtracking on γ: a step is accepted only if the error decreases, so it never grows;
* start from constant controls that move the explicit coordinates (the joints) straight to
  their goal, plus a small seeded perturbation: at λ = 0 the θ row of J is a combination of
  the joint rows, so a least-squares step would ignore θ (DESIGN §4);
* deterministic restarts with larger seeded perturbations when an attempt stalls.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..continuity import Elimination
from ..endpoint import _Endpoint

DAMPING = (1e-2, 1e-4, 1e-10)  # initial relative damping, cycled over attempts
STALL_WINDOW = 10  # iterations over which the error must fall ...
STALL_RATIO = 0.5  # ... at least by this factor, or the attempt restarts


@dataclass(frozen=True)
class NewtonSettings:
    tolerance: float = 1e-3
    max_iterations: int = 100
    restarts: int = 11
    seed: int = 0
    spread: float = 0.02  # relative size of the seeded perturbation of the first start


@dataclass
class LegSolution:
    """Outcome of one leg: coefficients (m_active, 2H+1), reached end point, error."""

    coefficients: np.ndarray
    end: np.ndarray
    error: float
    iterations: int
    attempts: int
    converged: bool


def _initial_coefficients(endpoint: _Endpoint, goal: np.ndarray, targets: np.ndarray) -> np.ndarray:
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


def plan_leg(
    endpoint: _Endpoint,
    goal: np.ndarray,
    targets: np.ndarray,
    elimination: Elimination,
    settings: NewtonSettings,
    stream: int = 0,
    initial: np.ndarray | None = None,
) -> LegSolution:
    """Steer `endpoint.q0` to `goal` on the coordinates `targets`; deterministic per `stream`.

    `initial` (flat coefficients) replaces the first start, e.g. to polish a solution found by
    another method; it is projected onto the boundary conditions first.
    """
    goal = np.asarray(goal, dtype=float)
    z_line = elimination.project(_initial_coefficients(endpoint, goal, targets))
    scale = 1.0 + float(np.abs(goal[targets] - endpoint.q0[targets]).max(initial=0.0))
    best: LegSolution | None = None
    total = 0
    for attempt in range(settings.restarts + 1):
        rng = np.random.default_rng([settings.seed, stream, attempt])
        cycle, mu0 = divmod(attempt, len(DAMPING))
        spread = (settings.spread if cycle == 0 else 0.25 * cycle) * scale
        z0 = z_line + rng.normal(0.0, spread, elimination.free)
        if attempt == 0 and initial is not None:
            z0 = elimination.project(np.asarray(initial, dtype=float))
        solution = _newton(endpoint, goal, targets, elimination, z0, settings, DAMPING[mu0])
        total += solution.iterations
        if best is None or solution.error < best.error:
            best = solution
        if solution.converged:
            break
    best.iterations = total
    best.attempts = attempt + 1
    return best


def _newton(endpoint, goal, targets, elimination, z, settings, mu) -> LegSolution:
    N = elimination.null

    def evaluate(z, jacobian):
        lam = elimination.coefficients(z)
        end, J = endpoint(lam, jacobian)
        return lam, end, J, goal[targets] - end[targets]

    lam, end, J, e = evaluate(z, True)
    err = float(np.linalg.norm(e))
    iterations = 0
    history = [err]
    while err > settings.tolerance and iterations < settings.max_iterations:
        if len(history) > STALL_WINDOW and err > STALL_RATIO * history[-STALL_WINDOW - 1]:
            break  # stalled: a fresh start is cheaper than crawling on
        iterations += 1
        Jz = J[targets] @ N
        A = Jz @ Jz.T
        damping = mu * max(float(np.trace(A)) / len(targets), 1e-300)
        try:
            step = Jz.T @ np.linalg.solve(A + damping * np.eye(len(targets)), e)
        except np.linalg.LinAlgError:
            mu = max(mu * 100.0, 1e-8)
            continue
        gamma, accepted = 1.0, False
        while gamma > 1e-6:  # backtracking: accept only a step that lowers the error
            z_new = z + gamma * step
            # the full step is usually accepted: its Jacobian comes with it at little cost
            lam_new, end_new, J_new, e_new = evaluate(z_new, gamma == 1.0)
            err_new = float(np.linalg.norm(e_new))
            if np.isfinite(err_new) and err_new < err:
                accepted = True
                break
            gamma *= 0.5
        if not accepted:
            mu *= 100.0
            if mu > 1e8:
                break  # stalled: no damping makes progress
            continue
        z, lam, end, e, err = z_new, lam_new, end_new, e_new, err_new
        if err > settings.tolerance:
            J = J_new if J_new is not None else endpoint(lam, True)[1]
        mu = max(mu / 10.0, 1e-12) if gamma == 1.0 else min(mu * 2.0, 1.0)
        history.append(err)
    L = lam.reshape(endpoint.m, endpoint.size)
    return LegSolution(L, end, err, iterations, 1, err <= settings.tolerance)
