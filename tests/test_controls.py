"""The Fourier basis: Gram matrix, derivatives, integrals, energy, embedding."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from stratcli.controls import FourierBasis, embed, energy

BASIS = FourierBasis(3, 2.17)


def test_gram_matrix_is_the_exact_integral():
    T = 1.37
    M = BASIS.gram(T)
    for a in range(BASIS.size):
        for b in range(BASIS.size):
            exact = quad(lambda t, a=a, b=b: BASIS.values(t)[a] * BASIS.values(t)[b], 0, T)[0]
            assert M[a, b] == pytest.approx(exact, abs=1e-13)


def test_basis_derivatives_and_integrals_are_consistent():
    t = np.linspace(0, 2, 41)
    h = 1e-6
    fd = (BASIS.values(t + h) - BASIS.values(t - h)) / (2 * h)
    np.testing.assert_allclose(BASIS.derivatives(t), fd, atol=1e-7)
    integral = [[quad(lambda s, b=b: BASIS.values(s)[b], 0, x)[0] for b in range(7)] for x in t]
    np.testing.assert_allclose(BASIS.integrals(t), integral, atol=1e-12)


def test_energy_is_the_integral_of_u_squared():
    rng = np.random.default_rng(3)
    lam = rng.normal(size=(2, BASIS.size))
    direct = quad(lambda t: float(np.sum((lam @ BASIS.values(t)) ** 2)), 0, 1.0, epsabs=1e-13)[0]
    assert energy(BASIS, 1.0, lam) == pytest.approx(direct, rel=1e-12)


def test_embed_keeps_the_controls():
    small, big = FourierBasis(3, 2.17), FourierBasis(6, 2.17)
    c = np.random.default_rng(0).normal(size=(2, 7))
    t = np.linspace(0, 1, 11)
    np.testing.assert_allclose(small.values(t) @ c.T, big.values(t) @ embed(c, 3, 6).T, atol=1e-14)
