"""Basis, end-point evaluators and boundary conditions."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from stratcli.continuity import eliminate, leg_constraints
from stratcli.controls import FourierBasis, energy
from stratcli.endpoint import OdeEndpoint, QuadratureEndpoint, make_endpoint
from stratcli.models.manipulator import ManipulatorSystem
from stratcli.models.planar import paper_one_arm
from stratcli.models.presets import preset

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


CASES = [("one-arm", s, np.array([0.3, -0.7, 1.1, 0.2])) for s in ("S1", "S2", "S3")] + [
    ("two-arm", s, np.array([0.1, 0.5, -0.4, 0.9, -0.3])) for s in ("S1", "S3", "S24", "S12")
]


@pytest.mark.parametrize(("model", "stratum", "q0"), CASES)
@pytest.mark.parametrize("scale", [0.3, 3.0, 25.0])
def test_quadrature_path_equals_ode_path(model, stratum, q0, scale):
    """Same end point to 1e-9 and same Jacobian on random controls, large ones included."""
    cs = preset(model).compiled(stratum)
    rng = np.random.default_rng([int(scale * 10), len(stratum)])
    fast = QuadratureEndpoint(cs, q0, BASIS, 1.0)
    slow = OdeEndpoint(cs, q0, BASIS, 1.0)
    lam = rng.normal(0.0, scale, fast.n_coefficients)
    end_fast, J_fast = fast(lam)
    end_slow, J_slow = slow(lam)
    np.testing.assert_allclose(end_fast, end_slow, atol=1e-9)
    np.testing.assert_allclose(J_fast, J_slow, atol=1e-8 * max(1.0, np.abs(J_slow).max()))


def test_quadrature_rule_grows_with_the_controls():
    """|λ| up to 160: the node count follows the coefficients, accuracy holds (DESIGN §1)."""
    cs = preset("one-arm").compiled("S1")
    q0 = np.array([0.0, 1.0, 0.0, 0.0])
    lam = np.zeros(14)
    lam[[0, 3, 7, 12]] = [160.0, -120.0, 90.0, 140.0]
    end_fast, _ = QuadratureEndpoint(cs, q0, BASIS, 1.0)(lam, jacobian=False)
    end_slow, _ = OdeEndpoint(cs, q0, BASIS, 1.0)(lam, jacobian=False)
    np.testing.assert_allclose(end_fast, end_slow, atol=1e-8)


@pytest.mark.parametrize("evaluator", ["quadrature", "ode"])
def test_jacobian_matches_finite_differences(evaluator):
    cs = preset("two-arm").compiled("S2")
    ep = make_endpoint(cs, np.array([0.2, 0.0, -0.5, 0.3, 0.1]), BASIS, 1.3, evaluator)
    lam = np.random.default_rng(0).normal(0, 1.0, ep.n_coefficients)
    _, J = ep(lam)
    h = 1e-6
    fd = np.column_stack(
        [
            (ep(lam + h * e, False)[0] - ep(lam - h * e, False)[0]) / (2 * h)
            for e in np.eye(lam.size)
        ]
    )
    np.testing.assert_allclose(J, fd, atol=1e-7)


@pytest.mark.parametrize(
    ("system", "stratum", "q0"),
    [
        (lambda: preset("one-arm"), "S2", np.array([0.3, -0.7, 1.1, 0.2])),
        (lambda: preset("two-arm"), "S12", np.array([0.1, 0.5, -0.4, 0.9, -0.3])),
        (lambda: ManipulatorSystem(paper_one_arm()), "S3", np.array([0.3, -0.7, 1.1, 0.2])),
    ],
)
def test_endpoint_hessian_matches_finite_differences_of_the_jacobian(system, stratum, q0):
    """The energy objective's exact second derivatives (fused compiled ∂²G_Q, or batched
    central differences of the closed-form connection) agree with the exact Jacobian."""
    ep = QuadratureEndpoint(system().compiled(stratum), q0, BASIS, 1.2)
    rng = np.random.default_rng(3)
    lam = rng.normal(0, 2.0, ep.n_coefficients)
    weights = rng.normal(size=q0.size)
    H = ep.hessian(lam, weights)
    h = 1e-6
    fd = np.column_stack(
        [weights @ (ep(lam + h * e)[1] - ep(lam - h * e)[1]) / (2 * h) for e in np.eye(lam.size)]
    )
    np.testing.assert_allclose(H, H.T, atol=1e-12 * np.abs(H).max())
    np.testing.assert_allclose(H, fd, atol=1e-6 * max(1.0, np.abs(H).max()))
    assert np.abs(H).max() > 1e-3  # the curvature is really there


def test_evaluator_choice_follows_structure():
    assert make_endpoint(preset("one-arm").compiled("S1"), np.zeros(4), BASIS, 1.0).kind == (
        "quadrature"
    )
    assert make_endpoint(preset("one-arm").compiled("S1"), np.zeros(4), BASIS, 1.0, "ode").kind == (
        "ode"
    )


def test_boundary_conditions_hold_after_elimination():
    system = preset("one-arm")
    prev_u = np.array([0.4, -1.2, 0.0])
    prev_du = np.array([2.0, 0.3, 0.0])
    active = system.stratum("S2").active  # u1, u3
    cons = leg_constraints(
        BASIS, 1.0, active, system.inputs, "lr-C1",
        previous=(prev_u, prev_du), next_active=system.stratum("S3").active,
        soft_start=False, full_stop=False,
    )  # fmt: skip
    elim = eliminate(cons)
    z = np.random.default_rng(1).normal(size=elim.free)
    lam = elim.coefficients(z).reshape(2, BASIS.size)
    u0, du0 = lam @ BASIS.values(0.0), lam @ BASIS.derivatives(0.0)
    uT, duT = lam @ BASIS.values(1.0), lam @ BASIS.derivatives(1.0)
    np.testing.assert_allclose(u0, [0.4, 0.0], atol=1e-12)  # u1 continues, u3 starts at 0
    np.testing.assert_allclose(du0, [2.0, 0.0], atol=1e-12)
    np.testing.assert_allclose([uT[1], duT[1]], [0.0, 0.0], atol=1e-12)  # u3 unused on S3
    assert elim.free == 14 - 6
