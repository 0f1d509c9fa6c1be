"""Lie brackets, the Philip Hall basis and the iterated integrals of Fourier controls (§4.2).

Conventions (one place for all signs):

* Lie bracket of vector fields `[f, g] = (∂g/∂q) f − (∂f/∂q) g`. With it, the commutator of
  Lie derivatives is `L_f L_g − L_g L_f = L_[f,g]`, so the map from the free Lie algebra on the
  inputs (letters) to vector fields is a homomorphism.
* The flow of `q' = Σ_i g_i(q) u_i(t)` over `[0, T]` is, to any order, the time-1 flow of the
  constant-coefficient field `Z = Σ_h α_h B_h(q)` (Chen–Fliess): `α` are the coordinates of
  `log S` in the Hall basis, where `S` is the signature of the controls with letters in time
  order, `S_{i1..ik} = ∫_{t1<…<tk} u_{i1}(t1)…u_{ik}(tk)`. Degree 2: `α_i = ∫u_i` and
  `α_[i,j] = ½∫(U_i u_j − U_j u_i) dt` with `U = ∫u` (paper eq. 21-23).

Vector fields and brackets are derived symbolically from `System.fields_on(stratum)` (exact
derivatives), restricted to the stratum's free coordinates, compiled once per stratum and
degree into one vectorised numpy function (common subexpressions shared) and cached on the
system. The iterated integrals `h(λ)` of the Fourier basis are polynomials (degree ≤ 3) in
the coefficients; their coefficient tensors are computed once per (basis, step length) with
Gauss–Legendre rules exact to rounding, so `h` and its Jacobian are a few tensor contractions.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache, lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .controls import FourierBasis
from .models import codecache
from .models.connection import connection, connection_A
from .models.manipulator import ManipulatorSystem
from .models.system import Stratum, System, _ArrayFunction

if TYPE_CHECKING:
    import sympy as sp

MAX_DEGREE = 3

# A Hall element: an int (generator index, 0-based among the stratum's active inputs) or a
# pair (left, right) of Hall elements, standing for the bracket [left, right].
HallElement = int | tuple


def element_degree(h: HallElement) -> int:
    return 1 if isinstance(h, int) else element_degree(h[0]) + element_degree(h[1])


def hall_basis(m: int, degree: int) -> list[HallElement]:
    """Philip Hall basis of the free Lie algebra on `m` generators, up to `degree`.

    Generators come first in their order; elements are ordered by degree, then by
    construction order. `[a, b]` is in the basis iff `a < b` and either `b` is a generator or
    `b = [c, d]` with `c ≤ a` (Serre / Lafferriere–Sussmann). Sizes follow Witt's formula:
    2 generators give 2, 1, 2 elements of degree 1, 2, 3; 3 generators give 3, 3, 8.
    """
    if m < 1 or degree < 1:
        return []
    basis: list[HallElement] = list(range(m))
    order = {h: k for k, h in enumerate(basis)}
    by_degree: dict[int, list[HallElement]] = {1: list(basis)}
    for d in range(2, degree + 1):
        new = []
        for da in range(1, d):
            for a in by_degree[da]:
                for b in by_degree[d - da]:
                    if not order[a] < order[b]:
                        continue
                    if not isinstance(b, int) and not order[b[0]] <= order[a]:
                        continue
                    new.append((a, b))
        # within a degree, order by (degree of the left factor, construction order)
        for h in new:
            order[h] = len(order)
        by_degree[d] = new
        basis.extend(new)
    return basis


def element_label(h: HallElement, names: tuple[str, ...] | list[str]) -> str:
    """`u2`, `[u2,u3]`, `[u2,[u2,u3]]`: the vector field of an input is named by the input."""
    if isinstance(h, int):
        return names[h]
    return f"[{element_label(h[0], names)},{element_label(h[1], names)}]"


def element_tensor(h: HallElement, m: int) -> np.ndarray:
    """The Hall element as a tensor of the free associative algebra, shape (m,)*degree."""
    if isinstance(h, int):
        e = np.zeros(m)
        e[h] = 1.0
        return e
    a, b = element_tensor(h[0], m), element_tensor(h[1], m)
    return np.multiply.outer(a, b) - np.multiply.outer(b, a)


# --------------------------------------------------------------------------------------------
# Vector fields and their brackets, symbolically, compiled once per stratum
# --------------------------------------------------------------------------------------------


def bracket(f: sp.Matrix, g: sp.Matrix, symbols, free: tuple[int, ...]) -> sp.Matrix:
    """`[f, g] = (∂g/∂q) f − (∂f/∂q) g`, differentiating along the free coordinates only
    (the fields of a stratum have zero rows on its locked coordinates)."""
    import sympy as sp  # only here: a cached model never needs sympy

    out = sp.zeros(f.shape[0], 1)
    for k in free:
        if f[k] != 0:
            out += sp.diff(g, symbols[k]) * f[k]
        if g[k] != 0:
            out -= sp.diff(f, symbols[k]) * g[k]
    return out


@dataclass
class LieBasis:
    """The Hall-basis vector fields of one stratum, as exact symbolic expressions and compiled.

    `evaluate(q)` maps configurations (..., n) to the fields on the free coordinates,
    (..., n_free, r), column `h` for `elements[h]`. `symbolic` is None for the closed-form
    path of physical manipulators (degree ≤ 2, see `_manipulator_basis`) and for a preset's
    brackets read from the code cache (`models.codecache`; derived once, compiled once).
    """

    system: System
    stratum: Stratum
    degree: int
    elements: list[HallElement]
    labels: list[str]
    free: tuple[int, ...]
    symbolic: sp.Matrix | None  # n_free x r
    evaluate: Callable[[np.ndarray], np.ndarray]

    @property
    def size(self) -> int:
        return len(self.elements)

    @property
    def m(self) -> int:
        return len(self.stratum.active)

    def full(self, q: np.ndarray) -> np.ndarray:
        """The fields in the full tangent space, (..., n, r); zero rows on locked coordinates."""
        q = np.asarray(q, dtype=float)
        B = self.evaluate(q)
        out = np.zeros((*q.shape[:-1], self.system.n, self.size))
        out[..., list(self.free), :] = B
        return out


def lie_basis(system: System, stratum: Stratum | str, degree: int = 2) -> LieBasis:
    """Generators and Hall brackets of `stratum` up to `degree` (cached on the system)."""
    if not 1 <= degree <= MAX_DEGREE:
        raise ValueError(f"bracket degree must be 1..{MAX_DEGREE}, got {degree}")
    s = system.stratum(stratum) if isinstance(stratum, str) else stratum
    cache = system.__dict__.setdefault("_lie_cache", {})
    key = (s.name, degree)
    if key not in cache:
        cache[key] = _build(system, s, degree)
    return cache[key]


SYMBOLIC_MAX_COORDINATES = 5  # larger manipulators: no symbolic closure across strata
STEP = 1e-3  # step of the fourth-order central differences of degree-3 brackets


def _build(system: System, stratum: Stratum, degree: int) -> LieBasis:
    if getattr(system, "robot", None) is not None and _is_manipulator(system):
        return _manipulator_basis(system, stratum, degree)
    if getattr(system, "spatial", None) is not None:  # a URDF robot: numeric, on SO(3)×Rᵏ
        from .spatial_lie import spatial_basis

        return spatial_basis(system, stratum, degree)
    free = stratum.free(system.n)
    elements = hall_basis(len(stratum.active), degree)
    names = [system.inputs[k] for k in stratum.active]
    labels = [element_label(h, names) for h in elements]
    key = _cache_key(system, stratum, degree)
    entry = codecache.load(key) if key else None
    if entry:
        try:  # a preset's brackets as compiled before: no sympy at all
            evaluate = _ArrayFunction.restored(entry["rows"], system.n)
            return LieBasis(system, stratum, degree, elements, labels, free, None, evaluate)
        except Exception:  # a damaged entry: derive them again
            pass
    rows = _symbolic_rows(system, stratum, elements, free)
    evaluate = _ArrayFunction(rows, list(system.symbols))
    saved = evaluate.saved() if key else None
    if saved is not None:
        codecache.store(key, {"rows": saved})
    return LieBasis(system, stratum, degree, elements, labels, free, rows, evaluate)


def _symbolic_rows(system: System, stratum: Stratum, elements, free) -> sp.Matrix:
    """The fields of `elements` on the free coordinates, derived with sympy (n_free x r)."""
    import sympy as sp  # only here: a cached model never needs sympy

    symbols = list(system.symbols)
    G = system.fields_on(stratum)  # n x m_active
    fields: dict[HallElement, sp.Matrix] = {}
    for h in elements:
        if isinstance(h, int):
            fields[h] = G[:, h]
        else:
            fields[h] = bracket(fields[h[0]], fields[h[1]], symbols, free)
    return sp.Matrix.hstack(*(fields[h] for h in elements)).extract(
        list(free), list(range(len(elements)))
    )


def _cache_key(system: System, stratum: Stratum, degree: int) -> str | None:
    """The code-cache key of a stratum's brackets, for systems with an `identity` only."""
    if system.identity is None:
        return None
    what = f"{system.identity}; liealgebra.py sha256 {_source_hash()}"
    return codecache.key(system.name, system.states, f"{stratum.name} brackets {degree}", what)


@cache
def _source_hash() -> str:
    return hashlib.sha256(Path(__file__).read_bytes()).hexdigest()


def _is_manipulator(system: System) -> bool:
    return isinstance(system, ManipulatorSystem)


def _manipulator_basis(system: System, stratum: Stratum, degree: int) -> LieBasis:
    """Closed-form fields of a physical manipulator (no sympy: cheap for long chains).

    `g_j = e_j + A_j e_θ` and, since `A` does not depend on θ, `[g_i, g_j] = F_ij e_θ` with
    `F_ij = ∂A_j/∂q_i − ∂A_i/∂q_j` (the curvature of the connection), exact from
    `connection.connection`. Degree 3: `[g_k, F_ij e_θ] = ∂F_ij/∂q_k e_θ`, by fourth-order
    central differences (step 1e-3, error about 1e-12 against the symbolic brackets) of the
    closed-form `∂A/∂q`; sympy took 0.3-0.7 s per stratum of a 4-link arm, and minutes on
    long chains.
    """
    robot = system.robot
    k = system.n - 1
    free = stratum.free(system.n)
    active = list(stratum.active)
    elements = hall_basis(len(active), degree)
    theta_row = free.index(k)
    names = [system.inputs[j] for j in active]

    def evaluate(q: np.ndarray) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        out = np.zeros((*q.shape[:-1], len(free), len(elements)))
        if degree >= 2:
            A, dA = connection(robot, q[..., :k])
        else:
            A = connection_A(robot, q[..., :k])
        if degree >= 3:  # dAs[s * k + p]: ∂A/∂q at q + (2h, h, -h, -2h)[s] e_p
            shifts = STEP * np.concatenate([2 * np.eye(k), np.eye(k), -np.eye(k), -2 * np.eye(k)])
            joints = q[..., :k]
            moved = joints[None] + shifts.reshape(4 * k, *([1] * (joints.ndim - 1)), k)
            dAs = connection(robot, moved)[1]
        for c, h in enumerate(elements):
            if isinstance(h, int):
                j = active[h]
                out[..., free.index(j), c] = 1.0
                out[..., theta_row, c] = A[..., j]
            elif isinstance(h[0], int) and isinstance(h[1], int):
                i, j = active[h[0]], active[h[1]]
                out[..., theta_row, c] = dA[..., j, i] - dA[..., i, j]
            else:  # [g_p, [g_i, g_j]] or [[g_i, g_j], g_p]
                sign, p, (a, b) = (1.0, h[0], h[1]) if isinstance(h[0], int) else (-1.0, *h[::-1])
                p, i, j = active[p], active[a], active[b]
                curl = dAs[..., j, i] - dAs[..., i, j]
                d = -curl[p] + 8 * curl[k + p] - 8 * curl[2 * k + p] + curl[3 * k + p]
                out[..., theta_row, c] = sign * d / (12 * STEP)
        return out

    labels = [element_label(h, names) for h in elements]
    return LieBasis(system, stratum, degree, elements, labels, free, None, evaluate)


def flow(basis: LieBasis, q0: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """End of the time-1 flow of `Z = Σ_h α_h B_h` from `q0` (the exponential of eq. 21)."""
    q0 = np.asarray(q0, dtype=float)
    free = list(basis.free)
    alpha = np.asarray(alpha, dtype=float)

    def rhs(_t, y):
        q = q0.copy()
        q[free] = y
        return basis.evaluate(q) @ alpha

    from scipy.integrate import solve_ivp  # only the Lie planner flows a basis numerically

    sol = solve_ivp(rhs, (0.0, 1.0), q0[free], method="DOP853", rtol=1e-12, atol=1e-14)
    out = q0.copy()
    out[free] = sol.y[:, -1]
    return out


# --------------------------------------------------------------------------------------------
# Iterated integrals h(λ) of the Fourier controls (paper eq. 23), exact tensors
# --------------------------------------------------------------------------------------------


def _rule(nodes: int, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(nodes)
    return a + 0.5 * (b - a) * (x + 1.0), 0.5 * (b - a) * w


@dataclass(frozen=True)
class IteratedIntegrals:
    """`α = h(λ)` for one step of length `duration`: the Hall coordinates of log S.

    `λ` is flat, laid out (m, 2H+1) like every leg's coefficients. `h` is
    `A1 λ + (λᵀ Q_h λ)_h + (W_h(λ, λ, λ))_h` with symmetric coefficient tensors, exact to
    rounding; `jacobian` is its exact derivative.
    """

    m: int
    degree: int
    elements: tuple
    A1: np.ndarray  # (r1, p)
    Q: np.ndarray  # (r2, p, p), symmetric in the last two axes
    W: np.ndarray  # (r3, p, p, p), symmetric in the last three axes
    slices: tuple[slice, slice, slice]

    @property
    def size(self) -> int:
        return len(self.elements)

    def evaluate(self, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`h(λ)` and its Jacobian together (the value of a homogeneous term of degree d is
        its Jacobian times λ over d): a few matrix products, no einsum."""
        lam = np.asarray(lam, dtype=float)
        p = lam.size
        jac = [self.A1]
        val = [self.A1 @ lam]
        if self.Q.shape[0]:
            J2 = 2.0 * (self.Q.reshape(-1, p) @ lam).reshape(-1, p)
            jac.append(J2)
            val.append(0.5 * (J2 @ lam))
        if self.W.shape[0]:
            J3 = 3.0 * (self.W.reshape(-1, p * p) @ np.outer(lam, lam).ravel()).reshape(-1, p)
            jac.append(J3)
            val.append((J3 @ lam) / 3.0)
        return np.concatenate(val), np.concatenate(jac)

    def __call__(self, lam: np.ndarray) -> np.ndarray:
        return self.evaluate(lam)[0]

    def jacobian(self, lam: np.ndarray) -> np.ndarray:
        return self.evaluate(lam)[1]

    def hessian(self, lam: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """`Σ_h weights_h ∇²h_h(λ)`, (p, p), exact."""
        lam = np.asarray(lam, dtype=float)
        p = lam.size
        w = np.asarray(weights, dtype=float)
        out = np.zeros((p, p))
        r1, r2 = self.A1.shape[0], self.Q.shape[0]
        if r2:
            out += 2.0 * np.tensordot(w[r1 : r1 + r2], self.Q, axes=1)
        if self.W.shape[0]:
            out += 6.0 * (np.tensordot(w[r1 + r2 :], self.W, axes=1) @ lam)
        return out


@lru_cache(maxsize=32)
def iterated_integrals(
    basis: FourierBasis, duration: float, m: int, degree: int = 2
) -> IteratedIntegrals:
    """Coefficient tensors of `h` for `m` inputs on a step of length `duration` (cached)."""
    T = float(duration)
    s = basis.size
    # Products of up to three basis functions oscillate at up to 3 ω_H: size the rule for it.
    highest = float(basis.omega[-1]) if basis.harmonics else 0.0
    nodes = 24 + int(np.ceil(1.5 * T * highest))
    t, w = _rule(nodes, 0.0, T)
    phi, psi = basis.values(t), basis.integrals(t)  # (K, s)
    psi_T = basis.integrals(T)
    K2 = np.einsum("k,ka,kb->ab", w, psi, phi)  # S2 = ∫ U_i u_j: Λ_i K2 Λ_jᵀ
    # S3 = ∫_0^T (∫_0^t ψ_a φ_b) φ_c(t) dt, inner integrals by a rule on [0, t_k]
    inner = np.empty((t.size, s, s))
    x, wx = np.polynomial.legendre.leggauss(nodes)
    for k, tk in enumerate(t):
        tt = 0.5 * tk * (x + 1.0)
        ww = 0.5 * tk * wx
        inner[k] = np.einsum("j,ja,jb->ab", ww, basis.integrals(tt), basis.values(tt))
    K3 = np.einsum("k,kab,kc->abc", w, inner, phi)

    elements = hall_basis(m, degree)
    by_degree = [[h for h in elements if element_degree(h) == d] for d in (1, 2, 3)]
    p = m * s

    def lift(C: np.ndarray, d: int) -> np.ndarray:
        """Tensor over flat λ for the Hall coordinates of degree d of the multilinear form
        L_d[i1..id] = Σ C[a1..ad] Λ[i1,a1]…Λ[id,ad]."""
        hs = by_degree[d - 1]
        if not hs:
            return np.zeros((0,) + (p,) * d)
        P = np.stack([element_tensor(h, m).ravel() for h in hs], axis=1)  # (m^d, r_d)
        R = np.linalg.pinv(P).reshape((len(hs),) + (m,) * d)  # exact: P has full column rank
        if d == 1:
            out = np.einsum("hi,a->hia", R, C)
        elif d == 2:
            out = np.einsum("hij,ab->hiajb", R, C)
        else:
            out = np.einsum("hijk,abc->hiajbkc", R, C)
        return out.reshape((len(hs),) + (p,) * d)

    A1 = lift(psi_T, 1)
    C2 = K2 - 0.5 * np.multiply.outer(psi_T, psi_T)
    Q = lift(C2, 2) if degree >= 2 else np.zeros((0, p, p))
    Q = 0.5 * (Q + Q.transpose(0, 2, 1))
    if degree >= 3:
        C3 = (
            K3
            - 0.5 * (np.multiply.outer(psi_T, K2) + np.multiply.outer(K2, psi_T))
            + np.multiply.outer(np.multiply.outer(psi_T, psi_T), psi_T) / 3.0
        )
        W = lift(C3, 3)
        perms = ((0, 1, 2, 3), (0, 1, 3, 2), (0, 2, 1, 3), (0, 2, 3, 1), (0, 3, 1, 2), (0, 3, 2, 1))
        W = sum(W.transpose(pm) for pm in perms) / 6.0
    else:
        W = np.zeros((0, p, p, p))
    r1, r2 = A1.shape[0], Q.shape[0]
    slices = (slice(0, r1), slice(r1, r1 + r2), slice(r1 + r2, r1 + r2 + W.shape[0]))
    ordered = tuple(h for d in range(1, degree + 1) for h in by_degree[d - 1])
    if list(ordered) != elements:  # hall_basis orders by degree already
        raise AssertionError("Hall basis not ordered by degree")
    for arr in (A1, Q, W):
        arr.setflags(write=False)
    return IteratedIntegrals(m, degree, ordered, A1, Q, W, slices)
