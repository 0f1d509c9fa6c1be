"""Iterated integrals `h(λ)` of the Fourier controls (paper eq. 21-23), as exact tensors.

`α = h(λ)` are the Hall coordinates of the logarithm of the controls' signature over one step
(conventions in `stratcli.liealgebra`): `α_i = ∫u_i`, `α_[i,j] = ½∫(U_i u_j − U_j u_i) dt`
and the degree-3 terms. They are polynomials (degree ≤ 3) in the coefficients; their
coefficient tensors are computed once per (basis, step length) with Gauss–Legendre rules exact
to rounding, so `h` and its Jacobian are a few tensor contractions.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .controls import FourierBasis
from .liealgebra import element_degree, element_tensor, hall_basis

__all__ = ["IteratedIntegrals", "iterated_integrals"]


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
