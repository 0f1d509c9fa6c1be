"""One start of the constrained search (`planners.constrained`): onto the node margins, then
least energy inside them.

The search works on the stacked problem of the energy objective (`stacked.StackedProblem`:
all legs' coefficients, continuity eliminated, every iterate restored onto the goals by
Newton steps of least energy norm) with the node margins g(z) ≥ 0 of `node_margins`.

1. **Feasibility** (`MarginSearch.reach_feasible`, both objectives). The end-point map is extended
   with the violations: its outputs are the goal residuals and `min(0, g_k − 2 PUSH)` at every
   node, driven to zero together by damped Gauss–Newton steps of least energy norm (the
   extended-map method of Janiak & Tchoń 2011, with the violation integral ∫ min(0, g)² dt
   resolved node by node: its gradient, unlike the integral's, does not vanish as the
   violation does). It ends when every margin is at least `PUSH` and the plan, restored onto
   the goals, is still strictly inside.
2. **Minimum energy inside the limits** (`MarginSearch.lower`, the energy objective only). First
   an interior (log-barrier) round from that feasible plan: the energy search's reduced
   Newton step (`sqp.Descent`) for `E(z) + μ Σ_k b(g_k(z)) / NODES`, b(g) = −log x + x − 1
   of x = g / REACH (zero and flat from REACH on: far margins cost nothing), its Hessian in
   Gauss–Newton form; every trial point is restored onto the goals and rejected unless every
   margin stays positive. Then an active-set SQP (`MarginSearch._sqp_step`): each step a small
   dense QP in the goals' tangent space with the margins within REACH linearised
   (`active_set`), the clearances' own curvature in its Hessian (through θ's exact
   curvature at the nodes as well, where obstacles make them depend on θ), an ℓ1 merit; it
   ends on the constrained minimum at the nodes in a few tens of steps, where further
   barrier rounds (μ tenfold smaller each) took a hundred or more, their steps cut to
   3–30 % by the fraction-to-boundary rule.

A search that cannot make every margin positive says which limit on which leg it stalled on
(`MarginSearch.stalled`).
"""

from __future__ import annotations

import numpy as np

from ..body_clearances import closest_pair
from ..node_margins import NODES, NodeMargins
from .active_set import convexified, least_distance
from .sqp import CURVATURE_FLOOR, RANK_RTOL, STEP_LIMIT, Descent
from .stacked import StackedProblem

__all__ = ["REACH", "MarginSearch"]

PUSH = 1e-3  # the feasibility phase ends with every node margin at least this
CLEARANCES = ("self-collision", "an obstacle")  # the node margins' kinds of clearance rows
FEASIBILITY_ITERATIONS = 60
DAMPING_MAX = 1e8  # relative Levenberg damping at which the feasibility phase gives up
BARRIER_START = 1e-2  # μ0 as a fraction of the feasible plan's energy
ROUND_ITERATIONS = 50  # of the barrier round that leads into the basin
LATER_ITERATIONS = 15  # of those after nodes were added: from close to the minimum
FLAT_STEPS, FLAT = 3, 1e-5  # a barrier round ends when that many steps lowered it by < FLAT
REACH = 0.3  # the barrier and the QP ignore margins above this (rad or length unit)
FRACTION_TO_BOUNDARY = 0.9
SQP_ITERATIONS = 60
# the SQP has converged when its step promises less than 1e-12 of the energy, or when NOISY
# steps in a row promised less than 1e-10: task A spent 12 of its 26 steps at 1e-11, within
# the ℓ1 merit's noise (active margins at ±1e-11 times the penalty), each line search halving
# 6-27 times; one such step alone is not the end (an active set that changes promises more)
SQP_CONVERGED, SQP_NOISE, NOISY = 1e-12, 1e-10, 3
CRAWL, CRAWL_DROP = 5, 1e-3  # `MarginSearch.lower`: the SQP's stop when crawling outside
ACTIVE = 1e-3  # a margin below this with a positive multiplier counts as active
VIOLATION = 1e-6  # an SQP iterate with no node margin below minus this counts as inside
VIOLATION_CAP = 1e-4  # no SQP trial may leave a node further outside (unless the iterate is)
ARMIJO, MIN_STEP = 1e-4, 1e-8  # sufficient decrease of a line search; its shortest step


class MarginSearch(Descent):
    """One start of the constrained search (phases 1 and 2 above): restoration and bookkeeping
    from `Descent`."""

    loose = False  # its own steps: every restoration to rounding

    def __init__(self, problem: StackedProblem, margins: NodeMargins, z: np.ndarray, tol: float):
        super().__init__(problem, z, tol)
        self.margins = margins
        self.stalled = ""
        self.outside = False  # whether the last SQP step started outside the node margins

    def _subspace(self, z):
        _, J = self.problem._evaluate(z, True)
        _, S, Vt = np.linalg.svd(J)
        rank = int(np.sum(S > RANK_RTOL * max(S[0], 1e-300))) if S.size else 0
        return J, Vt[rank:].T

    # ---- 1. feasibility --------------------------------------------------------------------
    def reach_feasible(self) -> bool:
        """Damped Gauss–Newton steps of least energy norm on the extended map (goal residuals
        and node violations together); True when the plan, restored onto the goals, has every
        margin at least `PUSH`."""
        if not self.feasible:  # (`Descent`: the start was restored onto the goals)
            self.stalled = "the start could not be restored onto the goals"
            return False
        problem, z = self.problem, self.z
        scale = 1.0 / np.sqrt(NODES)  # a node's violation: a share of the integral

        def extended(z, jacobian):
            c, J = problem._evaluate(z, jacobian)
            g, G = self.margins(z, jacobian)
            active = g < 2 * PUSH  # aim beyond PUSH: Gauss–Newton only approaches its aim
            R = np.concatenate([c, scale * (g[active] - 2 * PUSH)])
            A = np.vstack([J, scale * G[active]]) if jacobian else None
            return R, A, g

        R, A, g = extended(z, True)
        damping = 1e-6
        for _ in range(FEASIBILITY_ITERATIONS):
            if g.size == 0 or g.min() >= PUSH:
                restored = self._restore(z)
                if restored is not None:
                    g_r = self.margins(restored, False)[0]
                    if g_r.size == 0 or g_r.min() > 0:
                        self.z, self.energy = restored, problem.energy(restored)
                        return True
            self.iterations += 1
            H, grad = A.T @ A, A.T @ R
            size = max(float(np.diag(H).max(initial=0.0)), 1e-12)
            value = float(R @ R)
            while damping <= DAMPING_MAX:
                d = np.linalg.solve(H + damping * size * np.eye(len(H)), -grad)
                R_t = extended(z + d, False)[0]
                if np.all(np.isfinite(R_t)) and float(R_t @ R_t) < value:
                    z = z + d
                    R, A, g = extended(z, True)
                    damping = max(damping / 10, 1e-12)
                    break
                damping *= 10
            else:
                break
        worst = int(np.argmin(g))
        leg, what = self.margins.labels[worst]
        what = self._bodies(z, worst, what)
        angles = (
            self.margins.robot is not None
            or getattr(self.margins.system, "spatial", None) is not None
        )
        unit = " rad" if what.startswith("the joint limits") and angles else ""  # else its own
        self.stalled = (
            f"the constrained search stalled on leg {leg + 1}: {what} still violated by "
            f"{max(PUSH - g[worst], 0.0):.3g}{unit} at its nodes"
        )
        return False

    def _bodies(self, z: np.ndarray, row: int, what: str) -> str:
        """A clearance row's kind with the bodies (and obstacle) nearest touching at its node,
        as the verification names them (`self-collision (link 1 and link 3)`): "an obstacle"
        alone did not say which of three."""
        m = self.margins
        at = getattr(m, "_curvature_at", None)  # the last Jacobian's nodes, if at this z
        if what not in CLEARANCES or m.robot is None or at is None or not np.array_equal(at[0], z):
            return what
        _, first, node, _, q, *_ = at
        pair, _ = closest_pair(m.robot, q[node[row - first]], m.c, obstacles=what == "an obstacle")
        return f"{what} ({pair})"

    # ---- 2. minimum energy inside the limits ------------------------------------------------
    def _barrier(self, z, mu: float, g=None):
        if g is None:
            g = self.margins(z, jacobian=False)[0]
        if g.size and g.min() <= 0:
            return np.inf
        x = np.minimum(g, REACH) / REACH  # -log x + x - 1: zero, and flat, from REACH on
        return self.problem.energy(z) + mu * float(np.sum(x - 1.0 - np.log(x))) / NODES

    def _lower_barrier(self, iterations: int) -> None:
        """Log-barrier descent at μ0 from a feasible z (every iterate feasible). It only leads
        the SQP into the basin, so it ends once `FLAT_STEPS` steps lowered the barrier
        function by less than `FLAT` (relative) together: the obstacle task's first round
        spent 38 of its 50 steps on a plateau (energy 110.29 -> 110.18), with the same plan
        in the end."""
        mu = BARRIER_START * self.energy
        values = []  # the barrier function after each step
        for _ in range(iterations):
            self.iterations += 1
            if not self._barrier_step(mu):
                break
            values.append(self.barrier_value)  # (the accepted trial's)
            if len(values) > FLAT_STEPS and values[-FLAT_STEPS - 1] - values[-1] <= FLAT * abs(
                values[-1]
            ):
                break  # on a plateau: the SQP that follows goes on from here
        self.energy = self.problem.energy(self.z)

    def _barrier_step(self, mu: float) -> bool:
        problem, z = self.problem, self.z
        g, G = self.margins(z)
        J, Z = self._subspace(z)
        near = np.flatnonzero(g < REACH)  # the barrier is flat (and zero) beyond REACH
        inv = 1.0 / g[near]
        slope_b = inv - 1.0 / REACH  # -b'(g), per row near
        grad = problem.energy_grad(z) - (mu / NODES) * (G[near].T @ slope_b)
        reduced = Z.T @ grad
        if np.linalg.norm(reduced) <= 1e-9 * np.linalg.norm(grad):
            return False
        lagrange = -np.linalg.lstsq(J.T, grad, rcond=None)[0]
        GZ = (G[near] @ Z) * inv[:, None]
        R = Z.T @ (self.H0 + self.goal_curvature(z, J, lagrange)) @ Z
        R += (mu / NODES) * (GZ.T @ GZ)
        low = float(np.linalg.eigvalsh(R)[0]) / 2.0 if R.size else np.inf
        if low < CURVATURE_FLOOR:
            R = R + (CURVATURE_FLOOR - low) * 2.0 * np.eye(len(R))
        d = -Z @ np.linalg.solve(R, reduced)
        size = float(np.linalg.norm(d)) * np.sqrt(2.0)
        limit = STEP_LIMIT * np.sqrt(max(self.energy, 1e-300))
        if size > limit:
            d *= limit / size
        slope = float(grad @ d)
        if -slope <= 1e-12 * max(abs(self._barrier(z, mu, g)), 1e-300):
            return False
        Gd = G @ d
        shrinking = Gd < 0
        alpha = 1.0
        if shrinking.any():
            alpha = min(1.0, FRACTION_TO_BOUNDARY * float(np.min(g[shrinking] / -Gd[shrinking])))
        merit = self._barrier(z, mu, g) + float(lagrange @ problem.constraint(z))
        while alpha > MIN_STEP:
            trial = self._restore(z + alpha * d)
            if trial is not None:
                value = self._barrier(trial, mu)
                if np.isfinite(value):
                    m = value + float(lagrange @ problem.constraint(trial))
                    if m <= merit + ARMIJO * alpha * slope:
                        self.z, self.energy = trial, problem.energy(trial)
                        self.barrier_value = value
                        return True
            alpha *= 0.5
        return False

    def lower(self, lead_in: bool = True) -> None:
        """Least energy inside the limits from a feasible z: a barrier round, which leads into
        the basin (`ROUND_ITERATIONS` steps; `LATER_ITERATIONS` when not `lead_in`: after
        nodes were added, from close to the minimum), then the active-set SQP (`_sqp_step`),
        which converges in a few tens of steps where further barrier rounds take a hundred.
        The SQP stops early when `CRAWL` steps from iterates outside the margins (by up to
        `VIOLATION_CAP`) lowered the energy by less than `CRAWL_DROP` (relative): steps cut
        short by the cap, a random obstacle task's 60 steps took 4 of its 10 s that way."""
        self.multipliers = None  # the node margins', from the last QP
        self.penalty = 0.0  # of the ℓ1 merit
        self.noisy = 0  # SQP steps in a row that promised less than `SQP_NOISE`
        self._lower_barrier(ROUND_ITERATIONS if lead_in else LATER_ITERATIONS)
        energies = []  # after each step from an iterate outside the margins; reset inside
        for _ in range(SQP_ITERATIONS):
            self.iterations += 1
            if not self._sqp_step():
                break
            energies = [*energies, self.energy] if self.outside else []
            if len(energies) > CRAWL and energies[-CRAWL - 1] - self.energy <= CRAWL_DROP * (
                self.energy
            ):
                break  # crawling along just outside: phase 1 takes it back inside at once
        self.energy = self.problem.energy(self.z)

    def inside(self) -> bool:
        """Whether every node margin of z is at least -`VIOLATION`."""
        g = self.margins(self.z, jacobian=False)[0]
        return bool(g.size == 0 or g.min() >= -VIOLATION)

    def _merit(self, z, lagrange, g=None):
        """ℓ1 merit of the SQP: the Lagrangian of the goals (restored points meet them only
        to rounding, as in `sqp.Descent`) plus `penalty` x the summed node violation."""
        if g is None:
            g = self.margins(z, jacobian=False)[0]
        violation = float(np.sum(np.maximum(-g, 0.0)))
        value = self.problem.energy(z) + float(lagrange @ self.problem.constraint(z))
        return value + self.penalty * violation, violation

    def _sqp_step(self) -> bool:
        """One step of the active-set SQP in the goals' tangent space (reduced coordinates p,
        d = Z p): min ½pᵀRp + ∇Eᵀd subject to g + G d ≥ 0 at the nodes within `REACH`, R the
        reduced Hessian of the Lagrangian (the goals' exact Hessians, the clearances' own
        curvature; `active_set.convexified`). The trial is restored onto the goals and taken
        if the ℓ1 merit falls and no node goes further than `VIOLATION_CAP` outside; if the
        full step fails, a second-order correction (the same QP with the margins' nonlinear
        error at the full step) is tried before halving. False when converged or stuck."""
        problem, z = self.problem, self.z
        g, G = self.margins(z)
        J, Z = self._subspace(z)
        grad = problem.energy_grad(z)
        nu = self.multipliers
        if nu is None or nu.size != g.size:
            nu = np.zeros(g.size)
        lagrange = -np.linalg.lstsq(J.T, grad - G.T @ nu, rcond=None)[0]
        reduced = Z.T @ grad
        W = self.H0 + self.goal_curvature(z, J, lagrange) - self.margins.curvature(z, nu)
        R = convexified(Z.T @ W @ Z, G[(nu > 0) & (g < ACTIVE)] @ Z, CURVATURE_FLOOR)
        rows = np.flatnonzero(g < REACH)
        A = G[rows] @ Z
        L = np.linalg.cholesky(R)
        newton = -np.linalg.solve(R, reduced)
        At = np.linalg.solve(L, A.T).T  # A L⁻ᵀ: in w = Lᵀ(p - newton) the QP is least distance

        def qp(low, active):  # p and the multipliers of A p ≥ low (`active`: a warm start)
            solved = least_distance(At, low - A @ newton, active)
            if solved is None:
                return None, None
            return newton + np.linalg.solve(L.T, solved[0]), solved[1]

        p, nu_rows = qp(-g[rows], nu[rows] > 0)
        if p is None:
            return False  # the linearised margins admit no step
        d = Z @ p
        size = float(np.linalg.norm(d)) * np.sqrt(2.0)
        limit = STEP_LIMIT * np.sqrt(max(self.energy, 1e-300))
        scale = min(1.0, limit / max(size, 1e-300))
        d *= scale
        self.multipliers = np.zeros(g.size)
        self.multipliers[rows] = nu_rows
        self.penalty = max(self.penalty, 2.0 * float(nu_rows.max(initial=0.0)))
        merit, violation = self._merit(z, lagrange, g)
        worst = max(-float(g.min(initial=0.0)), 0.0)
        slope = float(grad @ d) - scale * self.penalty * violation
        promised = -slope / max(self.energy, 1e-300)
        self.noisy = self.noisy + 1 if promised <= SQP_NOISE and worst <= VIOLATION else 0
        if self.noisy >= NOISY or (promised <= SQP_CONVERGED and worst <= VIOLATION):
            return False  # converged (to rounding, or to the merit's noise)
        cap = max(VIOLATION_CAP, worst)
        self.outside = worst > VIOLATION

        def accept(trial, alpha):
            if trial is None:
                return False, None
            g_t = self.margins(trial, jacobian=False)[0]
            m = self._merit(trial, lagrange, g_t)[0]
            ok = bool(np.isfinite(m) and m <= merit + ARMIJO * alpha * slope)
            if ok and -float(g_t.min(initial=0.0)) <= cap:
                self.z, self.energy = trial, problem.energy(trial)
                return True, g_t
            return False, g_t

        ok, g_t = accept(self._restore(z + d), 1.0)
        if ok:
            return True
        if g_t is not None and scale == 1.0:  # second-order correction
            p2 = qp(-g[rows] - (g_t[rows] - g[rows] - G[rows] @ d), nu_rows > 0)[0]
            if p2 is not None and float(np.linalg.norm(Z @ p2)) * np.sqrt(2.0) <= limit:
                if accept(self._restore(z + Z @ p2), 1.0)[0]:
                    return True
        alpha = 0.5
        while alpha > MIN_STEP:
            if accept(self._restore(z + alpha * d), alpha)[0]:
                return True
            alpha *= 0.5
        return False
