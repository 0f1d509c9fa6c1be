"""Margins to joint limits, self-collision and obstacles at nodes of every leg, with their
derivatives in the coefficients of the stacked energy problem (no I/O).

The constrained search (`planners.constrained`) works in the free coordinates z of the stacked
problem (`planners.stacked.StackedProblem`: λ = λp + N z, the continuity terms eliminated).
Along each leg, at `NODES` equally spaced times (more for fast harmonics, `NODES_PER_RADIAN`):

* the joints are closed-form integrals of the Fourier controls, affine in λ: their margins to
  the joint limits and the derivatives of those are exact;
* the base angle θ (needed only for obstacles: self-collision depends on the joints alone) is
  a quadrature of the connection, accumulated over the node intervals with `GAUSS` Gauss
  points each, its derivative by the same quadrature (as `endpoint.QuadratureEndpoint`);
* the clearances are separating-axis gaps (`geometric_margins`, as `clearance.penetration`):
  minus the depth of overlap where bodies overlap, so that a colliding plan still has a
  direction out, and a lower bound of the distance where they are apart (so a plan with
  positive margins here has them in `constraints.verify` too); differentiated in the
  configuration by forward differences and chained with the above.

Every margin is reduced by `CUSHION` (rad or length unit) so that a plan that keeps every node
margin positive keeps the dense re-integration's (`constraints.verify`, 2000 samples a leg)
non-negative between the nodes too; `NodeMargins.refined` adds nodes where it does not.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from .endpoint import pair_products
from .geometric_margins import GeometricMargins

__all__ = ["CUSHION", "NODES", "NodeMargins", "searchable"]

NODES = 128  # per leg at least (t = 0 is the leg's fixed start and is left out)
NODES_PER_RADIAN = 13  # and at least this many per radian of the top harmonic's phase
GAUSS = 4  # Gauss points per node interval for the base angle's quadrature
CUSHION = 2e-3  # margin kept at the nodes, for the samples between them
FD_STEP = 1e-7  # forward differences of the clearances in the configuration
CURVATURE_STEP = 1e-4  # second differences of the clearances (`NodeMargins.curvature`)


def searchable(constraints) -> bool:
    """Whether the [constraints] table asks the search for anything (joint limits,
    self-collision or obstacles; rate limits are met by time scaling afterwards)."""
    if constraints is None:
        return False
    limited = np.isfinite(constraints.lower) | np.isfinite(constraints.upper)
    return bool(limited.any() or constraints.geometric)


def _per_phase(ep) -> int:
    omega = float(ep.basis.omega[-1]) if ep.basis.harmonics else 0.0
    return int(np.ceil(NODES_PER_RADIAN * omega * ep.duration))


class _Leg:
    """One leg's nodes: the affine map of its coefficients to the joints there, and the
    quadrature tables for θ."""

    def __init__(self, ep, rows: slice, t: np.ndarray, need_theta: bool):
        self.ep, self.rows = ep, rows
        self.t = np.asarray(t, dtype=float)  # increasing, in (0, T]
        m, s = ep.m, ep.size
        Psi = ep.basis.integrals(self.t)  # (N, s)
        # q_E(t_k) = q0_E + C L Ψ(t_k): dq_E/dλ[k, e, (a, b)] = C[e, a] Ψ[k, b]
        self.dE = np.einsum("ea,kb->keab", ep.C, Psi).reshape(len(self.t), ep.E.size, m * s)
        self.theta = need_theta and ep.Q.size > 0
        self.dqz = None  # dq/dz at the nodes, kept when it is constant (no θ: `NodeMargins`)
        self._memo = None  # (λ, q, θ's terms) of the last `configurations`
        # coordinates that move on this leg (a locked joint stays at its via, checked on
        # loading): joints driven by an input, and θ when it is integrated
        driven = ep.E[np.any(ep.C != 0.0, axis=1)] if ep.E.size else ep.E
        self.moving = set(driven.tolist()) | (set(ep.Q.tolist()) if self.theta else set())
        if self.theta:
            x, w = np.polynomial.legendre.leggauss(GAUSS)
            edges = np.concatenate([[0.0], self.t])
            h = np.diff(edges)
            self.tg = (edges[:-1, None] + 0.5 * h[:, None] * (x + 1.0)).ravel()
            self.wg = (0.5 * h[:, None] * w).ravel()
            self.Phi_g, self.Psi_g = ep.basis.values(self.tg), ep.basis.integrals(self.tg)

    @cached_property
    def pairs(self) -> np.ndarray:
        """The Gauss points' basis products for `theta_hessian` (made when first needed: the
        dense probe of `NodeMargins.refined` never needs them)."""
        return pair_products(self.wg, self.Phi_g, self.Psi_g)

    def _gauss_state(self, lam: np.ndarray):
        """q (θ at the leg's start) and u at the Gauss points, as the end point has them."""
        ep = self.ep
        L = lam.reshape(ep.m, ep.size)
        qg = np.broadcast_to(ep.q0, (len(self.tg), ep.q0.size)).copy()
        qg[:, ep.E] += self.Psi_g @ (L.T @ ep.C.T)
        return qg, self.Phi_g @ L.T

    def theta_hessian(self, lam: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """`Σ_k Σ_i weights[k, i] ∇²q_Q,i(t_k)` in λ (p x p): the quadrature coordinates' exact
        second derivatives at the nodes, weighted. θ(t_k) sums the integrand over the Gauss
        points before t_k, so the sum is one quadrature over the leg with each Gauss point
        weighted by the node weights from its interval on (`endpoint.integrand_hessian`)."""
        qg, u = self._gauss_state(lam)
        after = np.cumsum(weights[::-1], axis=0)[::-1]  # Σ_{j ≥ k} weights[j]
        return self.ep.integrand_hessian(qg, u, np.repeat(after, GAUSS, axis=0), self.pairs)

    def configurations(self, lam: np.ndarray, jacobian: bool):
        """q at the nodes (N, n) and dq/dλ (N, n, p) (None without `jacobian`). The last
        call's q and θ's integrand terms are kept: a line search's accepted trial is asked for
        again with the Jacobian."""
        ep = self.ep
        memo = self._memo
        if memo is None or not np.array_equal(memo[0], lam):
            memo = self._memo = (lam.copy(), *self._values(lam))
        _, q, GQ, dG = memo
        dq = None
        if jacobian:
            dq = np.zeros((len(self.t), ep.q0.size, lam.size))
            dq[:, ep.E] = self.dE
        if jacobian and self.theta:
            N = len(self.t)
            u = self.Phi_g @ lam.reshape(ep.m, ep.size).T
            if dG is None:  # physical models: θ's row and its contraction together
                GQ, Du = ep.cs.quadrature_jacobian(self._gauss_state(lam)[0], u[:, None, :])
                C = ep.C
            else:  # compiled rows: derivatives along the moving joints only (`_C_terms`)
                Du, C = (u[:, None, None, :] @ dG)[:, :, 0, :], ep._C_terms
            D = Du @ C  # (K, nQ, m)
            g = (GQ * self.wg[:, None, None])[..., None] * self.Phi_g[:, None, None, :]
            g += (D * self.wg[:, None, None])[..., None] * self.Psi_g[:, None, None, :]
            g = g.reshape(N, GAUSS, ep.Q.size, -1).sum(axis=1)
            dq[:, ep.Q] = np.cumsum(g, axis=0)
        return q, dq

    def _values(self, lam: np.ndarray):
        """q at the nodes, and θ's integrand row at the Gauss points with its derivatives
        along the joints where the model's rows come compiled (else None)."""
        ep = self.ep
        N, n = len(self.t), ep.q0.size
        q = np.broadcast_to(ep.q0, (N, n)).copy()
        q[:, ep.E] += self.dE @ lam
        if not self.theta:
            return q, None, None
        qg, u = self._gauss_state(lam)  # u: (K, m)
        if hasattr(ep.cs, "quadrature_jacobian"):  # θ's row alone (as quadrature_jacobian's)
            GQ, dG = ep.cs.quadrature_terms(qg, 0)[0], None
        else:
            GQ, dG = ep.cs.quadrature_terms(qg, 1)
        f = (GQ @ u[:, :, None])[..., 0] * self.wg[:, None]  # (K, nQ)
        q[:, ep.Q] += np.cumsum(f.reshape(N, GAUSS, -1).sum(axis=1), axis=0)
        return q, GQ, dG


class NodeMargins:
    """g(z) ≥ 0 at the nodes of every leg of a stacked energy problem, and ∂g/∂z.

    Parameters
    ----------
    problem : planners.stacked.StackedProblem
        The stacked problem (its legs' end-point maps must be quadrature maps).
    system : System
        The model (its `robot` carries the collision geometry).
    constraints : constraints.Constraints
        The resolved [constraints] table.
    """

    def __init__(self, problem, system, constraints, nodes=NODES, cushion=CUSHION, reach=np.inf):
        """`nodes`: a count per leg (equally spaced), or each leg's node times. Clearances
        above `reach` are given a zero derivative (a truncated barrier ignores them)."""
        self.problem, self.c, self.cushion, self.reach = problem, constraints, cushion, reach
        self.robot = getattr(system, "robot", None)
        self.geometric = constraints.geometric and self.robot is not None
        self._geometry = GeometricMargins(self.robot, constraints) if self.geometric else None
        limited = np.isfinite(constraints.lower) | np.isfinite(constraints.upper)
        k = self.robot.n_joints if self.robot is not None else limited.size
        # the quadrature coordinates (θ) are integrated at the nodes for obstacles, and for
        # limits on them (a planar robot's θ; any such coordinate of a custom model)
        limits_quadrature = any(limited[ep.Q].any() for ep in problem.endpoints)
        need_theta = bool(constraints.circles or constraints.boxes or limits_quadrature)
        offsets = problem.offsets
        if isinstance(nodes, int):  # more for fast harmonics: (ω h)² / 8 of their amplitude
            nodes = [
                np.linspace(0.0, ep.duration, max(nodes, _per_phase(ep)))[1:]
                for ep in problem.endpoints
            ]
        self.legs = [
            _Leg(ep, slice(offsets[i], offsets[i + 1]), t, need_theta)
            for i, (ep, t) in enumerate(zip(problem.endpoints, nodes, strict=True))
        ]
        self.need_theta = need_theta
        self.system = system
        self.limited = np.flatnonzero(limited).tolist()
        self.states = tuple(system.states)
        # which coordinates the clearances depend on: the joints; θ too with obstacles
        self.geo_coords = list(range(k + 1 if need_theta else k))
        self.labels: list[tuple[int, str]] = []  # per row: (leg index, what it limits)
        self.times = np.zeros(0)  # per row: the node's time in its leg
        self._last = None  # (z, clearances, kinds) of the last call: the next often repeats z
        self._limit_rows: list[tuple] = []  # (leg, coordinate, sign, first row, rows) of limits
        self._rows_of = None  # (node, pair) of each clearance row, made once
        self._limit_slopes: dict[tuple, np.ndarray] = {}  # `_limit_slope`'s constant rows
        self._dqz_all = None  # the clearance coordinates' dq/dz at every node, if constant

    def refined(self, z: np.ndarray, dense: int) -> NodeMargins | None:
        """These margins with more nodes where `dense` equally spaced samples a leg find less
        than a quarter of the cushion left (between the nodes), or None if they find none."""
        probe = NodeMargins(self.problem, self.system, self.c, dense, self.cushion)
        g = probe(z, jacobian=False)[0]
        low = g < -0.75 * self.cushion  # a quarter of the cushion left
        if not low.any():
            return None
        legs = np.fromiter((leg for leg, _ in probe.labels), int, len(probe.labels))
        nodes = []
        for index, leg in enumerate(self.legs):
            extra = probe.times[low & (legs == index)]
            nodes.append(np.union1d(leg.t, extra))
        return NodeMargins(self.problem, self.system, self.c, nodes, self.cushion, self.reach)

    def __call__(self, z: np.ndarray, jacobian: bool = True):
        """Margins g (M,) and their Jacobian in z (M, nz) (None without `jacobian`); row r
        limits what `labels[r]` says."""
        lam = self.problem.coefficients(z)
        null = self.problem.null
        values, grads, labels, times = [], [], [], []
        label = not self.labels
        configurations, slopes = [], []
        shifts = self.problem.start_shifts(z, jacobian) if self.need_theta else None
        for index, leg in enumerate(self.legs):
            kept = jacobian and leg.dqz is not None  # dq/dz constant: only the joints move
            q, dq = leg.configurations(lam[leg.rows], jacobian and not kept)
            dqz = None
            if jacobian:  # (N, n, nz)
                dqz = leg.dqz if kept else dq @ null[leg.rows]
                if not leg.theta:
                    leg.dqz = dqz
            shift = shifts[index] if leg.theta else None
            if shift is not None:  # θ from where the leg before ends (`StackedProblem`)
                coordinates, offset, slope = shift
                q = q.copy()
                q[:, coordinates] += offset
                if jacobian:
                    dqz = dqz.copy()
                    dqz[:, coordinates] += slope
            configurations.append((q, dqz))
            for i in self.limited:
                if i not in leg.moving:
                    continue  # locked on this leg: its via, checked on loading
                for sign, bound in ((1.0, self.c.lower[i]), (-1.0, self.c.upper[i])):
                    if np.isfinite(bound):
                        values.append(sign * (q[:, i] - bound) - self.cushion)
                        if jacobian:
                            grads.append(self._limit_slope(index, i, sign, dqz))
                        if label:
                            self._limit_rows.append((index, i, sign, len(labels), len(q)))
                            labels += [(index, f"the joint limits of {self.states[i]}")] * len(q)
                            times.append(leg.t)
        if self.geometric:  # every leg in one evaluation, then the differences near contact
            q = np.concatenate([c[0] for c in configurations])
            if self._last is not None and np.array_equal(self._last[0], z):
                g_all, kinds = self._last[1:]  # the line search's trial, now the iterate
            else:
                g_all, kinds = self._geometry(q)
                self._last = (z.copy(), g_all, kinds)
            if jacobian:  # differences at nodes near contact, in coordinates that move there
                slopes = np.zeros((len(self.geo_coords), *g_all.shape))
                near = (g_all < self.reach).any(axis=1)
                where = [np.flatnonzero(near & moves) for moves in self._moving_nodes]
                steps = [
                    q[w] + FD_STEP * np.eye(q.shape[1])[c]
                    for c, w in zip(self.geo_coords, where, strict=True)
                ]
                if sum(len(w) for w in where):
                    moved = self._geometry(np.concatenate(steps))[0]
                    start = 0
                    for k, w in enumerate(where):
                        slopes[k, w] = (moved[start : start + len(w)] - g_all[w]) / FD_STEP
                        start += len(w)
            row = 0
            for index, (qi, dqz) in enumerate(configurations):
                rows = slice(row, row + len(qi))
                row += len(qi)
                values.append(g_all[rows].T.ravel() - self.cushion)
                if label:
                    for kind in kinds:
                        labels += [(index, kind)] * len(qi)
                    times += [self.legs[index].t] * len(kinds)
                if jacobian:  # zero but at the nodes near contact (`slopes`)
                    at = np.flatnonzero(near[rows])
                    dg = np.zeros((g_all.shape[1], len(qi), dqz.shape[-1]))
                    dg[:, at] = np.einsum(
                        "cnp,ncz->pnz", slopes[:, rows][:, at], dqz[at][:, self.geo_coords]
                    )
                    grads.append(dg.reshape(-1, dqz.shape[-1]))
        g = np.concatenate(values) if values else np.zeros(0)
        G = (np.concatenate(grads) if grads else np.zeros((0, z.size))) if jacobian else None
        if label:  # the rows are the same on every call: labelled once
            self.labels, self.times = labels, np.concatenate(times) if times else np.zeros(0)
        if jacobian and self.geometric:  # for `curvature`: each clearance row's node and pair
            first = g.size - g_all.size
            node, pair = self._node_and_pair(g_all.shape[1])
            dqz_all = self._dqz_all
            if dqz_all is None:
                dqz_all = np.concatenate([c[1][:, self.geo_coords] for c in configurations])
                if not any(leg.theta for leg in self.legs):
                    self._dqz_all = dqz_all  # constant as the legs' dq/dz are
            self._curvature_at = (z.copy(), first, node, pair, q, dqz_all, slopes, self._sizes)
        return g, G

    def _limit_slope(self, index: int, i: int, sign: float, dqz: np.ndarray) -> np.ndarray:
        """The gradient rows of coordinate i's limit on leg `index` (kept where constant)."""
        key = (index, i, sign)
        if key in self._limit_slopes:
            return self._limit_slopes[key]
        rows = sign * dqz[:, i]
        if self.legs[index].dqz is not None:
            self._limit_slopes[key] = rows
        return rows

    @cached_property
    def _sizes(self) -> list[int]:
        return [len(leg.t) for leg in self.legs]

    @cached_property
    def _moving_nodes(self) -> list[np.ndarray]:
        """Per clearance coordinate, a mask of the nodes (all legs') of legs it moves on."""
        leg_of = np.repeat(np.arange(len(self.legs)), self._sizes)
        return [
            np.isin(leg_of, [i for i, leg in enumerate(self.legs) if c in leg.moving])
            for c in self.geo_coords
        ]

    def _node_and_pair(self, pairs: int) -> tuple[np.ndarray, np.ndarray]:
        """Each clearance row's node (all legs') and pair of bodies: the rows run leg by
        leg, pair by pair within a leg, node by node within a pair."""
        if self._rows_of is None or self._rows_of[1].size != pairs * sum(self._sizes):
            sizes, offsets = self._sizes, np.cumsum([0, *self._sizes[:-1]])
            node = [
                np.tile(np.arange(o, o + n), pairs) for o, n in zip(offsets, sizes, strict=True)
            ]
            pair = [np.repeat(np.arange(pairs), n) for n in sizes]
            self._rows_of = (np.concatenate(node), np.concatenate(pair))
        return self._rows_of

    def curvature(self, z: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """Σ_r weights[r] ∇²g_r(z) over the rows with a positive weight: the clearances' from
        second differences in the configuration (the joints are affine in z), and through θ
        (obstacles; limits on θ) its own exact curvature at the nodes (`_Leg.theta_hessian`).
        With clearances, needs the last call with the Jacobian to be at z."""
        out = np.zeros((z.size, z.size))
        if weights.size == 0:
            return out
        # per leg and node, the weight of each quadrature coordinate's curvature there
        along = [np.zeros((len(leg.t), leg.ep.Q.size)) for leg in self.legs]
        for index, i, sign, first, n in self._limit_rows:
            leg = self.legs[index]
            if leg.theta and i in leg.ep.Q:
                w = weights[first : first + n]
                along[index][:, list(leg.ep.Q).index(i)] += sign * np.where(w > 0, w, 0.0)
        if self.geometric:
            out += self._clearance_curvature(z, weights, along)
        lam, null = self.problem.coefficients(z), self.problem.null
        for leg, w in zip(self.legs, along, strict=True):
            if leg.theta and np.any(w):
                N = null[leg.rows]
                out += N.T @ leg.theta_hessian(lam[leg.rows], w) @ N
        return out

    def _clearance_curvature(self, z, weights, along) -> np.ndarray:
        """The clearance rows' share of `curvature` in the configuration; their weights on θ's
        curvature at each node (the clearance's slope in θ) are added to `along`."""
        out = np.zeros((z.size, z.size))
        at, first, node, pair, q, dqz, slopes, sizes = self._curvature_at
        if not np.array_equal(at, z):
            raise ValueError("curvature needs the margins' Jacobian at the same z")
        rows = np.flatnonzero(weights[first:] > 0)
        if rows.size == 0:
            return out
        k = len(self.geo_coords)
        h = CURVATURE_STEP
        eye = np.zeros((k, q.shape[1]))
        eye[np.arange(k), self.geo_coords] = h
        i, j = np.triu_indices(k)
        signs = np.array([(1, 1), (1, -1), (-1, 1), (-1, -1)])
        shifts = signs[:, 0, None, None] * eye[i] + signs[:, 1, None, None] * eye[j]  # (4, P, n)
        base = q[node[rows]]  # (A, n)
        points = base[:, None, None, :] + shifts[None]  # (A, 4, P, n)
        values = self._geometry(points.reshape(-1, q.shape[1]))[0]
        values = values.reshape(rows.size, 4, len(i), -1)[np.arange(rows.size), ..., pair[rows]]
        second = (values[:, 0] - values[:, 1] - values[:, 2] + values[:, 3]) / (4 * h * h)
        H = np.zeros((rows.size, k, k))
        H[:, i, j] = second
        H[:, j, i] = second
        D = dqz[node[rows]]  # (A, k, nz)
        w = weights[first:][rows]
        starts = np.cumsum([0, *sizes])
        for index, leg in enumerate(self.legs):  # through θ: its slope, weighted, per node
            if not leg.theta:
                continue
            mine = (node[rows] >= starts[index]) & (node[rows] < starts[index + 1])
            for c, coordinate in enumerate(leg.ep.Q):
                if coordinate in self.geo_coords and mine.any():
                    slope = slopes[self.geo_coords.index(coordinate), node[rows], pair[rows]]
                    at_node = node[rows][mine] - starts[index]
                    np.add.at(along[index][:, c], at_node, (w * slope)[mine])
        return np.einsum("a,akz,akl,aly->zy", w, D, H, D)
