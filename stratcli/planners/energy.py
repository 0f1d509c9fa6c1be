"""Energy-optimal planning (beyond the paper): min Σ ∫|u|² subject to reaching every via.

All legs are optimised together: the continuity conditions of the whole sequence are linear in
the stacked coefficients and eliminated once (`λ = λp + N z`, N whitened so that the energy is
`e0 + b·z + |z|²`); the goals are nonlinear equality constraints with exact Jacobians and
Hessians (the legs' quadrature end-point maps). The problem `min λᵀMλ s.t. k_i(λ_i) = goal_i`
is solved by a feasible-point SQP with the exact Hessian of the Lagrangian (`Descent`), from
several deterministic starts that are raced (`optimise_energy`).
"""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np

from ..continuity import eliminate, sequence_constraints
from ..endpoint import make_endpoint
from ..models.system import System
from ..results import Optimisation, StartOutcome
from ..wording import counted
from .base import (
    ENERGY_RUNAWAY,
    damped_gauss_newton,
    goal_residual,
    no_divergence_check,
    onto_goals,
)
from .legwise import legwise_start
from .sqp import KEPT, MINIMUM, PG_TOL, Descent

ABANDON_AFTER, ABANDON_RATIO = 4, 1.25  # drop a start this far above the best so far
SAME_MINIMUM = 1e-2  # relative energy-norm distance at which two starts share a minimum
SAME_ENERGY = 1e-9  # relative: the legwise start wins only if lower than this (`legwise`)
# The pulled start (`pulled_start`): Gauss-Newton on |c(z)|² + w²|z - z*|² for each weight
# w in turn (z* the energy's unconstrained minimiser), each for at most PULL_ITERATIONS, then
# back onto the goals by minimum-norm Gauss-Newton (at most RESTORE_ITERATIONS, to RESTORED).
PULL_WEIGHTS = (0.316, 0.1, 0.0316)
PULL_ITERATIONS, RESTORE_ITERATIONS, RESTORED = 15, 30, 1e-9
ENERGY_RANK_TOL = 1e-12  # energy directions below this (relative) change no control


def _block_diag(blocks: list[np.ndarray]) -> np.ndarray:
    """The block-diagonal matrix of `blocks` (scipy.linalg.block_diag; no scipy import)."""
    out = np.zeros((sum(b.shape[0] for b in blocks), sum(b.shape[1] for b in blocks)))
    r = c = 0
    for b in blocks:
        out[r : r + b.shape[0], c : c + b.shape[1]] = b
        r, c = r + b.shape[0], c + b.shape[1]
    return out


def null_space(A: np.ndarray) -> np.ndarray:
    """Orthonormal basis of A's null space (scipy.linalg.null_space's rank rule)."""
    if A.size == 0:
        return np.eye(A.shape[1])
    _, s, vh = np.linalg.svd(A, full_matrices=True)
    tol = max(A.shape) * np.finfo(float).eps * (s.max() if s.size else 0.0)
    return vh[int(np.sum(s > tol)) :].T


class StackedProblem:
    """The stacked problem in the free coordinates z, with evaluations cached per z."""

    def __init__(self, system: System, starts, legs, settings, targets, constraints=None):
        basis = settings.basis
        self.legs = legs
        self.targets = targets
        actives = [system.stratum(leg.stratum).active for leg in legs]
        durations = [leg.duration for leg in legs]
        self.sizes = [len(a) * basis.size for a in actives]
        self.offsets = np.cumsum([0, *self.sizes])
        cons = (
            constraints
            if constraints is not None
            else sequence_constraints(
                basis,
                durations,
                actives,
                system.inputs,
                settings.continuity,
                soft_start=settings.soft_start,
                full_stop=settings.full_stop,
            )
        )
        self.constraints = cons
        elim = eliminate(cons)
        self.M = _block_diag(
            [
                np.kron(np.eye(len(a)), basis.gram(T))
                for a, T in zip(actives, durations, strict=True)
            ]
        )
        self.endpoints = [
            make_endpoint(system.compiled(leg.stratum), s, basis, leg.duration, settings.evaluator)
            for leg, s in zip(legs, starts, strict=True)
        ]
        self.goals = [np.asarray(leg.goal)[t] for leg, t in zip(legs, targets, strict=True)]
        self.n_residuals = sum(t.size for t in targets)
        # Work in coordinates where the energy is |z|² (up to λp): whiten the energy's
        # Hessian. The Fourier basis is far from orthogonal on a leg shorter than its period
        # (condition number ~1e13 at H = 8), and directions that change no control at all
        # (energy eigenvalue < 1e-12 of the largest) change nothing else either: drop them.
        N = elim.null
        ev, V = np.linalg.eigh(N.T @ self.M @ N)
        keep = ev > ENERGY_RANK_TOL * ev.max(initial=0.0)
        self._particular = elim.particular
        self.null = N @ (V[:, keep] / np.sqrt(ev[keep]))  # λ = λp + null @ z
        self._to_z = (np.sqrt(ev[keep])[:, None] * V[:, keep].T) @ N.T
        self.H0 = 2.0 * np.eye(int(keep.sum()))  # Hessian of the energy in z
        # The energy as the quadratic it is in z, `e0 + b·z + |z|²`: evaluating λᵀMλ instead
        # loses ~1e-12 of it to the Gram matrix's conditioning, more than the decrease left
        # near an optimum with 8 harmonics, so the line search would stall short of it.
        Mp = self.M @ self._particular
        self._e0 = float(self._particular @ Mp)
        self._b = 2.0 * self.null.T @ Mp
        self._z = None

    def with_rhs(self, c: np.ndarray) -> StackedProblem:
        """This problem with the continuity rows' right-hand side `c` (`legwise.join`): the
        same rows, so the same null space and whitened coordinates; only λp moves."""
        other = copy.copy(self)
        other._particular = eliminate(replace(self.constraints, c=np.asarray(c, float))).particular
        Mp = self.M @ other._particular
        other._e0, other._b = float(other._particular @ Mp), 2.0 * self.null.T @ Mp
        other._z = None  # evaluations are cached per z, and z now means other coefficients
        return other

    def set_accuracy(self, accuracy: float | None) -> None:
        """The accuracy (rad) the legs' maps may evaluate to (`MagnusEndpoint.accuracy`;
        None: their own); evaluations cached at another one are dropped."""
        for ep in self.endpoints:
            if hasattr(ep, "accuracy") and ep.accuracy != accuracy:
                ep.accuracy = accuracy
                self._z = None

    def coefficients(self, z):
        return self._particular + self.null @ z

    def project(self, lam):
        """z of the coefficients closest to `lam` (in energy) that meet the continuity terms."""
        return self._to_z @ (lam - self._particular)

    def split(self, lam):
        return [lam[a:b] for a, b in zip(self.offsets[:-1], self.offsets[1:], strict=True)]

    def _evaluate(self, z, jacobian: bool):
        """Goal residuals (and their Jacobian in z), cached for the last z."""
        if self._z is None or not np.array_equal(z, self._z):
            self._z, self._c, self._J = z.copy(), None, None
        if self._c is not None and jacobian and self._J is None:
            self._J = self._late_jacobian(z)
        if self._c is None or (jacobian and self._J is None):
            lam = self.coefficients(z)
            res = []
            J = np.zeros((self.n_residuals, lam.size)) if jacobian else None
            row = 0
            for i, (ep, t, g) in enumerate(
                zip(self.endpoints, self.targets, self.goals, strict=True)
            ):
                end, Ji = ep(lam[self.offsets[i] : self.offsets[i + 1]], jacobian)
                r, Jt = goal_residual(ep, end, Ji, g, t)
                res.append(r)
                if jacobian:
                    J[row : row + t.size, self.offsets[i] : self.offsets[i + 1]] = Jt
                row += t.size
            self._c = np.concatenate(res)
            if jacobian:
                self._J = J @ self.null
        return self._c, self._J

    def _late_jacobian(self, z):
        """The Jacobian in z of the residuals already evaluated at z, from the legs' last
        evaluations (their marches), or None if a leg's map cannot add it afterwards."""
        if not all(hasattr(ep, "jacobian_of_last") for ep in self.endpoints):
            return None
        lam = self.coefficients(z)
        J = np.zeros((self.n_residuals, lam.size))
        row = 0
        for i, (ep, t, g) in enumerate(zip(self.endpoints, self.targets, self.goals, strict=True)):
            end, Ji = ep.jacobian_of_last(lam[self.offsets[i] : self.offsets[i + 1]])
            J[row : row + t.size, self.offsets[i] : self.offsets[i + 1]] = goal_residual(
                ep, end, Ji, g, t
            )[1]
            row += t.size
        return J @ self.null

    def constraint(self, z):
        return self._evaluate(z, False)[0]

    def constraint_jac(self, z):
        return self._evaluate(z, True)[1]

    def energy(self, z):
        return self._e0 + float(self._b @ z) + float(z @ z)

    def energy_grad(self, z):
        return self._b + 2.0 * z

    @property
    def exact_hessians(self) -> bool:
        return all(hasattr(ep, "hessian") for ep in self.endpoints)

    def constraint_hessian(self, z, mu) -> np.ndarray:
        """`Σ_j μ_j ∇²c_j(z)` in z (exact, from the legs' quadrature Hessians)."""
        lam = self.coefficients(z)
        H = np.zeros((lam.size, lam.size))
        row = 0
        for i, (ep, t) in enumerate(zip(self.endpoints, self.targets, strict=True)):
            weights = np.zeros(ep.q0.size)
            weights[t] = mu[row : row + t.size]
            a, b = self.offsets[i], self.offsets[i + 1]
            H[a:b, a:b] = ep.hessian(lam[a:b], weights)
            row += t.size
        N = self.null
        return N.T @ H @ N

    def projected_gradient(self, z) -> float:
        """|Z'∇f| / |∇f| with Z a basis of the constraints' tangent space at z."""
        g = self.energy_grad(z)
        Z = null_space(self.constraint_jac(z))
        return float(np.linalg.norm(Z.T @ g) / max(np.linalg.norm(g), 1e-300))


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
    start is made here), and the legwise start; default: silent. `pg_tol`: the relative
    projected gradient at which a start has converged (`sqp.PG_TOL`; a leg bound of the
    screen without exact Hessians needs less, `leg_bounds.BOUND_PG_TOL`).
    """
    say = progress or (lambda phase: None)
    problem = StackedProblem(system, starts, legs, settings, targets, constraints)
    if not problem.exact_hessians:  # URDF, ODE-path legs: first-order steps are slow
        say(f"energy search: minimum energy from {_starts(seeds[:1])}")
        runs = _first_kept(problem, seeds, settings.tolerance, pg_tol)
        seeds = seeds[: len(runs)]
    else:
        say("energy search: pulling the Newton plan toward low energy (a start)")
        seeds = _with_pulled_start(problem, seeds, settings.starts)
        say(f"energy search: minimum energy from {_starts(seeds)}")
        zs = [problem.project(lam) for _, lam in seeds]
        runs = race(problem, zs, settings.tolerance, pg_tol)
    if problem.exact_hessians and settings.search == "legwise":
        # raced on its own, after the others: their race (which abandons a start that an
        # earlier low one outruns) is the default search's, so the result is never higher
        say(f"energy search: start {len(seeds) + 1}, made leg by leg (legwise)")
        z = legwise_start(problem, system, legs, settings, *_newton_part(seeds))
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
        # energy can undercut that converged one only by rounding; nor is the legwise start
        # at the default starts' minimum (it changes a plan only where it finds a lower one)
        below = best_energy * (1.0 - SAME_ENERGY) if seeds[k][0] == "legwise" else best_energy
        if ok and run.reason != "same minimum" and energy < below:
            best_energy = energy
            best_index = k
            coefficients = problem.split(problem.coefficients(z))
    return coefficients, Optimisation(tuple(outcomes), best_index, None)


def race(
    problem: StackedProblem, zs: list[np.ndarray], tolerance: float, pg_tol: float = PG_TOL
) -> list[Descent]:
    """The feasible SQP from each start `zs` (whitened), raced (`optimise_energy`); the runs,
    in the order of `zs`."""
    runs = [Descent(problem, z, tolerance, pg_tol) for z in zs]
    found: list[np.ndarray] = []  # minima reached by finished starts
    best = [np.inf]

    first = next((run.energy for run in runs if run.feasible), np.inf)

    def finish(run: Descent, iterations: int | None) -> None:
        while not run.done and (iterations is None or run.iterations < iterations):
            if run.energy > ENERGY_RUNAWAY * first:
                run.stop("diverged")  # ran away from the first feasible start's energy
            elif run.iterations >= ABANDON_AFTER and run.energy > ABANDON_RATIO * best[0]:
                run.stop("abandoned")  # energy only decreases: unlikely to beat the best
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
