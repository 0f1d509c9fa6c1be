"""The one Levenberg–Marquardt loop with backtracking that Newton and the Lie-algebraic
method use (`damped_gauss_newton`), and what it watches for: a runaway search
(`SearchDiverged`), coordinates that fly off, coefficients that blow up.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..wording import counted

__all__ = [
    "COORDINATE_RUNAWAY",
    "ENERGY_RUNAWAY",
    "GaussNewtonResult",
    "SearchDiverged",
    "damped_gauss_newton",
    "no_divergence_check",
    "onto_goals",
    "runaway",
]

# A Newton search is abandoned as diverged when, after an accepted step that did not reach the
# goal, a coordinate of its end point is COORDINATE_RUNAWAY (rad, or the model's unit) farther
# from 0 than where the first evaluation ended (a start can begin far out and come back: one
# of Sim 3's hybrid starts ends at q3 = 185 and plans). Not 10 rad: correct plans of weak legs
# with free joints ("*") wind a distal joint 7-53 rad (the 4-link arm of issue 14 turning its
# base 10-40° on S12); a runaway search winds it by hundreds or thousands. A start of the
# energy search is abandoned when its energy is ENERGY_RUNAWAY times the first feasible one's.
COORDINATE_RUNAWAY = 100.0
ENERGY_RUNAWAY = 1e4


class SearchDiverged(Exception):
    """A search ran away: coordinate `coordinate` (0-based) `detail`; `stratified` ends the
    leg with `Status.DIVERGED`. Raised by `damped_gauss_newton` when the caller passes no
    `diverged` check of its own."""

    def __init__(self, coordinate: int, detail: str, iterations: int = 0):
        super().__init__(f"coordinate {coordinate + 1} {detail}")
        self.coordinate, self.detail, self.iterations = coordinate, detail, iterations


@dataclass(frozen=True)
class GaussNewtonResult:
    z: np.ndarray
    error: float
    iterations: int
    extra: object  # the last accepted evaluation's payload (e.g. coefficients and end point)
    diverged: str = ""  # why the search was abandoned as diverged ("" if it was not)


def runaway(payload: object, first: object) -> tuple[int, str] | None:
    """The built-in divergence check of a Newton payload `(λ, end point)` against the first
    evaluation's: (the coordinate that ran away, how far), or None (other payloads: never).

    Coordinates only: the first start's controls can be almost zero (a leg whose joints end
    where they start), so their growth says nothing; a planner that knows the leg's energy
    passes its own `diverged` check to `damped_gauss_newton`. (A goal 1000 rad off, which
    the search heads for, ends here too: allowed that far, such a leg ran 185 s of
    continuation and failed all the same.)"""
    pairs = (payload, first)
    if not all(isinstance(p, tuple) and len(p) == 2 for p in pairs):
        return None  # not a Newton payload: no built-in check
    end, end0 = (np.asarray(p[1], dtype=float) for p in pairs)
    if end.ndim != 1 or end.shape != end0.shape or not np.all(np.isfinite(end)):
        return None  # a non-finite end is the numerical-failure path's
    farther = np.abs(end) - np.abs(end0)  # a search coming back from a far start is fine
    k = int(np.argmax(farther)) if farther.size else 0
    if farther.size and farther[k] > COORDINATE_RUNAWAY:
        return k, (
            f"reached {end[k]:.4g}, {farther[k]:.3g} farther out than where the first start "
            f"ended (limit {COORDINATE_RUNAWAY:g})"
        )
    return None


def damped_gauss_newton(
    evaluate: Callable[[np.ndarray, bool], tuple[np.ndarray, np.ndarray | None, object]],
    z: np.ndarray,
    *,
    tolerance: float,
    max_iterations: int,
    mu: float,
    min_step: float = 1e-6,
    stall_window: int | None = None,
    stall_ratio: float = 0.5,
    diverged: Callable[[object], str | None] | None = None,
    jacobian_after: Callable[[], np.ndarray] | None = None,
    lazy: bool = False,
) -> GaussNewtonResult:
    """Drive the residual `e(z)` to zero: damped pseudo-inverse steps with backtracking.

    `evaluate(z, jacobian)` returns `(e, J, payload)` with `J = −∂e/∂z` (or None when not
    asked). Steps `Jᵀ(JJᵀ + μ tr(JJᵀ)/k · I)⁻¹ e` (Levenberg–Marquardt, paper eq. 20 and 24);
    a step is accepted only if it lowers |e| (halving down to `min_step`); μ falls after a
    full step and rises after a failure. It stops at `tolerance`, after `max_iterations`,
    when no damping makes progress, or, with `stall_window`, when |e| did not fall by
    `stall_ratio` over that many iterations (a fresh start is cheaper than crawling on).

    After every accepted step short of the tolerance, `diverged(payload)` says whether the
    search ran away (a reason) or not (None): the loop then stops with the reason in the
    result's `diverged`. Without `diverged`, the built-in check `runaway` (payloads
    ``(λ, end)`` only) raises `SearchDiverged` instead: the whole leg is abandoned.

    With `jacobian_after` (the Jacobian of the latest `evaluate`, added to it afterwards:
    an end-point map that keeps its last evaluation), the full step too is evaluated without
    its Jacobian, which is added only once the step is accepted short of the tolerance (the
    same numbers, without the Jacobians of rejected and of final steps).

    With `lazy` (maps whose value is much cheaper than the Jacobian and the same with or
    without it: quadrature legs and stacked problems), a full step after a refused one is
    evaluated without its Jacobian, which is asked for once the step is accepted: a search
    crawling on a curved residual refuses many full steps, each throwing a Jacobian away.
    Not for maps whose evaluation depends on what was asked before (Magnus legs choose their
    steps from the last error) or whose value and Jacobian come from different solves (the
    ODE path): the value and the Jacobian might then not match.
    """
    e, J, payload = evaluate(z, True)
    first = payload
    err = float(np.linalg.norm(e))
    iterations = 0
    history = [err]
    # the full step's Jacobian comes with its evaluation (usually accepted: little extra
    # cost), but with `lazy` not after a full step was refused
    eager = jacobian_after is None
    while err > tolerance and iterations < max_iterations:
        if stall_window and len(history) > stall_window:
            if err > stall_ratio * history[-stall_window - 1]:
                break
        iterations += 1
        A = J @ J.T
        damping = mu * max(float(np.trace(A)) / max(len(e), 1), 1e-300)
        try:
            step = J.T @ np.linalg.solve(A + damping * np.eye(len(e)), e)
        except np.linalg.LinAlgError:
            mu = max(mu * 100.0, 1e-8)
            continue
        gamma, accepted = 1.0, False
        while gamma > min_step:
            z_new = z + gamma * step
            e_new, J_new, payload_new = evaluate(z_new, gamma == 1.0 and eager)
            err_new = float(np.linalg.norm(e_new))
            if np.isfinite(err_new) and err_new < err:
                accepted = True
                break
            gamma *= 0.5
        eager = jacobian_after is None and (gamma == 1.0 or not lazy)
        if not accepted:
            mu *= 100.0
            if mu > 1e8:
                break  # stalled: no damping makes progress
            continue
        z, e, err, payload = z_new, e_new, err_new, payload_new
        if err > tolerance:
            if diverged is None:
                ran = runaway(payload, first)
                if ran:
                    detail = f"{ran[1]} after {counted(iterations, 'iteration')}"
                    raise SearchDiverged(ran[0], detail, iterations)
            elif reason := diverged(payload):
                return GaussNewtonResult(z, err, iterations, payload, reason)
            if J_new is None:
                later = jacobian_after is not None and gamma == 1.0
                J_new = jacobian_after() if later else evaluate(z, True)[1]
            J = J_new
        mu = max(mu / 10.0, 1e-12) if gamma == 1.0 else min(mu * 2.0, 1.0)
        history.append(err)
    return GaussNewtonResult(z, err, iterations, payload)


def onto_goals(evaluate, z: np.ndarray, tolerance: float, max_iterations: int):
    """`z` brought onto the goals by minimum-norm (in whitened coordinates: least-energy)
    Gauss-Newton steps, or None if they do not get within `tolerance`.

    `evaluate(z, jacobian)` gives the goal residuals c(z) and, if asked, their Jacobian."""

    def residual(x, jacobian):
        c, J = evaluate(x, jacobian)
        return -c, J, None

    back = damped_gauss_newton(
        residual,
        z,
        tolerance=tolerance,
        max_iterations=max_iterations,
        mu=1e-2,
        diverged=no_divergence_check,
        lazy=True,  # (stacked problems: a Jacobian after the value is the same march's)
    )
    return back.z if back.error <= tolerance and np.all(np.isfinite(back.z)) else None


def no_divergence_check(payload) -> None:
    """For searches whose payloads carry nothing to check for runaway."""
    return None
