"""The energy objective's problem over all legs at once (`StackedProblem`): the legs' Fourier
coefficients stacked, the continuity conditions eliminated once (`λ = λp + N z`, N whitened so
that the energy is `e0 + b·z + |z|²`), the goals nonlinear equality constraints with their
Jacobians (and exact Hessians where the legs' end-point maps have them), evaluations cached
per z. A via's free ("*") base attitude chains the legs (`_chained`); its other free
coordinates are held where the plan the search starts from left them (`_held`), so that
every leg starts where the one before ends. `planners.energy` searches it; the constrained
search and the legwise start too.
"""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np

from .. import so3
from ..continuity import eliminate, sequence_constraints
from ..endpoint import make_endpoint
from ..models.system import System
from .base import goal_residual

__all__ = ["HELD_NOTE", "StackedProblem", "held_coordinates", "null_space"]

ROTATION = "rotation"  # a leg chained to the one before by its attitude (`_chained`)
HELD_NOTE = "the energy search held "  # how the note of `held_coordinates` begins
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
            make_endpoint(
                system.compiled(leg.stratum),
                s,
                basis,
                leg.duration,
                settings.evaluator,
                settings.tolerance,
            )
            for leg, s in zip(legs, starts, strict=True)
        ]
        self.chained = _chained(self.endpoints, targets)
        self.legs, self.targets = _held(system, legs, targets, self.endpoints, self.chained)
        self.goals = [
            np.asarray(leg.goal)[t] for leg, t in zip(self.legs, self.targets, strict=True)
        ]
        self._ends: list = []  # of the last evaluation (`_residuals`)
        self.n_residuals = sum(t.size for t in self.targets)
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
            self._c, self._J = self._residuals(z, lambda ep, lam: ep(lam, jacobian))
        return self._c, self._J

    def _late_jacobian(self, z):
        """The Jacobian in z of the residuals already evaluated at z, from the legs' last
        evaluations (their marches), or None if a leg's map cannot add it afterwards."""
        if not all(hasattr(ep, "jacobian_of_last") for ep in self.endpoints):
            return None
        return self._residuals(z, lambda ep, lam: ep.jacobian_of_last(lam))[1]

    def _residuals(self, z, evaluate):
        """The goal residuals at z and their Jacobian in z (None where `evaluate(ep, λ)`, a
        leg's end and Jacobian, gives none); a leg that starts after a via with a free
        attitude starts where the leg before ends (`_chained`)."""
        lam = self.coefficients(z)
        res, rows, before, ends = [], [], None, []
        for i, (ep, t, g) in enumerate(zip(self.endpoints, self.targets, self.goals, strict=True)):
            a, b = self.offsets[i], self.offsets[i + 1]
            end, Ji = evaluate(ep, lam[a:b])
            J = None
            if Ji is not None:
                J = np.zeros((end.size, lam.size))
                J[:, a:b] = Ji
            if self.chained[i] is not None:
                end, J = _after(self.chained[i], ep, end, J, *before)
            before = (end, J)
            ends.append(before)
            r, Jt = goal_residual(ep, end, J, g, t)
            res.append(r)
            rows.append(Jt)
        J = None if any(Jt is None for Jt in rows) else np.vstack(rows) @ self.null
        self._ends = ends  # each leg's end (chained) and its rows over λ: `start_shifts`
        return np.concatenate(res), J

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
        """`Σ_j μ_j ∇²c_j(z)` in z (exact, from the legs' quadrature Hessians): a leg chained
        to the one before on coordinates it adds to (`_chained`) weighs that leg's ends there
        as well, so the weights are carried back from the last leg."""
        lam = self.coefficients(z)
        weights = [np.zeros(ep.q0.size) for ep in self.endpoints]
        row = 0
        for w, t in zip(weights, self.targets, strict=True):
            w[t] = mu[row : row + t.size]
            row += t.size
        for i in range(len(weights) - 1, 0, -1):
            if self.chained[i] is not None:  # (additive: a spatial leg has no Hessian)
                weights[i - 1][self.chained[i]] += weights[i][self.chained[i]]
        H = np.zeros((lam.size, lam.size))
        for i, (ep, w) in enumerate(zip(self.endpoints, weights, strict=True)):
            a, b = self.offsets[i], self.offsets[i + 1]
            H[a:b, a:b] = ep.hessian(lam[a:b], w)
        N = self.null
        return N.T @ H @ N

    def start_shifts(self, z, jacobian: bool) -> list:
        """Per leg: None, or (coordinates, shift, its Jacobian in z) where the leg starts
        elsewhere than its nominal start on quadrature coordinates chained to the leg before
        (`_chained`): what `node_margins` adds to θ along the leg (obstacles, limits on θ)."""
        self._evaluate(z, jacobian)
        out = []
        for i, link in enumerate(self.chained):
            if link is None or isinstance(link, str):
                out.append(None)
                continue
            end, J = self._ends[i - 1]
            slope = J[link] @ self.null if jacobian else None
            out.append((link, end[link] - self.endpoints[i].q0[link], slope))
        return out

    def projected_gradient(self, z) -> float:
        """|Z'∇f| / |∇f| with Z a basis of the constraints' tangent space at z."""
        g = self.energy_grad(z)
        Z = null_space(self.constraint_jac(z))
        return float(np.linalg.norm(Z.T @ g) / max(np.linalg.norm(g), 1e-300))


def _chained(endpoints, targets) -> list:
    """How each leg starts where the leg before ends, not where the plan the search was
    seeded from left the via, for the coordinates that via leaves free ("*"): None (it
    leaves none such), ROTATION (a spatial leg after a via whose attitude is free in part
    or whole: a leg turns the base by ΔR whatever attitude it starts from, its angular
    velocity in its own frame a function of the joints alone, so the legs chain as a
    product of rotations) or the indices of quadrature coordinates (a planar base's θ: no
    field depends on them, so a leg adds the same to them from any start). Joints left free
    at a via stay where that plan put them: the legs after them would move otherwise."""
    out = [None]
    for before, ep, t in zip(endpoints[:-1], endpoints[1:], targets[:-1], strict=True):
        link = None
        if ep.kind == "magnus" and getattr(before, "k", None) == ep.k:
            link = ROTATION if not np.isin(np.arange(ep.k, ep.k + 3), t).all() else None
        elif ep.kind == "quadrature" and before.kind == "quadrature":
            added = np.setdiff1d(ep.Q, t)
            link = added if added.size else None
        out.append(link)
    return out


def held_coordinates(system: System, legs, targets, endpoints, chained=None) -> list[np.ndarray]:
    """Per via (every leg but the last), the coordinates the search holds (`_held`): free
    there, moved by the leg, not carried into the next leg by `_chained` (`chained`, where
    the caller has it)."""
    chained = _chained(endpoints, targets) if chained is None else chained
    out = []
    for leg, t, link, after in zip(
        legs[:-1], targets[:-1], chained[1:], endpoints[1:], strict=True
    ):
        carried = np.arange(after.k, after.k + 3) if link == ROTATION else link
        moved = np.asarray(system.stratum(leg.stratum).free(system.n), dtype=int)
        out.append(np.setdiff1d(moved, np.union1d(t, [] if carried is None else carried)))
    return out


def _held(system: System, legs, targets, endpoints, chained):
    """The legs and targets searched: a via's free coordinates that the next leg does not
    chain (`_chained`: a joint, or any coordinate of an ODE-path leg) are held where the
    plan the search starts from left them (the next leg's nominal start), so that the next
    leg starts where this one ends: left free, the search moved them at no cost to a leg
    that ignores them, and re-chaining its controls re-planned the next leg (task D with q2
    free at its via: 96.00 where holding gives a plan whose energy is the search's)."""
    out_legs, out_targets = list(legs), list(targets)
    for i, held in enumerate(held_coordinates(system, legs, targets, endpoints, chained)):
        if held.size:
            goal = np.array(legs[i].goal, dtype=float)
            goal[held] = endpoints[i + 1].q0[held]
            out_legs[i] = replace(legs[i], goal=goal)
            out_targets[i] = np.union1d(targets[i], held).astype(int)
    return out_legs, out_targets


def _after(link, ep, end, J, before, J_before):
    """A leg's end (and its Jacobian rows over every coefficient) started at `before`, the
    end of the leg before (`J_before`), instead of at the via `ep.q0` on the coordinates of
    `link` (`_chained`). A rotation: R = R_before ΔR with ΔR = R(q0)ᵀ R(end), so a right
    perturbation δ of R_before is `ΔRᵀ δ` of R (rotation vectors through the right
    Jacobians of `so3`)."""
    out = np.array(end, dtype=float)
    J = None if J is None else J.copy()
    if not isinstance(link, str):  # quadrature coordinates: added to
        out[link] += before[link] - ep.q0[link]
        if J is not None:
            J[link] += J_before[link]
        return out, J
    k = ep.k
    turn = so3.exp(ep.q0[k:]).T @ so3.exp(end[k:])  # ΔR of this leg
    phi = so3.log(so3.exp(before[k:]) @ turn)
    out[k:] = phi
    if J is not None:
        J[k:] = so3.right_jacobian_inverse(phi) @ (
            turn.T @ so3.right_jacobian(before[k:]) @ J_before[k:]
            + so3.right_jacobian(end[k:]) @ J[k:]
        )
    return out, J
