"""Lie brackets, the P. Hall basis, iterated integrals and the one-step flow."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from conftest import UNICYCLE

import stratcli.liealgebra as lie
from stratcli.controls import FourierBasis
from stratcli.endpoint import OdeEndpoint
from stratcli.iterated import iterated_integrals
from stratcli.liealgebra import element_degree, flow, hall_basis, lie_basis
from stratcli.models.connection import connection
from stratcli.models.presets import preset
from stratcli.scenario import load_scenario, parse_scenario

PI = np.pi


@pytest.mark.parametrize(
    ("m", "degree", "size"), [(2, 1, 2), (2, 2, 3), (2, 3, 5), (3, 2, 6), (3, 3, 14)]
)
def test_hall_basis_sizes_follow_witt(m, degree, size):
    basis = hall_basis(m, degree)
    assert len(basis) == size
    assert len(set(basis)) == size
    assert [element_degree(h) for h in basis] == sorted(element_degree(h) for h in basis)


def test_hall_basis_of_two_generators():
    assert hall_basis(2, 3) == [0, 1, (0, 1), (0, (0, 1)), (1, (0, 1))]


def test_unicycle_bracket_by_hand():
    """[g_v, g_w] = (∂g_w/∂q) g_v − (∂g_v/∂q) g_w = −∂g_v/∂θ = (sin θ, −cos θ, 0)."""
    system = parse_scenario(UNICYCLE).system
    lb = lie_basis(system, "drive", 2)
    th = system.symbols[2]
    assert lb.labels == ["v", "w", "[v,w]"]
    expected = sp.Matrix([sp.sin(th), -sp.cos(th), 0])
    assert sp.simplify(lb.symbolic[:, 2] - expected) == sp.zeros(3, 1)
    q = np.array([[0.3, -1.0, 0.7], [1.0, 2.0, -2.5]])
    np.testing.assert_allclose(lb.evaluate(q)[:, :, 2], np.c_[np.sin(q[:, 2]), -np.cos(q[:, 2]),
                               np.zeros(2)], atol=1e-15)  # fmt: skip


@pytest.mark.parametrize("stratum", ["S1", "S2", "S3"])
def test_one_arm_bracket_is_the_curvature_of_the_connection(stratum):
    """On a one-arm stratum [g_i, g_j] = (∂A_j/∂q_i − ∂A_i/∂q_j) e_θ; here A and dA come from
    the physical derivation of the robot (models.connection), independent of eq. 6's sympy."""
    system = preset("one-arm")
    lb = lie_basis(system, stratum, 2)
    i, j = system.stratum(stratum).active
    q = np.random.default_rng(3).uniform(-PI, PI, (200, 4))
    _, dA = connection(system.robot, q[:, :3])
    B = lb.evaluate(q)  # free coordinates: the two joints and theta
    np.testing.assert_allclose(B[:, :2, 2], 0.0, atol=1e-15)
    np.testing.assert_allclose(B[:, 2, 2], dA[:, j, i] - dA[:, i, j], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("degree, atol", [(2, 1e-13), (3, 1e-11)])
def test_manipulator_closed_form_brackets_equal_the_symbolic_ones(
    scenarios_dir, monkeypatch, degree, atol
):
    """Degree 2 exactly (curvature of the connection); degree 3 by fourth-order central
    differences of the closed-form ∂A/∂q (about 1e-13 off here)."""
    import stratcli.liealgebra as lie

    system = load_scenario(scenarios_dir / "rods_three_link.toml").system
    q = np.random.default_rng(4).uniform(-PI, PI, (50, 4))
    fast = lie_basis(system, "S2", degree)
    assert fast.symbolic is None  # the closed-form path of physical manipulators
    monkeypatch.setattr(lie, "_is_manipulator", lambda s: False)
    slow = lie._build(system, system.stratum("S2"), degree)  # sympy, from System.fields_on
    assert slow.symbolic is not None
    np.testing.assert_allclose(fast.evaluate(q), slow.evaluate(q), rtol=0, atol=atol)


def _prediction_errors(system, stratum, q0, degree, scales, flip_bracket=False):
    basis, T = FourierBasis(3, 2.17), 0.51
    lb = lie_basis(system, stratum, degree)
    h = iterated_integrals(basis, T, len(system.stratum(stratum).active), degree)
    ode = OdeEndpoint(system.compiled(stratum), q0, basis, T)
    direction = np.random.default_rng(1).normal(size=h.A1.shape[1])
    errors = []
    for eps in scales:
        lam = eps * direction
        alpha = h(lam)
        if flip_bracket:
            alpha[h.slices[1]] *= -1.0
        true, _ = ode(lam, False)
        errors.append(np.linalg.norm(flow(lb, q0, alpha) - true))
    return np.array(errors)


@pytest.mark.parametrize(("degree", "order"), [(2, 3), (3, 4)])
def test_one_step_prediction_error_shrinks_like_u_cubed(degree, order):
    """exp(Σ α_h(u) B_h)(q) against a real integration: O(|u|^3) for degree 2, O(|u|^4) for 3."""
    q0 = np.array([-PI / 3, -PI / 3, PI / 6, PI / 12])
    errors = _prediction_errors(preset("one-arm"), "S1", q0, degree, [0.2, 0.1, 0.05])
    rates = np.log2(errors[:-1] / errors[1:])
    assert np.all(rates > order - 0.25), rates


def test_wrong_bracket_sign_is_caught_by_the_shrinkage_rate():
    system = parse_scenario(UNICYCLE).system
    q0 = np.array([0.1, -0.2, 0.4])
    good = _prediction_errors(system, "drive", q0, 2, [0.1, 0.05, 0.025])
    bad = _prediction_errors(system, "drive", q0, 2, [0.1, 0.05, 0.025], flip_bracket=True)
    assert np.all(np.log2(good[:-1] / good[1:]) > 2.75)
    assert np.all(np.log2(bad[:-1] / bad[1:]) < 2.25)  # the O(|u|^2) bracket term is wrong


@pytest.mark.parametrize("name", ["one-arm", "two-arm"])
def test_numeric_third_order_brackets_match_the_symbolic_ones(name):
    system = preset(name)
    rng = np.random.default_rng(1)
    Q = rng.uniform(-3, 3, (10, system.n))
    Q[0] = 0.0  # where every degree-2 bracket vanishes
    for stratum in system.strata.values():
        exact = lie._build(system, stratum, 3)
        numeric = lie._manipulator_basis(system, stratum, 3)
        assert numeric.labels == exact.labels
        assert np.abs(numeric.evaluate(Q) - exact.evaluate(Q)).max() < 1e-8
