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
cheapest combination do the step (Sim 3's Lie leg, degree 3: energy 1.7 instead of 4.3·10³).

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

from dataclasses import dataclass, field

import numpy as np

from ..continuity import eliminate, leg_constraints
from ..controls import FourierBasis, energy
from ..endpoint import make_endpoint
from ..lie import iterated_integrals, lie_basis
from ..models.system import System

RETRIES = 6  # halvings of γ per step when the true step does not lower the error
STARTS = 3  # seeded starts of the eq.-24 Newton method per step, until one finds a solution
RCOND = 1e-10  # directions of eq. 22 weaker than this (relative) are not asked for
STALL_STEPS = 3  # consecutive steps without progress before the leg gives up
ALPHA_MODES = ("energy", "pinv")


@dataclass(frozen=True)
class LieSettings:
    """Settings of the Lie-algebraic method (scenario: `lie = { ... }`)."""

    step_duration: float = 0.51  # the paper's step length
    gamma: float = 0.5  # fraction of the remaining error asked of one step
    degree: int = 2  # Hall basis degree: 2 (default) or 3
    max_steps: int = 40
    alpha: str = "energy"  # "energy" | "pinv" (the paper's two stages), see the module doc
    rest: bool = True  # every step ends with u = u' = 0 (self-contained loops), see module doc

    def __post_init__(self) -> None:
        if not 1 <= self.degree <= 3:
            raise ValueError(f"lie.degree must be 1, 2 or 3, got {self.degree}")
        if not 0.0 < self.gamma <= 1.0:
            raise ValueError(f"lie.gamma must be in (0, 1], got {self.gamma}")
        if self.alpha not in ALPHA_MODES:
            raise ValueError(f"lie.alpha must be one of {ALPHA_MODES}, got {self.alpha!r}")


@dataclass
class LiePiece:
    t0: float  # leg-local start time
    duration: float
    coefficients: np.ndarray  # (m_active, 2H+1)


@dataclass
class LieSolution:
    pieces: list[LiePiece]
    end: np.ndarray
    error: float
    steps: int
    iterations: int  # Newton iterations (eq. 24 and least energy), all steps
    converged: bool
    free_coefficients: int
    energy: float
    errors: list[float] = field(default_factory=list)  # error after each step
    message: str = ""


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
        r, Jz = self.residual(z)
        err = float(np.linalg.norm(r))
        eye = np.eye(len(r))
        for _ in range(max_iter):
            if err <= self.tol:
                break
            self.iterations += 1
            A = Jz @ Jz.T
            damp = mu * max(float(np.trace(A)) / max(len(r), 1), 1e-300)
            try:
                step = Jz.T @ np.linalg.solve(A + damp * eye, r)
            except np.linalg.LinAlgError:
                mu *= 100.0
                continue
            g = 1.0
            while g > 1e-4:
                z_new = z + g * step
                r_new, J_new = self.residual(z_new)
                e_new = float(np.linalg.norm(r_new))
                if e_new < err:
                    break
                g *= 0.5
            else:
                mu *= 100.0
                if mu > 1e8:
                    break
                continue
            z, r, Jz, err = z_new, r_new, J_new, e_new
            mu = max(mu / 10.0, 1e-12) if g == 1.0 else min(mu * 2.0, 1.0)
        return z, err

    def cheapest(self, z, max_iter=30):
        """Newton's method on the KKT conditions from a solution `z`."""
        E0 = self.energy(z)
        start = z
        N, k = self.N, len(self.target)
        r, Jz = self.residual(z)
        grad = 2.0 * (self.H @ z + self.g)
        nu = np.linalg.lstsq(Jz.T, grad, rcond=None)[0]
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
            if (
                np.linalg.norm(d[: len(z)]) <= 1e-10 * (1.0 + np.linalg.norm(z))
                and float(np.linalg.norm(r)) <= self.tol
            ):
                break
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


def plan_lie_leg(
    system: System,
    stratum_name: str,
    q0: np.ndarray,
    goal: np.ndarray,
    targets: np.ndarray,
    basis: FourierBasis,
    settings: LieSettings,
    *,
    tolerance: float,
    mode: str,
    previous: tuple[np.ndarray, np.ndarray] | None,
    next_active: tuple[int, ...] | None,
    soft_start: bool,
    full_stop: bool,
    evaluator: str = "auto",
    seed: int = 0,
    stream: int = 0,
) -> LieSolution:
    """Steer `q0` to `goal` on `targets` with Lie-algebraic steps; see the module docstring.

    `previous`/`next_active`/`soft_start`/`full_stop` are the leg's boundary data, as for a
    Newton leg (`soft_start` only affects the first piece of the first leg).
    """
    stratum = system.stratum(stratum_name)
    active = stratum.active
    m = len(active)
    tau = float(settings.step_duration)
    lb = lie_basis(system, stratum, settings.degree)
    hI = iterated_integrals(basis, tau, m, settings.degree)
    cs = system.compiled(stratum)
    M = np.kron(np.eye(m), basis.gram(tau))
    rows = [lb.free.index(int(i)) for i in targets]
    goal = np.asarray(goal, dtype=float)
    q = np.asarray(q0, dtype=float).copy()

    def error_of(x: np.ndarray) -> float:
        return float(np.linalg.norm(goal[targets] - x[targets]))

    err = error_of(q)
    pieces: list[LiePiece] = []
    errors: list[float] = []
    iterations = 0
    free = None
    stalls = 0
    message = ""
    prev = previous
    while (err > tolerance or not pieces) and len(pieces) < settings.max_steps:
        elim = eliminate(
            leg_constraints(
                basis,
                tau,
                active,
                system.inputs,
                mode,
                previous=prev,
                next_active=None if settings.rest else next_active,  # rest: u = u' = 0
                soft_start=soft_start and not pieces,
                full_stop=full_stop or settings.rest,
            )
        )
        free = elim.free if free is None else min(free, elim.free)
        endpoint = make_endpoint(cs, q, basis, tau, evaluator)
        B = lb.evaluate(q)[rows]  # the Hall-basis fields on the targeted coordinates
        U, S, Vt = np.linalg.svd(B, full_matrices=False)
        rank = int(np.sum(S > RCOND * S[0])) if S.size and S[0] > 0 else 0
        gamma = settings.gamma
        best = None
        for trial in range(RETRIES + 1):
            dq = gamma * (goal[targets] - q[targets])
            coords = (U.T @ dq)[:rank] / S[:rank]  # eq. 22 in the orthonormal basis V of α
            alpha0 = Vt[:rank].T @ coords  # its minimum-norm solution
            if settings.alpha == "pinv":  # then h(λ) = α_d (eq. 23-24)
                solver = _StepSolver(hI, elim, M, np.eye(lb.size), alpha0)
            else:  # every α with Σ α_h B_h(q) = δq: Vᵀα = S⁻¹Uᵀδq (well conditioned)
                solver = _StepSolver(hI, elim, M, Vt[:rank], coords)
            rng = np.random.default_rng([seed, stream, len(pieces), trial])
            # starts sized like the controls that make α: brackets need |u| ~ sqrt(α)/τ
            scale = 0.3 * np.sqrt(float(np.abs(alpha0).max(initial=0.0)) + 1e-12) / tau
            z, _ = solver.solve(rng, scale)
            iterations += solver.iterations
            lam = elim.coefficients(z)
            end, _ = endpoint(lam, False)
            new_err = error_of(end)
            if best is None or new_err < best[0]:
                best = (new_err, lam, end)
            if new_err < err:
                break
            gamma *= 0.5
        new_err, lam, end = best
        stalls = stalls + 1 if new_err >= err else 0
        L = lam.reshape(m, basis.size)
        pieces.append(LiePiece(len(pieces) * tau, tau, L))
        errors.append(new_err)
        q, err = end, new_err
        u_end = np.zeros(system.m)
        du_end = np.zeros(system.m)
        u_end[list(active)] = L @ basis.values(tau)
        du_end[list(active)] = L @ basis.derivatives(tau)
        prev = (u_end, du_end)
        if stalls >= STALL_STEPS:
            message = f"no progress in {STALL_STEPS} consecutive steps"
            break
    if err > tolerance and not message:
        message = f"{settings.max_steps} steps (lie.max_steps) were not enough"
    return LieSolution(
        pieces=pieces,
        end=q,
        error=err,
        steps=len(pieces),
        iterations=iterations,
        converged=err <= tolerance,
        free_coefficients=0 if free is None else free,
        energy=float(sum(energy(basis, p.duration, p.coefficients) for p in pieces)),
        errors=errors,
        message=message,
    )
