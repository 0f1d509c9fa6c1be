"""Iterated integrals of the Fourier controls (`stratcli.iterated`, paper eq. 21-23)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid

from stratcli.controls import FourierBasis
from stratcli.iterated import iterated_integrals


def test_iterated_integrals_match_brute_force_and_have_exact_jacobians():
    basis, T = FourierBasis(3, 2.17), 0.51
    h = iterated_integrals(basis, T, 2, 3)
    lam = np.random.default_rng(5).normal(size=2 * basis.size)
    L = lam.reshape(2, -1)
    t = np.linspace(0.0, T, 20001)
    u = basis.values(t) @ L.T
    U = cumulative_trapezoid(u, t, axis=0, initial=0.0)
    alpha = h(lam)
    np.testing.assert_allclose(alpha[:2], np.trapezoid(u, t, axis=0), rtol=1e-7)
    area = 0.5 * np.trapezoid(U[:, 0] * u[:, 1] - U[:, 1] * u[:, 0], t)
    assert alpha[2] == pytest.approx(area, rel=1e-6)
    J = h.jacobian(lam)
    E = np.eye(lam.size) * 1e-6
    numeric = np.array([(h(lam + e) - h(lam - e)) / 2e-6 for e in E]).T
    np.testing.assert_allclose(J, numeric, atol=1e-9)
