"""Lie-algebraic leg planner (paper §4.2, eq. 21-24): small local steps, one piece each.

At the current configuration `q` of the leg:

1. desired step `δq = γ (q_goal − q)` on the coordinates the leg targets;
2. the fields of the stratum's Philip Hall basis at `q`, `B(q)` (generators and brackets up
   to `degree`), and the iterated integrals `α = h(λ)` of one step of controls (eq. 23);
3. controls of one step of length `step_duration` with `Σ_h α_h(λ) B_h(q) = δq` (eq. 22),
   solved by Newton's method (eq. 24) in the coefficients left free by the boundary conditions
   of the step; among the solutions, the one of least energy `∫|u|²` (Newton's method on the
   optimality conditions, with the exact second derivatives of `h`);
4. apply the step to the true system (the leg's end-point evaluator) and repeat.

How `α` is chosen (`lie.alpha`): "energy" (default) solves eq. 22 and 23 together as above.
"pinv" is the paper's two stages: `α_d = B(q)# δq` (minimum-norm), then `h(λ) = α_d`. The
two are the same when the basis has as many fields as the leg has targets (two inputs,
degree 2: the paper's models); with more fields (degree 3, or three inputs) the minimum-norm
`α_d` asks for third-order brackets that are expensive to make, and "energy" lets the
cheapest combination do the step (Sim 3's Lie leg, degree 3: energy 1.56 instead of 946
with "pinv"; not always: a base turn on S3 cost 1816 with "energy", 333 with "pinv").

Every step is one piece of the leg, with local time `[0, step_duration]`. Its boundary
conditions are those of a leg (`continuity.leg_constraints`): the first piece continues the
previous leg's controls, each next piece the previous piece's (C0/C1 as the mode says), and
*every* piece satisfies the leg's end conditions (inputs the next leg does not use end at 0
under lr-modes; full stop), so the leg may end after any step. With `lie.rest` (default) every
step also ends at rest, `u = u' = 0`: each step is a self-contained small loop, and the next
one starts from rest (the joints are trivially C1). Without it, a step that minimises only
its own energy may hand large end velocities to the next step, whose local model then fails
(Sim 3's Lie leg: energies of 10²–10³ instead of 1.7). A step whose true result does not
lower the error is retried with half the `γ`; after `STALL_STEPS` steps without progress the
leg gives up.
"""

from __future__ import annotations

import numpy as np

from ..controls import end_controls
from ..iterated import iterated_integrals
from ..liealgebra import hall_basis, lie_basis
from ..results import Piece
from ..settings import LieSettings
from ..status import Status
from .base import LegOutcome, LegPlanner, LegProblem, damped_gauss_newton

__all__ = ["LiePlanner"]

RETRIES = 6  # halvings of γ per step when the true step does not lower the error
STARTS = 3  # seeded starts of the eq.-24 Newton method per step, until one finds a solution
RCOND = 1e-10  # directions of eq. 22 weaker than this (relative) are not asked for
STALL_STEPS = 3  # consecutive steps without progress before the leg gives up
# `_StepSolver.cheapest` stops where a relative step below this no longer halves the last
ROUNDING_STEP = 1e-6


class _StepSolver:
    """`F(z) = Bt h(λp + N z) − target = 0` for one step, of least energy.

    Damped Newton (eq. 24, Levenberg–Marquardt, minimum-norm increments) to a solution from a
    seeded start (more starts only if it fails), then Newton's method on the optimality
    conditions of `min E(z)` s.t. `F(z) = 0` (exact Hessians: `h` is a polynomial of degree
    ≤ 3), accepted only when it lowers the energy and stays a solution.
    """

    def __init__(self, hI, elim, M, Bt, target):
        self.hI, self.elim, self.N, self.Bt = hI, elim, elim.null, np.asarray(Bt, dtype=float)
        self.target = np.asarray(target, dtype=float)
        self.H = self.N.T @ M @ self.N
        self.g = self.N.T @ M @ elim.particular
        self.c = float(elim.particular @ M @ elim.particular)
        self.tol = 1e-12 * (1.0 + float(np.abs(self.target).max(initial=0.0)))
        self.iterations = 0

    def energy(self, z):
        return float(z @ self.H @ z + 2.0 * self.g @ z + self.c)

    def residual(self, z):
        """`target − F`, and the Jacobian of F in z."""
        val, jac = self.hI.evaluate(self.elim.coefficients(z))
        return self.target - self.Bt @ val, self.Bt @ jac @ self.N

    def feasible(self, z, max_iter=60, mu=1e-3):
        """A solution of `F(z) = target` near `z` (damped Gauss–Newton, eq. 24)."""

        def evaluate(z, _jacobian):
            r, Jz = self.residual(z)
            return r, Jz, None

        result = damped_gauss_newton(
            evaluate, z, tolerance=self.tol, max_iterations=max_iter, mu=mu, min_step=1e-4
        )
        self.iterations += result.iterations
        return result.z, result.error

    def cheapest(self, z, max_iter=30):
        """Newton's method on the KKT conditions from a solution `z`."""
        E0 = self.energy(z)
        start = z
        N, k = self.N, len(self.target)
        r, Jz = self.residual(z)
        grad = 2.0 * (self.H @ z + self.g)
        nu = np.linalg.lstsq(Jz.T, grad, rcond=None)[0]
        last = np.inf  # the last relative step
        for _ in range(max_iter):
            self.iterations += 1
            lam = self.elim.coefficients(z)
            w = self.Bt.T @ nu
            HL = 2.0 * self.H - N.T @ self.hI.hessian(lam, w) @ N
            K = np.block([[HL, -Jz.T], [Jz, np.zeros((k, k))]])
            rhs = np.concatenate([-(grad - Jz.T @ nu), r])
            try:
                d = np.linalg.solve(K, rhs)
            except np.linalg.LinAlgError:
                break
            z = z + d[: len(z)]
            nu = nu + d[len(z) :]
            r, Jz = self.residual(z)
            grad = 2.0 * (self.H @ z + self.g)
            if not np.all(np.isfinite(z)):
                break
            step = float(np.linalg.norm(d[: len(z)])) / (1.0 + float(np.linalg.norm(z)))
            if step <= 1e-10 and float(np.linalg.norm(r)) <= self.tol:
                break
            if step <= ROUNDING_STEP and step > 0.5 * last:  # no longer contracting: rounding
                break  # (the steps stall at 1e-8 relative after 8-10 quadratic ones: Sim 3's
            last = step  # steps ran all 30 iterations, a third of its plan's time)
        if not np.all(np.isfinite(z)):
            return start
        z, err = self.feasible(z, max_iter=20, mu=1e-8)
        return z if err <= self.tol and self.energy(z) < E0 else start

    def solve(self, rng, scale):
        best = None
        for k in range(STARTS):
            z, err = self.feasible(rng.normal(0.0, scale * (1.0 + k), self.elim.free))
            if err <= self.tol:  # the least-energy solution near it: seen to be the same
                return self.cheapest(z), err  # from every start, so one start suffices
            if best is None or err < best[1]:
                best = (z, err)
        return best


class LiePlanner(LegPlanner):
    """Lie-algebraic local steps (paper §4.2); one piece per step. See the module docstring.

    Parameters
    ----------
    settings : LieSettings
        Step length, γ, Hall basis degree, step limit, how α is chosen, rest between steps.
    """

    method = "lie"

    @classmethod
    def from_settings(cls, settings, leg, **overrides) -> LiePlanner:
        """The leg's own Lie settings, else the planner's (Newton overrides do not apply)."""
        return cls(leg.lie or settings.lie)

    def __init__(self, settings: LieSettings | None = None):
        self.settings = settings or LieSettings()

    def problem_duration(self, leg_duration: float) -> float:
        return self.settings.step_duration

    def shortfall(self, where: str, settings, free: int, needed: int) -> str:
        return (
            f"{where} (method lie): the boundary conditions of a step leave {free} free "
            f"coefficients for the {needed} coordinates of the Hall basis (degree "
            f"{self.settings.degree}): {needed - free} missing; raise planner.basis.harmonics"
        )

    def missing_coefficients(self, problem: LegProblem) -> tuple[int, int]:
        """A step must leave enough free coefficients to solve `h(λ) = α` (eq. 23) for all
        Hall coordinates, both as the first step and as a later one (from rest)."""
        lie = self.settings
        r = max(len(hall_basis(len(problem.stratum.active), lie.degree)), len(problem.targets))
        zero = (np.zeros(problem.system.m), np.zeros(problem.system.m))
        free = min(
            problem.elimination(lie.step_duration, previous, lie.rest, first).free
            for previous, first in ((problem.previous, True), (zero, False))
        )
        return free, r

    def plan(self, problem: LegProblem) -> LegOutcome:
        """Steer `problem.start` to `problem.goal` with local steps until the tolerance."""
        lie = self.settings
        system, stratum = problem.system, problem.stratum
        active = stratum.active
        m = len(active)
        basis = problem.basis
        tau = float(lie.step_duration)
        targets = np.array(problem.targets, dtype=int)
        lb = lie_basis(system, stratum, lie.degree)
        hI = iterated_integrals(basis, tau, m, lie.degree)
        M = np.kron(np.eye(m), basis.gram(tau))
        rows = [lb.free.index(int(i)) for i in targets]
        goal = np.asarray(problem.goal, dtype=float)
        q = np.asarray(problem.start, dtype=float).copy()
        err = problem.error(q)
        pieces: list[Piece] = []
        iterations = 0
        free = None
        stalls = 0
        message = ""
        prev = problem.previous
        kind = problem.endpoint(q, tau).kind
        while (err > problem.tolerance or not pieces) and len(pieces) < lie.max_steps:
            elim = problem.elimination(tau, prev, lie.rest, not pieces)
            free = elim.free if free is None else min(free, elim.free)
            endpoint = problem.endpoint(q, tau)
            B = lb.evaluate(q)[rows]  # the Hall-basis fields on the targeted coordinates
            U, S, Vt = np.linalg.svd(B, full_matrices=False)
            rank = int(np.sum(S > RCOND * S[0])) if S.size and S[0] > 0 else 0
            gamma = lie.gamma
            best = None
            for trial in range(RETRIES + 1):
                dq = gamma * (goal[targets] - q[targets])
                coords = (U.T @ dq)[:rank] / S[:rank]  # eq. 22 in the orthonormal basis V of α
                alpha0 = Vt[:rank].T @ coords  # its minimum-norm solution
                if lie.alpha == "pinv":  # then h(λ) = α_d (eq. 23-24)
                    solver = _StepSolver(hI, elim, M, np.eye(lb.size), alpha0)
                else:  # every α with Σ α_h B_h(q) = δq: Vᵀα = S⁻¹Uᵀδq (well conditioned)
                    solver = _StepSolver(hI, elim, M, Vt[:rank], coords)
                rng = np.random.default_rng([problem.seed, problem.index, len(pieces), trial])
                # starts sized like the controls that make α: brackets need |u| ~ sqrt(α)/τ
                scale = 0.3 * np.sqrt(float(np.abs(alpha0).max(initial=0.0)) + 1e-12) / tau
                z, _ = solver.solve(rng, scale)
                iterations += solver.iterations
                lam = elim.coefficients(z)
                end, _ = endpoint(lam, False)
                new_err = problem.error(end)
                if best is None or new_err < best[0]:
                    best = (new_err, lam, end)
                if new_err < err:
                    break
                gamma *= 0.5
            new_err, lam, end = best
            stalls = stalls + 1 if new_err >= err else 0
            L = lam.reshape(m, basis.size)
            pieces.append(Piece(len(pieces) * tau, tau, L))
            q, err = end, new_err
            prev = end_controls(basis, L, tau, active, system.m)
            if stalls >= STALL_STEPS:
                message = f"no progress in {STALL_STEPS} consecutive steps"
                break
        ok = err <= problem.tolerance
        if not ok and not message:
            message = f"{lie.max_steps} steps (lie.max_steps) were not enough"
        if not ok:
            message += _drifted(system, problem.start, q, goal, targets)
        return LegOutcome(
            pieces=tuple(pieces),
            end=np.array(q, dtype=float),
            error=err,
            iterations=len(pieces),  # result.json counts a Lie leg's steps as iterations
            attempts=1,
            status=Status.SUCCESS if ok else Status.LIE_NOT_CONVERGED,
            free_coefficients=0 if free is None else free,
            evaluator=kind,
            message="" if ok else message,
        )


DRIFT = 0.5  # rad: a free coordinate that moved this far is named in a failed leg's message
DRIFTED = "free coordinates drifted"  # `leg_failures.failure_message` puts it first


def _drifted(system, start, end, goal, targets) -> str:
    """Free coordinates ("*") of a failed Lie leg that drifted far: its steps steer only the
    targeted ones, and the least-norm step may move a free one through a weak field instead
    (a trial's S12 leg: q4 free drifted to 3.95 rad and failed; given, it planned in 11)."""
    steered = set(np.ravel(targets).tolist())
    free = [i for i in range(len(goal)) if i not in steered and np.isnan(goal[i])]
    moved = [i for i in free if abs(float(end[i]) - float(start[i])) > DRIFT]
    if not moved:
        return ""
    what = ", ".join(f"{system.states[i]} {start[i]:.3g} -> {end[i]:.3g}" for i in moved)
    return f"; {DRIFTED} ({what}): give them values in the leg's goal"
