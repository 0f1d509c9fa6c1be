"""Lie brackets and the Philip Hall basis of a stratum's fields (§4.2).

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
system. The iterated integrals `h(λ)` that give `α` are in `stratcli.iterated`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .models import codecache
from .models.connection import connection, connection_A
from .models.generated import ArrayFunction, cached_function, keep_function
from .models.manipulator import ManipulatorSystem
from .models.system import Stratum, System

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
    if found := cached_function(key, system.n):  # a preset's brackets: no sympy at all
        return LieBasis(system, stratum, degree, elements, labels, free, None, found[0])
    rows = _symbolic_rows(system, stratum, elements, free)
    evaluate = ArrayFunction(rows, list(system.symbols))
    keep_function(key, evaluate)
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


def _source_hash() -> str:
    return codecache.sources_hash(Path(__file__).resolve())


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
