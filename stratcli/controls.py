"""Fourier control basis (paper eq. 30), its exact Gram matrix, and time scaling.

Per active input `k`: `u_k(t) = λ0 + Σ_{i=1..H} λi sin(ω_i t) + λ_{i+H} cos(ω_i t)`, with
`ω_i = 2πi/P`. The coefficient layout (λ0, sines, cosines) is the one of `result.json`.
Energy `∫ u_k² dt = λᵀ M λ` with the exact Gram matrix `M` of the basis on [0, T].
"""

from __future__ import annotations

from functools import cached_property, lru_cache
from typing import Annotated

import numpy as np
from pydantic import ConfigDict, Field, Strict
from pydantic.dataclasses import dataclass

# Shared by every settings class: unknown keys and non-finite numbers are errors.
CONFIG = ConfigDict(extra="forbid", allow_inf_nan=False)
MAX_PERIODS_PER_LEG = 1000  # duration / period of one leg (or one Lie step)
MAX_PERIOD = 1e6  # s: the longest basis period (a plan slowed by time scaling stretches it)


@dataclass(frozen=True, config=CONFIG)
class FourierBasis:
    """Basis functions `1, sin(ω_i t), cos(ω_i t)` (i = 1..H) with `ω_i = 2πi/period`.

    Scenario table ``[planner.basis]``. What bounds the work of a leg is its number of
    periods, `duration / period` (quadrature nodes grow with it); the scenario checks it per
    leg (`MAX_PERIODS_PER_LEG`), since time scaling divides both by the same factor.

    Attributes
    ----------
    harmonics : int
        H, 1 to 40 (2H+1 coefficients per input and piece).
    period : float
        The basis period, s.
    """

    harmonics: Annotated[int, Strict(), Field(ge=1, le=40)] = 3
    period: Annotated[float, Strict(), Field(gt=0, le=MAX_PERIOD)] = 2.17

    @property
    def size(self) -> int:
        """Coefficients per input: λ0, H sines and H cosines."""
        return 2 * self.harmonics + 1

    @cached_property
    def omega(self) -> np.ndarray:
        return 2.0 * np.pi * np.arange(1, self.harmonics + 1) / self.period

    def values(self, t: np.ndarray | float) -> np.ndarray:
        """The basis functions φ(t).

        Parameters
        ----------
        t : float or array of float
            Times, s.

        Returns
        -------
        ndarray
            Shape (*t.shape, size): 1, the sines, the cosines.
        """
        wt = np.multiply.outer(np.asarray(t, dtype=float), self.omega)
        one = np.ones((*wt.shape[:-1], 1))
        return np.concatenate([one, np.sin(wt), np.cos(wt)], axis=-1)

    def derivatives(self, t: np.ndarray | float) -> np.ndarray:
        """The basis functions' time derivatives φ'(t).

        Parameters
        ----------
        t : float or array of float
            Times, s.

        Returns
        -------
        ndarray
            Shape (*t.shape, size).
        """
        wt = np.multiply.outer(np.asarray(t, dtype=float), self.omega)
        zero = np.zeros((*wt.shape[:-1], 1))
        return np.concatenate([zero, self.omega * np.cos(wt), -self.omega * np.sin(wt)], axis=-1)

    def integrals(self, t: np.ndarray | float) -> np.ndarray:
        """The integrals ∫_0^t φ(s) ds, in closed form (so joints need no integration).

        Parameters
        ----------
        t : float or array of float
            Upper limits, s.

        Returns
        -------
        ndarray
            Shape (*t.shape, size).
        """
        t = np.asarray(t, dtype=float)
        wt = np.multiply.outer(t, self.omega)
        return np.concatenate(
            [t[..., None], (1.0 - np.cos(wt)) / self.omega, np.sin(wt) / self.omega], axis=-1
        )

    def gram(self, duration: float) -> np.ndarray:
        """The Gram matrix `M_ab = ∫_0^T φ_a φ_b dt`, exact (closed form, product-to-sum).

        Parameters
        ----------
        duration : float
            T, s.

        Returns
        -------
        ndarray
            Shape (size, size), a copy: the energy of coefficients λ (m, size) is
            ``trace(λ M λᵀ)``.
        """
        return _gram(self.harmonics, self.period, float(duration)).copy()


def _int_cos(c: np.ndarray, T: float) -> np.ndarray:
    """∫_0^T cos(c t) dt, elementwise, exact at c = 0."""
    c = np.asarray(c, dtype=float)
    safe = np.where(c == 0.0, 1.0, c)
    return np.where(c == 0.0, T, np.sin(c * T) / safe)


def _int_sin(c: np.ndarray, T: float) -> np.ndarray:
    """∫_0^T sin(c t) dt, elementwise, exact at c = 0."""
    c = np.asarray(c, dtype=float)
    safe = np.where(c == 0.0, 1.0, c)
    return np.where(c == 0.0, 0.0, (1.0 - np.cos(c * T)) / safe)


@lru_cache(maxsize=64)
def _gram(harmonics: int, period: float, T: float) -> np.ndarray:
    # Every basis function is cos(w t) or sin(w t); products follow from product-to-sum.
    w = np.concatenate([[0.0], 2.0 * np.pi * np.arange(1, harmonics + 1) / period])
    w = np.concatenate([w, w[1:]])
    is_sin = np.zeros(w.size, dtype=bool)
    is_sin[1 : harmonics + 1] = True
    a, b = np.meshgrid(w, w, indexing="ij")
    sa, sb = np.meshgrid(is_sin, is_sin, indexing="ij")
    plus, minus = a + b, a - b
    cc = 0.5 * (_int_cos(minus, T) + _int_cos(plus, T))  # cos a cos b
    ss = 0.5 * (_int_cos(minus, T) - _int_cos(plus, T))  # sin a sin b
    sc = 0.5 * (_int_sin(plus, T) + _int_sin(minus, T))  # sin a cos b
    cs = 0.5 * (_int_sin(plus, T) - _int_sin(minus, T))  # cos a sin b
    M = np.where(sa & sb, ss, np.where(sa, sc, np.where(sb, cs, cc)))
    M = 0.5 * (M + M.T)
    M.setflags(write=False)
    return M


def energy(basis: FourierBasis, duration: float, coefficients: np.ndarray) -> float:
    """∫ Σ_k u_k² dt for coefficients of shape (m_active, size), exactly."""
    M = basis.gram(duration)
    lam = np.atleast_2d(coefficients)
    return float(np.einsum("ka,ab,kb->", lam, M, lam))


def embed(coefficients: np.ndarray, harmonics: int, more: int) -> np.ndarray:
    """Coefficients (…, 2H+1) in a basis with `more` ≥ H harmonics: the same controls."""
    c = np.asarray(coefficients, dtype=float)
    out = np.zeros((*c.shape[:-1], 2 * more + 1))
    out[..., : harmonics + 1] = c[..., : harmonics + 1]
    out[..., more + 1 : more + 1 + harmonics] = c[..., harmonics + 1 :]
    return out


def end_controls(
    basis: FourierBasis, coefficients: np.ndarray, duration: float, active, m: int
) -> tuple[np.ndarray, np.ndarray]:
    """Values and derivatives of all `m` inputs at the end of a piece of `duration` whose
    coefficients (one row per input of `active`) drive those inputs, the others at rest: the
    `previous` controls of the piece or leg after it."""
    L = np.atleast_2d(np.asarray(coefficients, dtype=float))
    u, du = np.zeros(m), np.zeros(m)
    u[list(active)] = L @ basis.values(duration)
    du[list(active)] = L @ basis.derivatives(duration)
    return u, du
