"""End point and Jacobian of a spatial leg: joints in closed form, the attitude on SO(3).

The joints are closed-form integrals of the Fourier controls (`q(t) = q0 + C Ψ(t) λ`); the
base attitude obeys `Ṙ = R [ξ]×` with the body-frame rate `ξ = S_ω(q) u`, and is
integrated with the 4th-order Magnus method with two Gauss points per step::

    Ω_k = h/2 (ξ1 + ξ2) + (√3 h²/12) ξ1 × ξ2,     R_{k+1} = R_k exp([Ω_k]×).

The Jacobian is the exact derivative of that discrete map, a weighted sum over the nodes
(the quadrature structure, no variational ODE): with `R = R̄ exp([η]×)`,
`η_{k+1} = exp(−Ω_k) η_k + J_r(Ω_k) δΩ_k`, so `η_N = Σ_k R_Nᵀ R_{k+1} J_r(Ω_k) δΩ_k`, and
`δξ = S_ω δu + ∂(S_ω u)/∂q δq` at every node. The plan's coordinates carry the attitude as
the rotation vector `φ = log(R_N)`, whose derivative is `J_r⁻¹(φ) η_N`.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from . import so3
from .controls import FourierBasis
from .endpoint import _Endpoint, _speed_grid

__all__ = ["MagnusEndpoint", "attitude_path", "residual_on_group"]

SQRT3 = np.sqrt(3.0)
MIN_STEPS = 16
# Steps per radian of `T (max Σ|u| + ω_eff)`, the phase the attitude rate's fastest terms run
# through in a leg: the joints turn at Σ|u|, the controls oscillate at up to ω_H, weighted by
# their amplitudes (`_effective_frequency`: the error follows the rate's 4th derivative). The
# error falls 16x per halving; 14 keeps it below 5e-10 rad on legs with joint speeds of several
# rad/s (tests/test_magnus.py) and far below on calmer ones.
STEPS_PER_RADIAN = 14.0
ACCURACY = 5e-10  # rad: the Magnus error on the full steps (tests/test_magnus.py)
# Far from the goal the map is evaluated to 1e-5 of the last goal error (a Newton step
# usually divides it by far more than 10), and the result kept if its accuracy is within
# RELATIVE_ACCURACY of the goal error it finds.
TOLERANCE_SHARE = 0.1  # of a leg's tolerance the map's error may take (`for_tolerance`)
AIM_ACCURACY = 1e-5
RELATIVE_ACCURACY = 1e-3
COUPLING_REFERENCE = 0.6  # |S_ω| of the golden arm (robots/arm3.urdf), where it is calibrated


def _effective_frequency(L: np.ndarray, basis: FourierBasis) -> float:
    """`(Σ A_h ω_h⁴ / Σ A)^¼` over the harmonics' amplitudes `A_h` of every input (the
    constant terms count in the denominator): ω_H for wild controls, 0 for constant ones."""
    H = basis.harmonics
    amplitude = np.hypot(L[:, 1 : 1 + H], L[:, 1 + H :])  # (m, H)
    total = float(np.abs(L[:, 0]).sum() + amplitude.sum())
    if not total > 0:
        return 0.0
    return float((amplitude.sum(axis=0) @ basis.omega**4 / total) ** 0.25)


class _March:
    """One attitude march: the nodes' rates and the steps' rotations; the momentum
    derivatives `D` at the nodes and the Jacobian `J` are added on demand."""

    def __init__(self, h, Phi, Psi, S_w, x1, x2, Omega, R, pending):
        self.h, self.Phi, self.Psi, self.S_w = h, Phi, Psi, S_w
        self.x1, self.x2, self.Omega, self.R = x1, x2, Omega, R
        self._pending = pending  # (robot, its state at the nodes, S, joint rates)
        self._D = None
        self.J = None

    @property
    def D(self) -> np.ndarray:
        if self._D is None:
            robot, state, S, u = self._pending
            self._D = robot.angular_derivative(state, S, u)
        return self._D

    def parts(self):
        """(h, Φ, Ψ, S_ω at the nodes, D at the nodes, ξ1, ξ2, Ω, R_0..R_N)."""
        return (self.h, self.Phi, self.Psi, self.S_w, self.D, self.x1, self.x2, self.Omega, self.R)


def _prefix_products(R0: np.ndarray, E: np.ndarray) -> np.ndarray:
    """`R_0, R_0 E_0, R_0 E_0 E_1, ...` (N + 1, 3, 3): the attitudes at the step boundaries,
    by a parallel prefix scan (⌈log₂ N⌉ stacked products instead of N small ones in Python;
    the same products, associated differently: rounding apart, the same matrices)."""
    P = np.array(E, dtype=float)
    shift = 1
    while shift < P.shape[0]:
        P[shift:] = P[:-shift] @ P[shift:]
        shift *= 2
    R = np.empty((P.shape[0] + 1, 3, 3))
    R[0] = R0
    np.matmul(R0, P, out=R[1:])
    return R


class MagnusEndpoint(_Endpoint):
    """`k(λ)` and `∂k/∂λ` of a spatial leg; `kind = "magnus"`. Interface of `endpoint`'s."""

    kind = "magnus"

    def __init__(self, cs, q0: np.ndarray, basis: FourierBasis, duration: float):
        super().__init__(cs, q0, basis, duration)
        self.k = cs.k
        self.C = cs.C_explicit
        # as a quadrature map's layout (`node_margins`): the joints are the explicit
        # coordinates, closed-form integrals of the controls; the attitude is not in Q
        self.E, self.Q = np.arange(self.k), np.zeros(0, dtype=int)
        self.act = cs.act
        self.robot = cs.system.spatial
        self.psi_T = basis.integrals(self.duration)
        self._tables: dict[int, tuple] = {}
        self.steps_override: int | None = None  # tests: a fixed number of steps
        self._aim: tuple[np.ndarray, np.ndarray] | None = None  # goal values, targets
        self._error = np.inf  # the goal error of the last evaluation
        self._full: tuple | None = None  # ((λ, steps), end) of the last full-step evaluation
        self._marches: dict[tuple, tuple[np.ndarray, _March]] = {}  # (λ, steps): (end, march)
        self._last: dict[bytes, tuple] = {}  # λ: (end, march) of the last two evaluations
        # set by a search that needs less (`sqp.Descent` far from a minimum): every evaluation
        # on the steps that reach this accuracy (rad), not only those far from the goal
        self.accuracy: float | None = None
        self.full_accuracy = ACCURACY  # rad, of the full steps (`for_tolerance`)

    @cached_property
    def coupling(self) -> float:
        """Spectral norm of the active columns of `S_ω` at the start (one Pinocchio call)."""
        S, _ = self.robot.angular(self.q0[None, : self.k])
        return float(np.linalg.norm(S[0][:, self.act], 2)) if self.act.size else 0.0

    def steps(self, L: np.ndarray) -> int:
        """Magnus steps: `STEPS_PER_RADIAN` per radian of `T (max Σ|u| + ω_eff)`."""
        if self.steps_override:
            return self.steps_override
        u = _speed_grid(self.basis, self.duration) @ L.T
        speed = float(np.abs(u).sum(axis=1).max()) if u.size else 0.0
        phase = self.duration * (speed + _effective_frequency(L, self.basis))
        # the error also grows with the rate itself (∝ speed): fast legs get (speed/4)^¼ more;
        # and as the square of the coupling |S_ω| (the error terms are commutators of rates):
        # a bus heavy against its arm needs fewer steps than the golden arm (|S_ω| ≈ 0.6)
        phase *= max(1.0, (1.0 + speed) / 5.0) ** 0.25
        phase *= min(max(np.sqrt(self.coupling / COUPLING_REFERENCE), 0.5), 2.0)
        phase *= (ACCURACY / self.full_accuracy) ** 0.25  # a tighter tolerance: more steps
        if not np.isfinite(phase):
            return MIN_STEPS
        return int(min(max(MIN_STEPS, np.ceil(STEPS_PER_RADIAN * phase)), 1 << 14))

    def _table(self, N: int):
        if N not in self._tables:
            h = self.duration / N
            left = h * np.arange(N)
            t = (left[:, None] + h * (0.5 + np.array([-1.0, 1.0]) * SQRT3 / 6)).ravel()
            self._tables[N] = (h, t, self.basis.values(t), self.basis.integrals(t))
        return self._tables[N]

    def _march(self, L: np.ndarray, jacobian: bool, steps: int | None = None) -> _March:
        """The attitude march on `steps` (default: the full ones); with `jacobian` the
        momentum derivatives at the nodes come with it, else `_March.D` adds them later."""
        h, _, Phi, Psi = self._table(self.steps(L) if steps is None else steps)
        u = Phi @ L.T  # (2N, m)
        q = self.q0[: self.k] + Psi @ (L.T @ self.C.T)  # (2N, k)
        S, state = self.robot.angular_map(q)
        S_w = S[:, :, self.act]  # (2N, 3, m)
        xi = (S_w @ u[:, :, None])[:, :, 0]
        x1, x2 = xi[0::2], xi[1::2]
        Omega = 0.5 * h * (x1 + x2) + (SQRT3 * h * h / 12.0) * so3.cross(x1, x2)
        R = _prefix_products(so3.exp(self.q0[self.k :]), so3.exp(Omega))
        march = _March(h, Phi, Psi, S_w, x1, x2, Omega, R, (self.robot, state, S, u @ self.C.T))
        if jacobian:
            march.D  # noqa: B018 (computed now, as the caller asked)
        return march

    def __call__(self, lam: np.ndarray, jacobian: bool = True):
        """End point and (with `jacobian`) its Jacobian; far from the goal on coarser steps.

        Once a goal is known (`residual` was called), the map is evaluated on fewer steps
        when the last goal error was large: to an accuracy of `AIM_ACCURACY` × that error
        (the Magnus error falls as N⁻⁴), kept only if it is below `RELATIVE_ACCURACY` × the
        error it then finds, else evaluated again on the full steps. Near the goal every
        evaluation is on the full steps, unless a search set a looser `accuracy` (then every
        evaluation is on the steps that reach it); `refined` gives the full-step end of any λ.
        The Jacobian is added only to the evaluation that is kept (`jacobian_of_last` adds
        it later); the last two marches are remembered (a map asked again at the same λ and
        steps, e.g. for its Jacobian after its value, is not integrated again).
        """
        L = np.asarray(lam, dtype=float).reshape(self.m, self.size)
        if not np.all(np.isfinite(L)):
            end = np.full(self.q0.size, np.nan)
            return end, (np.full((end.size, self.n_coefficients), np.nan) if jacobian else None)
        full = self.steps(L)
        if (
            self.accuracy is not None
            and self.accuracy > self.full_accuracy
            and not self.steps_override
        ):
            steps = int(np.ceil(full * (self.full_accuracy / self.accuracy) ** 0.25))
            if max(MIN_STEPS, steps) < full:
                end, march = self._end(L, max(MIN_STEPS, steps))
                self._remember(L, end, march)
                return end.copy(), (self._jacobian(end, march) if jacobian else None)
        coarse = self._coarse_steps(full)
        if coarse < full:
            end, march = self._end(L, coarse)
            error = np.linalg.norm(residual_on_group(end, None, *self._aim, self.k)[0])
            if RELATIVE_ACCURACY * error >= self.full_accuracy * (full / coarse) ** 4:
                self._remember(L, end, march)
                return end.copy(), (self._jacobian(end, march) if jacobian else None)
        end, march = self._end(L, full)
        self._full = ((L.tobytes(), full), end.copy())
        self._remember(L, end, march)
        return end.copy(), (self._jacobian(end, march) if jacobian else None)

    def for_tolerance(self, tolerance: float) -> None:
        """Full steps that keep the map's error a tenth of the leg's `tolerance` where that is
        below `ACCURACY` (the Magnus error falls as N⁻⁴): at 1e-10 a plan reported its legs
        within it, measured on a map 3e-10 off (an independent integration's finding)."""
        self.full_accuracy = min(ACCURACY, TOLERANCE_SHARE * float(tolerance))

    def jacobian_of_last(self, lam: np.ndarray):
        """End point and Jacobian of the last evaluation (`__call__`) at `lam` (one of the
        last two), on the steps it used, the Jacobian added now; else a new evaluation."""
        L = np.asarray(lam, dtype=float).reshape(self.m, self.size)
        last = self._last.get(L.tobytes())
        if last is not None:
            return last[0].copy(), self._jacobian(*last)
        return self(lam, True)

    def _remember(self, L: np.ndarray, end: np.ndarray, march: _March) -> None:
        key = L.tobytes()
        self._last.pop(key, None)
        if len(self._last) >= 2:
            del self._last[next(iter(self._last))]
        self._last[key] = (end, march)

    def _coarse_steps(self, full: int) -> int:
        if self._aim is None or self.steps_override or not np.isfinite(self._error):
            return full
        wanted = max(self.full_accuracy, AIM_ACCURACY * self._error)
        coarse = int(np.ceil(full * (self.full_accuracy / wanted) ** 0.25))
        return max(MIN_STEPS, coarse) if coarse < 0.8 * full else full

    def refined(self, lam: np.ndarray) -> np.ndarray:
        """The end point on the full steps (what a plan records)."""
        L = np.asarray(lam, dtype=float).reshape(self.m, self.size)
        if not np.all(np.isfinite(L)):
            return np.full(self.q0.size, np.nan)
        steps = self.steps(L)
        if self._full is not None and self._full[0] == (L.tobytes(), steps):
            return self._full[1].copy()  # its last evaluation was this one, on the full steps
        return self._end(L, steps)[0].copy()

    def _end(self, L: np.ndarray, steps: int) -> tuple[np.ndarray, _March]:
        """The end point on `steps` and its march (remembered: the last two)."""
        key = (L.tobytes(), steps)
        if key in self._marches:
            return self._marches[key]
        k = self.k
        end = self.q0.copy()
        end[:k] += self.C @ (L @ self.psi_T)
        march = self._march(L, False, steps)
        end[k:] = so3.log(march.R[-1])
        end.setflags(write=False)
        if len(self._marches) >= 2:
            del self._marches[next(iter(self._marches))]
        self._marches[key] = (end, march)
        return end, march

    def _jacobian(self, end: np.ndarray, march: _March) -> np.ndarray:
        """`∂k/∂λ` of the end `end` of `march` (the exact derivative of the discrete map)."""
        if march.J is None:
            k = self.k
            h, Phi, Psi, S_w, D, x1, x2, Omega, R = march.parts()
            c = SQRT3 * h * h / 12.0
            W = np.swapaxes(R[-1], -1, -2) @ R[1:] @ so3.right_jacobian(Omega)  # (N, 3, 3)
            M = np.empty((2 * W.shape[0], 3, 3))
            M[0::2] = W @ (0.5 * h * np.eye(3) - c * so3.hat(x2))
            M[1::2] = W @ (0.5 * h * np.eye(3) + c * so3.hat(x1))
            A1 = M @ S_w  # (2N, 3, m): through u
            A2 = M @ (D @ self.C)  # (2N, 3, m): through q
            K = M.shape[0]
            eta = A1.reshape(K, -1).T @ Phi + A2.reshape(K, -1).T @ Psi  # (3 * m, size)
            J = np.array(self._J_explicit)
            J[k:] = so3.right_jacobian_inverse(end[k:]) @ eta.reshape(3, -1)
            J.setflags(write=False)
            march.J = J
        return march.J.copy()

    def residual(self, end, J, aim, targets):
        """`residual_on_group` for this leg's coordinates; remembers the goal and the error
        (they set the accuracy of the next evaluation)."""
        r, Jt = residual_on_group(end, J, aim, targets, self.k)
        self._aim = (np.array(aim, dtype=float), np.array(targets, dtype=int))
        self._error = float(np.linalg.norm(r))
        return r, Jt

    def attitudes(self, lam: np.ndarray) -> np.ndarray:
        """R at the step boundaries (N + 1, 3, 3) for coefficients λ."""
        L = np.asarray(lam, dtype=float).reshape(self.m, self.size)
        return self._march(L, False).R

    @cached_property
    def _J_explicit(self) -> np.ndarray:
        J = np.zeros((self.q0.size, self.n_coefficients))
        J[: self.k] = np.einsum("ea,b->eab", self.C, self.psi_T).reshape(self.k, -1)
        J.setflags(write=False)
        return J


def attitude_path(cs, q0, basis: FourierBasis, duration: float, lam, tau: np.ndarray):
    """Joints (len(tau), k) and attitudes (len(tau), 3, 3) at leg-local times `tau`, by the
    Magnus map on each prefix [0, τ] (records and audits)."""
    out_q, out_R = [], []
    for t in np.asarray(tau, dtype=float):
        if t <= 0:
            out_q.append(np.asarray(q0, dtype=float)[: cs.k])
            out_R.append(so3.exp(np.asarray(q0, dtype=float)[cs.k :]))
            continue
        ep = MagnusEndpoint(cs, q0, basis, t)
        L = np.asarray(lam, dtype=float).reshape(ep.m, ep.size)
        out_q.append(np.asarray(q0, dtype=float)[: cs.k] + cs.C_explicit @ (L @ basis.integrals(t)))
        out_R.append(ep.attitudes(lam)[-1])
    return np.array(out_q), np.array(out_R)


def residual_on_group(end, J, aim, targets, k: int):
    """End minus goal on the targeted coordinates, the attitude's as `log(R_goalᵀ R(T))`.

    `aim` holds the goal's values of `targets`; the attitude (coordinates k, k+1, k+2) is
    measured on the group when all three are targeted, else (a partly free attitude)
    coordinate-wise. The Jacobian rows follow: `J_r⁻¹(e) J_r(φ) ∂φ/∂λ`.
    """
    targets = np.asarray(targets, dtype=int)
    r = end[targets] - aim
    Jt = None if J is None else J[targets]
    rows = np.flatnonzero(targets >= k)
    if rows.size != 3:
        return r, Jt
    phi, goal = end[k:], aim[rows]
    e = so3.log(so3.exp(goal).T @ so3.exp(phi))
    r = r.copy()
    r[rows] = e
    if Jt is not None:
        Jt = Jt.copy()
        Jt[rows] = so3.right_jacobian_inverse(e) @ so3.right_jacobian(phi) @ Jt[rows]
    return r, Jt
