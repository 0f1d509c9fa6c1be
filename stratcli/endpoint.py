"""End-point map `k(λ)` of one leg and its Jacobian `∂k/∂λ` (paper eq. 15, 19).

Two evaluators with one interface:

* `QuadratureEndpoint`: when every non-constant row of `G` depends only on constant-row
  (explicit) coordinates, as for all space manipulators (`A` does not depend on `θ`), the
  explicit coordinates are closed-form integrals of the Fourier controls and the others are
  a single Gauss–Legendre quadrature; the Jacobian is a second quadrature using `∂G/∂q`.
* `OdeEndpoint`: the general path, state plus sensitivity (variational equation, eq. 16-17)
  integrated with an adaptive 8th-order Runge–Kutta method.

Coefficients are a flat vector laid out as `(m_active, 2H+1)`, row `a` for active input `a`.
"""

from __future__ import annotations

from functools import cached_property, lru_cache

import numpy as np

from .controls import FourierBasis
from .errors import Problem
from .models.compiled_stratum import CompiledStratum
from .models.system import System

PANEL = 32  # Gauss–Legendre nodes per panel of the composite rule
MIN_NODES = 64
MAX_NODES = 1 << 15  # controls this large are wrong anyway; keep memory bounded


@lru_cache(maxsize=128)
def gauss_legendre(nodes: int, duration: float) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss–Legendre rule on [0, duration] with `nodes` (a multiple of PANEL)."""
    x, w = np.polynomial.legendre.leggauss(PANEL)
    panels = nodes // PANEL
    h = duration / panels
    left = h * np.arange(panels)
    t = (left[:, None] + 0.5 * h * (x + 1.0)).ravel()
    weights = np.tile(0.5 * h * w, panels)
    t.setflags(write=False)
    weights.setflags(write=False)
    return t, weights


def node_count(coefficients: np.ndarray, duration: float, basis: FourierBasis) -> int:
    """Nodes needed for ~1e-12 accuracy: the integrand oscillates with the joint speed.

    A fixed rule is not enough: at |λ| ≈ 20 a 64-node rule was 2e-3 rad off.
    The speed bound is Σ_k max|u_k| sampled on a fine grid (the coefficients themselves can
    be large and cancel: the basis is far from orthogonal on a leg shorter than its period).
    """
    u = _speed_grid(basis, float(duration)) @ np.atleast_2d(coefficients).T
    return _nodes_for_speed(float(np.abs(u).sum(axis=1).max()), float(duration), basis)


def _nodes_for_speed(peak: float, duration: float, basis: FourierBasis) -> int:
    """`node_count` for controls whose Σ_k |u_k| peaks at `peak` on the grid."""
    speed = 1.1 * peak
    wiggles = duration * (4.0 * speed + 4.0 * basis.omega[-1] if basis.harmonics else speed)
    need = min(max(MIN_NODES, int(np.ceil(wiggles))), MAX_NODES)
    return PANEL * int(np.ceil(need / PANEL))


@lru_cache(maxsize=256)
def _quadrature_tables(basis: FourierBasis, duration: float, K: int) -> tuple:
    """(t, w, Φ, Ψ, [wΦ; wΨ]) of the K-node rule on [0, duration], shared by every end point
    with this basis and duration (a plan makes many: each Newton attempt, each start)."""
    t, w = gauss_legendre(K, duration)
    Phi, Psi = basis.values(t), basis.integrals(t)
    out = (t, w, Phi, Psi, np.concatenate([w[:, None] * Phi, w[:, None] * Psi]))
    for a in out:
        a.setflags(write=False)
    return out


def pair_products(w: np.ndarray, Phi: np.ndarray, Psi: np.ndarray) -> np.ndarray:
    """[w Φ⊗Ψ; w Ψ⊗Ψ] at K nodes, (2K, size²): the quadrature of basis pairs that
    `QuadratureEndpoint.integrand_hessian` takes."""
    B = np.concatenate([Phi[:, :, None] * Psi[:, None, :], Psi[:, :, None] * Psi[:, None, :]])
    return np.tile(w, 2)[:, None] * B.reshape(2 * len(w), -1)


@lru_cache(maxsize=64)
def _pair_products(basis: FourierBasis, duration: float, K: int) -> np.ndarray:
    """`pair_products` of the K-node rule, shared like `_quadrature_tables`."""
    _, w, Phi, Psi, _ = _quadrature_tables(basis, duration, K)
    out = pair_products(w, Phi, Psi)
    out.setflags(write=False)
    return out


@lru_cache(maxsize=64)
def _speed_grid(basis: FourierBasis, duration: float) -> np.ndarray:
    return basis.values(np.linspace(0.0, duration, 97))


class _Endpoint:
    kind = ""

    def __init__(self, cs: CompiledStratum, q0: np.ndarray, basis: FourierBasis, duration: float):
        self.cs = cs
        self.q0 = np.asarray(q0, dtype=float)
        self.basis = basis
        self.duration = float(duration)
        self.m = len(cs.stratum.active)
        self.size = basis.size

    @property
    def n_coefficients(self) -> int:
        return self.m * self.size

    def __call__(self, lam: np.ndarray, jacobian: bool = True):
        raise NotImplementedError


def _selection(C: np.ndarray):
    """Column a of C as an index when C only selects (q_j' = u_j, every manipulator: products
    with C are then gathers), else None; None too when the gather would be the identity."""
    selects = C.size and np.all((C == 0.0) | (C == 1.0)) and np.all(C.sum(axis=0) == 1.0)
    if not selects:
        return None
    index = C.argmax(axis=0)
    identity = C.shape[0] == C.shape[1] and np.array_equal(index, np.arange(C.shape[1]))
    return slice(None) if identity else index


def _apply(D: np.ndarray, C: np.ndarray, select) -> np.ndarray:
    """`D @ C` over the last axis of D, a gather when C only selects (`_selection`)."""
    return D @ C if select is None else D[..., select]


def _layout(cs) -> tuple:
    """(E, Q, C, C's selection, C_terms, its selection) of a stratum, kept on it: every Newton
    attempt and every start makes end points of the same strata.

    C_terms: the rows of C the compiled rows differentiate along (`derivatives_along`, the
    explicit coordinates that move); closed-form physical connections along all of them."""
    layout = cs.__dict__.get("_endpoint_layout")
    if layout is None:
        C = cs.C_explicit
        along = getattr(cs, "derivatives_along", None)
        C_terms = C if along is None else C[list(along)]
        E, Q = np.array(cs.explicit, dtype=int), np.array(cs.quadrature, dtype=int)
        for a in (E, Q):
            a.setflags(write=False)
        layout = (E, Q, C, _selection(C), C_terms, _selection(C_terms))
        cs.__dict__["_endpoint_layout"] = layout
    return layout


class QuadratureEndpoint(_Endpoint):
    """Closed-form joints plus one quadrature for the rest; exact Jacobian by quadrature."""

    kind = "quadrature"

    def __init__(self, cs, q0, basis, duration):
        if not cs.supports_quadrature:
            raise ValueError(f"stratum {cs.stratum.name} does not allow the quadrature path")
        super().__init__(cs, q0, basis, duration)
        self.E, self.Q, self.C, self._select, self._C_terms, self._select_terms = _layout(cs)
        self.psi_T = basis.integrals(self.duration)
        self._tables: dict[int, tuple] = {}
        self._pair_tables: dict[int, np.ndarray] = {}
        self._grid = _speed_grid(basis, self.duration)  # node_count's, looked up once

    def _table(self, K: int):
        """The rule (t, w), the basis values Φ and integrals Ψ at t, and [wΦ; wΨ] (the
        Jacobian's quadrature in one product) for K nodes."""
        if K not in self._tables:
            self._tables[K] = _quadrature_tables(self.basis, self.duration, K)
        return self._tables[K]

    def _nodes(self, lam: np.ndarray):
        """Coefficients (m, size), the quadrature rule and its tables, and the controls u and
        configurations q at the nodes (explicit coordinates in closed form)."""
        L = np.asarray(lam, dtype=float).reshape(self.m, self.size)
        peak = float(np.abs(self._grid @ L.T).sum(axis=1).max())  # node_count, inlined
        t, w, Phi, Psi, _ = self._table(_nodes_for_speed(peak, self.duration, self.basis))
        q = np.empty((t.size, self.q0.size))
        q[:, self.E] = self.q0[self.E] + Psi @ (L.T @ self.C.T)
        q[:, self.Q] = self.q0[self.Q]
        return L, w, Phi, Psi, Phi @ L.T, q

    def __call__(self, lam: np.ndarray, jacobian: bool = True):
        L, w, _, _, u, q = self._nodes(lam)
        end = self.q0.copy()
        end[self.E] += self.C @ (L @ self.psi_T)
        if self.Q.size == 0:
            return (end, self._J_explicit.copy()) if jacobian else (end, None)
        if jacobian and hasattr(self.cs, "quadrature_jacobian"):  # physical models
            GQ, Du = self.cs.quadrature_jacobian(q, u[:, None, :])  # Du: (K, nQ, nE)
            D = _apply(Du, self.C, self._select)  # (K, nQ, m)
        else:
            terms = self.cs.quadrature_terms(q, 1 if jacobian else 0)
            GQ = terms[0]  # (K, nQ, m)
            if jacobian:
                Du = np.einsum("km,kimd->kid", u, terms[1])  # Σ_a u_a ∂G_ia/∂q_d
                D = _apply(Du, self._C_terms, self._select_terms)
        end[self.Q] += w @ (GQ @ u[:, :, None])[..., 0]
        if not jacobian:
            return end, None
        J = self._J_explicit.copy()
        # ∂(G u)/∂λ: directly through u (basis values Φ) and through q_E (basis integrals Ψ),
        # both quadratures in one product with [wΦ; wΨ]
        K = w.size
        JQ = np.concatenate([GQ.reshape(K, -1), D.reshape(K, -1)]).T @ self._tables[K][4]
        J[self.Q] = JQ.reshape(self.Q.size, -1)  # (nQ, m * size)
        return end, J

    def hessian(self, lam: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """`Σ_i weights_i ∇²k_i(λ)` (p x p): exact second derivatives of the end point.

        Explicit coordinates are linear in λ; a quadrature row's integrand `G_Q(q_E(t)) u(t)`
        is bilinear in (q_E, u) to first order, so its Hessian needs ∂G_Q/∂q_E and ∂²G_Q/∂q_E².
        """
        p = self.n_coefficients
        omega = np.asarray(weights, dtype=float)[self.Q]
        if self.Q.size == 0 or not np.any(omega):
            return np.zeros((p, p))
        _, w, _, _, u, q = self._nodes(lam)
        return self.integrand_hessian(q, u, omega, self._products(w.size))

    def integrand_hessian(self, q, u, omega, products) -> np.ndarray:
        """`Σ_k Σ_i ω_ki ∇²(G_i(q_E) u)(t_k)` in λ, quadrature weights in `products`
        ([w Φ⊗Ψ; w Ψ⊗Ψ] at the K nodes, `_pair_products`) and `omega` (nQ,) or per node
        (K, nQ): the end point's Hessian (`hessian`), or a weighted sum of the quadrature
        coordinates' Hessians at times inside the leg (`node_margins`: θ at the nodes)."""
        K, m, s = len(q), self.m, self.size
        per_node = omega.ndim == 2
        u_weighted = (omega[:, :, None] if per_node else omega[None, :, None]) * u[:, None, :]

        def weigh(A):  # Σ_i ω_i A[k, i, ...]
            A = A.reshape(K, omega.shape[-1], -1)
            return np.einsum("ki,kix->kx", omega, A) if per_node else omega @ A

        if hasattr(self.cs, "quadrature_hessian"):  # the contraction only (physical models)
            dGQ, D2 = self.cs.quadrature_hessian(q, u_weighted)
            C, sel = self.C, self._select
        else:
            _, dGQ, ddGQ = self.cs.quadrature_terms(q, 2)
            nd = dGQ.shape[-1]  # the coordinates it differentiates along
            D2 = u[:, None, :] @ weigh(ddGQ).reshape(K, m, nd * nd)
            C, sel = self._C_terms, self._select_terms
        nE = dGQ.shape[-1]
        D1 = weigh(dGQ).reshape(K, m, nE)  # Σ_i ω_i ∂G_i/∂q
        D2 = D2.reshape(K, nE, nE)
        # W1: ∂G_a/∂q · ∂q/∂λ_a', W2: C'ᵀ ∂²G C', both (K, m, m)
        if sel is None:
            W1, W2 = D1 @ C, C.T @ D2 @ C
        elif isinstance(sel, slice):
            W1, W2 = D1, D2
        else:
            W1, W2 = D1[..., sel], D2[:, sel[:, None], sel[None, :]]
        # H[a,b,c,d] = Σ_k w_k (W1[k,a,c] Φ[k,b] Ψ[k,d] (+ transpose) + W2[k,a,c] Ψ[k,b] Ψ[k,d]):
        # one product (m², 2K) @ (2K, s²), which is cheaper than forming (K, m, s, m) arrays
        W = np.concatenate([W1, 0.5 * W2]).reshape(2 * K, m * m)
        H = (W.T @ products).reshape(m, m, s, s).transpose(0, 2, 1, 3)
        H = H + H.transpose(2, 3, 0, 1)
        return H.reshape(m * s, m * s)

    def _products(self, K: int) -> np.ndarray:
        """[w Φ⊗Ψ; w Ψ⊗Ψ] at K nodes, (2K, size²): the Hessian's quadrature of basis pairs."""
        if K not in self._pair_tables:
            self._pair_tables[K] = _pair_products(self.basis, self.duration, K)
        return self._pair_tables[K]

    @cached_property
    def _J_explicit(self) -> np.ndarray:
        J = np.zeros((self.q0.size, self.n_coefficients))
        J[self.E] = np.einsum("ea,b->eab", self.C, self.psi_T).reshape(self.E.size, -1)
        J.setflags(write=False)
        return J


class _OutOfBudget(Exception):
    """The integration needed more evaluations than `OdeEndpoint.max_evaluations`."""


class OdeEndpoint(_Endpoint):
    """General path: integrate `q' = G(q)u` and `S' = ∂(Gu)/∂q S + G ∂u/∂λ` (eq. 16-17).

    The work of one call is bounded: an integration that needs more than `max_evaluations`
    evaluations of the right-hand side, or more than `growth` times what the last finished
    call needed (a trial step into a stiff region, huge controls), or once the map has spent
    `max_total` evaluations over all its calls (a search that can only grind), or that fails,
    returns
    NaN, which the planners treat as a step that does not reach the goal (it is rejected,
    and a leg that never gets a finite end point fails with a numerical-failure status).
    """

    kind = "ode"
    rtol = 1e-12
    atol = 1e-12
    max_evaluations = 20_000  # DOP853 takes 12 per step; the biped's legs need at most ~300
    growth = 20  # a call may take at most this many times the evaluations of the last good one
    max_total = 400_000  # all calls of one end-point map (one leg): then every call is NaN
    _last = 0  # evaluations of the last call that finished (per end-point map: per leg)
    _spent = 0  # evaluations of all its calls so far

    def __call__(self, lam: np.ndarray, jacobian: bool = True):
        L = np.asarray(lam, dtype=float).reshape(self.m, self.size)
        n, p = self.q0.size, self.n_coefficients
        G, dG, basis = self.cs.G, self.cs.dG, self.basis

        calls = 0
        budget = min(self.max_evaluations, self.max_total - self._spent)
        if self._last:  # after a finished call: a trial step may not cost far more
            budget = min(budget, max(2_000, self.growth * self._last))

        def rhs(t, y):
            nonlocal calls
            calls += 1
            if calls > budget:
                raise _OutOfBudget
            q = y[:n]
            phi = basis.values(t)
            u = L @ phi
            Gq = G(q)
            dq = Gq @ u
            if not jacobian:
                return dq
            S = y[n:].reshape(n, p)
            A = np.einsum("iaj,a->ij", dG(q), u)
            dS = A @ S + np.einsum("ia,b->iab", Gq, phi).reshape(n, p)
            return np.concatenate([dq, dS.ravel()])

        y0 = np.concatenate([self.q0, np.zeros(n * p)]) if jacobian else self.q0
        from scipy.integrate import solve_ivp  # here: models with a quadrature path never need it

        try:
            sol = solve_ivp(
                rhs, (0.0, self.duration), y0, method="DOP853", rtol=self.rtol, atol=self.atol
            )
            ok = sol.success
        except _OutOfBudget:
            ok = False
        self._spent += calls
        if ok:
            self._last = calls
        y = sol.y[:, -1] if ok else np.full(y0.size, np.nan)
        return (y[:n], y[n:].reshape(n, p)) if jacobian else (y[:n], None)


def evaluator_problems(system: System, evaluator: str, strata) -> list[Problem]:
    """Why `planner.evaluator` cannot be used on these strata of `system`, so that what is
    asked is what runs: "magnus" only on URDF models (their attitude on SO(3)), "quadrature"
    not on them and only where the structure allows it ("auto" and "ode" run anywhere)."""
    urdf = getattr(system, "spatial", None) is not None
    if evaluator == "magnus" and not urdf:
        return [
            Problem(
                "planner.evaluator",
                "'magnus' is the evaluator of URDF models (their attitude on SO(3)); on "
                "this model use 'auto', 'quadrature' or 'ode'",
            )
        ]
    if evaluator == "quadrature" and urdf:
        return [
            Problem(
                "planner.evaluator",
                "a URDF model has no quadrature path: its attitude is integrated on SO(3) by "
                "the Magnus method; use 'auto' or 'magnus' (or 'ode', much slower)",
            )
        ]
    if evaluator != "quadrature":
        return []
    return [
        Problem(
            "planner.evaluator",
            f"stratum {name} does not allow the quadrature path (a non-constant row depends "
            "on a non-explicit coordinate); use 'auto' or 'ode'",
        )
        for name in dict.fromkeys(strata)
        if not system.compiled(name).supports_quadrature
    ]


def make_endpoint(
    cs: CompiledStratum,
    q0,
    basis: FourierBasis,
    duration: float,
    evaluator: str = "auto",
    tolerance: float | None = None,
) -> _Endpoint:
    """The quadrature path when the structure allows it (or when asked), else the ODE path.

    A stratum with an end-point map of its own (`endpoint`: spatial models, whose attitude is
    integrated on SO(3) by the Magnus method) uses it unless the ODE path is asked for, as
    accurate as the leg's `tolerance` needs (`MagnusEndpoint.for_tolerance`);
    `evaluator_problems` refuses "quadrature" on them and "magnus" elsewhere."""
    own = getattr(cs, "endpoint", None)
    if own is not None and evaluator != "ode":
        ep = own(q0, basis, duration)
        if tolerance is not None and hasattr(ep, "for_tolerance"):
            ep.for_tolerance(tolerance)
        return ep
    if evaluator == "ode" or (evaluator == "auto" and not cs.supports_quadrature):
        return OdeEndpoint(cs, q0, basis, duration)
    return QuadratureEndpoint(cs, q0, basis, duration)
