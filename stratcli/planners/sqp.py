"""The feasible-point SQP of the energy objective, one start at a time (`Descent`).

Every iterate reaches the goals (restored by Newton steps of least energy norm); a step
minimises the quadratic model of the Lagrangian on the constraints' tangent space, with the
exact Hessian where the legs' end-point maps have one (else the goals' curvature estimated by
symmetric-rank-one updates: URDF and ODE-path legs), and is halved until the restored point
has less energy. `planners.energy` races several `Descent`s; the constrained search
(`planners.constrained`) extends one with its margins.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .stacked import StackedProblem

__all__ = ["CURVATURE_FLOOR", "MINIMUM", "RANK_RTOL", "STEP_LIMIT", "Descent"]

SQP_ITERATIONS = 100
FIRST_ORDER_ITERATIONS = 40  # without exact second derivatives (ODE-path legs, URDF robots)
PG_TOL = 1e-10  # relative projected gradient at convergence (the issue asks ≤ 1e-8)
CURVATURE_FLOOR = 1e-2  # reduced Hessian ≥ this x the energy's own, on the tangent space
RESTORATION_STEPS = 12
# far from a minimum (projected gradient above LOOSE_ABOVE) iterates meet the goals to
# LOOSE_RESTORATION only; nearer, and every result, to rounding (`Descent.c_tol`)
LOOSE_RESTORATION, LOOSE_ABOVE = 1e-6, 1e-3
# ... and while they do, maps that can (URDF legs: fewer Magnus steps) evaluate to this
# accuracy (rad) instead of their own 5e-10: 1% of the loose restoration tolerance
LOOSE_ACCURACY = 1e-2 * LOOSE_RESTORATION
STEP_LIMIT = 0.5  # energy-norm step ≤ this x the current controls' energy norm
KEPT = ("converged", "noise floor", "line search", "iteration limit")  # stops that give results
MINIMUM = ("converged", "noise floor")  # stops at a minimum (the others stop on the way down)
# singular values of the goals' Jacobian below this x its largest are rounding (zero): its
# rank; the right singular vectors beyond it span the goals' tangent space (Z)
RANK_RTOL = 1e-12
SR1_SKIP = 1e-8  # `_curvature`: an update whose denominator is below this (relative) is skipped
STALL_ITERATIONS = 5  # near the solution: stop when the gradient no longer halves


def _least_norm(J: np.ndarray):
    """`c -> J⁺ c`, the least-energy-norm step that cancels the residuals `c` to first order
    (H0 = 2 I: the energy is |z|² in the whitened z), or None where it cannot be made.

    Of full row rank (the rule of `Descent._step`): `H0⁻¹ Jᵀ (J H0⁻¹ Jᵀ)⁻¹ c` by Cholesky, as
    always. Else on the rows' range only (truncated SVD): goals that the leg's stratum cannot
    move at all there (arm3's S1 at j1 = 0 turns the base about y only, its rx and rz rows
    are zero to rounding) are met or not whatever the step, and inverting their rounding-level
    rows threw trial points to |λ| ~ 1e8 (Magnus steps at their cap) without ever restoring
    them: 40 SQP iterations of 2-4 s each, then no result."""
    if not np.all(np.isfinite(J)):  # an overflowed trial point: the line search shortens
        return None
    try:
        S = np.linalg.svd(J, compute_uv=False)
    except np.linalg.LinAlgError:
        return None
    rank = int(np.sum(S > RANK_RTOL * max(S[0], 1e-300))) if S.size else 0
    if rank == J.shape[0]:
        HJ = 0.5 * J.T  # H0⁻¹ Jᵀ
        try:
            L = np.linalg.cholesky(J @ HJ)
        except np.linalg.LinAlgError:
            return None
        return lambda c: HJ @ np.linalg.solve(L.T, np.linalg.solve(L, c))
    if rank == 0:
        return None
    try:
        U, S, Vt = np.linalg.svd(J, full_matrices=False)
    except np.linalg.LinAlgError:
        return None
    U, S, V = U[:, :rank], S[:rank], Vt[:rank].T
    return lambda c: V @ ((U.T @ c) / S)


class Descent:
    """One start of the feasible-point SQP with the exact Hessian of the Lagrangian, advanced
    one iteration at a time (so that starts can be raced).

    Every iterate reaches the goals (restored by Newton steps of least energy norm); a step
    minimises the quadratic model of the Lagrangian on the constraints' tangent space, and is
    halved until the restored point has less energy. Near a regular minimum the steps are
    Newton steps of the reduced problem: a handful of iterations, each a few endpoint calls.
    """

    loose = True  # restore loosely far from a minimum (`_step`)

    def __init__(self, problem: StackedProblem, z: np.ndarray, tol: float, pg_tol: float = PG_TOL):
        clock = time.perf_counter()
        self.problem = problem
        self.pg_tol = pg_tol  # relative projected gradient at which it has converged
        self.H0 = problem.H0
        self.exact = problem.exact_hessians  # ODE-path legs: no second derivatives
        self.c_tol = min(1e-10, 1e-3 * tol)
        # restoration tolerance of the current iteration (loose only for this class's own
        # steps, `_step`; subclasses that take other steps restore to rounding throughout)
        self.c_now = LOOSE_RESTORATION if self.loose else self.c_tol
        self.z_tol = self.c_now  # ... and the one the current iterate was restored to
        # maps that keep their last evaluation add the Jacobian later at no extra march
        self.eager = not all(hasattr(ep, "jacobian_of_last") for ep in problem.endpoints)
        self.iterations = 0
        self.best_pg, self.since = np.inf, 0
        self.pg, self.pg_at = np.nan, None  # the last projected gradient and its point
        self.model_low = None  # the last full Newton step's model minimum (`_step`)
        self.curvature, self.last = None, None  # `_curvature`: without exact Hessians
        start = self._restore(z)
        self.feasible = start is not None
        self.z = z if start is None else start
        self.energy = problem.energy(self.z) if self.feasible else np.inf
        self.done = not self.feasible
        self.reason = "" if self.feasible else "not restored onto the goals"
        self.seconds = time.perf_counter() - clock

    def stop(self, reason: str) -> None:
        self.done, self.reason = True, reason
        if self.feasible and self.z_tol > self.c_tol and reason in KEPT:
            self.c_now = self.z_tol = self.c_tol  # a result: onto the goals to rounding
            z = self._restore(self.z)
            if z is None:
                self.reason = "not restored onto the goals"
            else:
                self.z, self.energy = z, self.problem.energy(z)

    def _restore(self, z, simplified: bool = False):
        """Back onto the goals: Newton steps of least energy norm, quadratically convergent.

        `simplified`: every step after the first reuses the first one's Jacobian while the
        steps at least halve the violation, then Newton steps again (without exact Hessians:
        a URDF leg's Jacobian costs a Pinocchio derivative per node, and the corrections
        after the first are small). The first step is Newton's own either way."""
        problem, previous = self.problem, np.inf
        self._accuracy(self.c_now)
        kept = None  # (H0⁻¹ Jᵀ, Cholesky factor of J H0⁻¹ Jᵀ) reused by a simplified step
        for _ in range(RESTORATION_STEPS):
            c, J = problem._evaluate(z, self.eager and kept is None)
            violation = np.abs(c).max(initial=0.0)
            if violation <= self.c_now:
                return z
            if violation > 0.5 * previous:
                if kept is None:
                    return None  # not converging fast: let the line search shorten the step
                kept = None  # the kept Jacobian is too far off: Newton steps from here
                simplified = False
            previous = violation
            if kept is not None:
                correct = kept
            else:
                if J is None:
                    J = problem._evaluate(z, True)[1]
                correct = _least_norm(J)
                if correct is None:
                    return None
                if simplified:
                    kept = correct
            z = z - correct(c)
            if not np.all(np.isfinite(z)):
                return None
        return None

    def goal_curvature(self, z: np.ndarray, J: np.ndarray, mu: np.ndarray) -> np.ndarray:
        """`Σ_j μ_j ∇²c_j(z)`, the goals' part of the Lagrangian's Hessian: exact where the
        legs' end-point maps have second derivatives, else estimated (`_curvature`); `J` is
        the goals' Jacobian at z."""
        if self.exact:
            return self.problem.constraint_hessian(z, mu)
        return self._curvature(z, J, mu)

    def _accuracy(self, tol: float) -> None:
        """Loose restoration, loose maps (`LOOSE_ACCURACY`); else the maps' own accuracy."""
        self.problem.set_accuracy(LOOSE_ACCURACY if tol >= LOOSE_RESTORATION else None)

    def _curvature(self, z: np.ndarray, J: np.ndarray, mu: np.ndarray) -> np.ndarray:
        """`Σ_j μ_j ∇²c_j` estimated without second derivatives: symmetric-rank-one updates
        from the change of `Jᵀμ` between iterates (the energy's own Hessian H0 is exact)."""
        if self.curvature is None:
            self.curvature = np.zeros((z.size, z.size))
        if self.last is not None:
            s = z - self.last[0]
            r = (J - self.last[1]).T @ mu - self.curvature @ s
            sr = float(s @ r)
            if abs(sr) > SR1_SKIP * np.linalg.norm(s) * np.linalg.norm(r):
                self.curvature += np.outer(r, r) / sr
        self.last = (z.copy(), J.copy())
        return self.curvature

    def step(self) -> None:
        clock = time.perf_counter()
        try:
            self._step()
        finally:
            self.seconds += time.perf_counter() - clock

    def _step(self) -> None:
        problem, H0, z, energy = self.problem, self.H0, self.z, self.energy
        if self.iterations >= (SQP_ITERATIONS if self.exact else FIRST_ORDER_ITERATIONS):
            return self.stop("iteration limit")
        self.iterations += 1
        self._accuracy(self.z_tol)  # the iterate's Jacobian on the maps it was restored on
        _, J = problem._evaluate(z, True)
        g = problem.energy_grad(z)
        U, S, Vt = np.linalg.svd(J)
        rank = int(np.sum(S > RANK_RTOL * max(S[0], 1e-300))) if S.size else 0
        Z = Vt[rank:].T
        reduced = Z.T @ g
        pg = np.linalg.norm(reduced) / max(np.linalg.norm(g), 1e-300)
        self.pg, self.pg_at = float(pg), z  # the record's, if the run ends here
        # Far from a minimum the iterates need not meet the goals to rounding (the Lagrangian
        # merit sees a violation to first order only); near one they must, or the decrease
        # left drowns in it: the iterate itself is then restored again first.
        self.c_now = LOOSE_RESTORATION if self.loose and pg > LOOSE_ABOVE else self.c_tol
        if self.c_now < self.z_tol:
            self.z_tol = self.c_now
            tight = self._restore(z)
            if tight is not None:
                self.z, self.energy = tight, problem.energy(tight)
                self.iterations -= 1
                return self._step()
        if pg <= self.pg_tol:
            return self.stop("converged")
        if pg < 0.5 * self.best_pg:
            self.best_pg, self.since = pg, 0
        else:
            self.since += 1
            if pg <= 1e-6 and self.since >= STALL_ITERATIONS:
                return self.stop("noise floor")  # the end-point map allows no further progress

        # least-squares multipliers Jᵀμ = -g from the same decomposition
        mu = -(U[:, :rank] / S[:rank]) @ (Vt[:rank] @ g)
        W = H0 + self.goal_curvature(z, J, mu)
        R = Z.T @ W @ Z
        R0 = Z.T @ H0 @ Z
        # R0 = Zᵀ H0 Z = 2 I (Z orthonormal): the generalised eigenproblem is R's own, halved
        low = float(np.linalg.eigvalsh(R)[0]) / 2.0 if R.size else np.inf
        convex = low >= CURVATURE_FLOOR
        if not convex:  # convexify in the energy metric (the basis is ill-scaled)
            R = R + (CURVATURE_FLOOR - low) * R0
        d = -Z @ np.linalg.solve(R, reduced)
        # Trust region in the energy norm: a step may change the controls by at most
        # STEP_LIMIT times their current size (a huge step needs a huge quadrature rule
        # and cannot be restored onto the goals anyway).
        size = float(np.sqrt(max(d @ H0 @ d, 0.0)))
        limit = STEP_LIMIT * np.sqrt(max(energy, 1e-300))
        if size > limit:
            d *= limit / size
        slope = float(g @ d)
        # where the reduced model is exact, convex and its Newton step within the trust region,
        # the model's minimum is energy + slope / 2 (the race drops a start converging far
        # above the best: `energy.race`; not on estimated curvature, a few updates old)
        trusted = self.exact and convex and size <= limit
        self.model_low = energy + 0.5 * slope if trusted else None
        if -slope <= 1e-16 * max(energy, 1e-300):
            return self.stop("converged")  # no decrease predicted above rounding
        near = np.linalg.norm(reduced) <= 1e-6 * np.linalg.norm(g)
        # Merit: the Lagrangian f + μᵀc, not f alone. Restored points meet the goals only to
        # the restoration tolerance, which moves f by about |μ| x that tolerance: more than
        # the decrease left near the solution. In the Lagrangian that first-order effect
        # cancels, so the line search still sees progress there.
        merit = energy + float(mu @ problem.constraint(z))
        alpha = 1.0
        while alpha > 1e-10:
            trial = self._restore(z + alpha * d, simplified=not self.exact)
            if trial is not None:
                e = problem.energy(trial)
                m = e + float(mu @ problem.constraint(trial))
                # close to the solution a full Newton step is trusted up to rounding
                allowed = 1e-12 * energy if near else 1e-4 * alpha * slope + 1e-15 * energy
                if m <= merit + allowed:
                    self.z, self.energy, self.z_tol = trial, e, self.c_now
                    return None
            alpha *= 0.5
        return self.stop("line search")
