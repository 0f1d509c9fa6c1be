"""End-point evaluators: quadrature and ODE paths, Jacobians, Hessians, the choice."""

from __future__ import annotations

import numpy as np
import pytest

from stratcli.controls import FourierBasis
from stratcli.endpoint import OdeEndpoint, QuadratureEndpoint, make_endpoint
from stratcli.errors import InputError
from stratcli.models.manipulator import ManipulatorSystem
from stratcli.models.planar import paper_one_arm, paper_two_arm
from stratcli.models.presets import preset
from stratcli.scenario import parse_scenario

BASIS = FourierBasis(3, 2.17)


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
        (lambda: ManipulatorSystem(paper_two_arm()), "S2", np.array([0.1, 0.5, -0.4, 0.9, -0.3])),
    ],
)
def test_endpoint_hessian_matches_finite_differences_of_the_jacobian(system, stratum, q0):
    """The energy objective's exact second derivatives (fused compiled ∂²G_Q, or the
    closed-form contracted second derivatives of the physical connection) agree with the
    exact Jacobian."""
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


NON_QUADRATURE = """
name = "c"
[model]
kind = "custom"
states = ["x", "y", "z"]
inputs = ["u1", "u2"]
fields = { u1 = [1, 0, "z"], u2 = [0, 1, "x"] }
strata = [{ name = "A", active = ["u1", "u2"] }]
[task]
start = [0, 0, 1]
goal = [0.5, 0.2, 1.3]
[[legs]]
stratum = "A"
"""


def test_evaluator_is_chosen_from_structure():
    """z' = z u1 + x u2 depends on z itself: only the general path can integrate it."""
    task = parse_scenario(NON_QUADRATURE)
    cs = task.system.compiled("A")
    assert not cs.supports_quadrature
    assert make_endpoint(cs, task.start, BASIS, 1.0).kind == "ode"
    with pytest.raises(InputError, match="does not allow the quadrature path"):
        parse_scenario(
            NON_QUADRATURE.replace("[[legs]]", '[planner]\nevaluator = "quadrature"\n[[legs]]')
        )


LOCKED_AND_MIXED = """
name = "m"
[model]
kind = "custom"
states = ["x", "a", "b"]
inputs = ["u1", "u2"]
fields = {{ u1 = ["cos(a) + sin(b)", {c1}, 0], u2 = ["sin(a) * cos(b)", 1, 0] }}
strata = [{{ name = "A", active = ["u1", "u2"] }}]
[task]
start = [0, 0, 0.4]
goal = [0.5, 0.2, 0.4]
[[legs]]
stratum = "A"
"""


@pytest.mark.parametrize("c1", [1, 2])  # a' = u1 + u2 (C selects), a' = 2 u1 + u2 (it does not)
def test_derivatives_of_a_stratum_with_an_unmoved_explicit_coordinate(c1):
    """b has a constant (zero) row: explicit but never moved, so the compiled rows are not
    differentiated along it; the Jacobian and Hessian still equal finite differences."""
    cs = parse_scenario(LOCKED_AND_MIXED.format(c1=c1)).system.compiled("A")
    assert cs.explicit == (1, 2) and cs.derivatives_along == (0,)
    ep = QuadratureEndpoint(cs, np.array([0.1, -0.3, 0.4]), BASIS, 1.1)
    rng = np.random.default_rng(c1)
    lam = rng.normal(0, 1.5, ep.n_coefficients)
    h = 1e-6
    steps = np.eye(lam.size)
    fd = np.column_stack(
        [(ep(lam + h * e, False)[0] - ep(lam - h * e, False)[0]) / (2 * h) for e in steps]
    )
    np.testing.assert_allclose(ep(lam)[1], fd, atol=1e-7)
    weights = np.array([0.7, 0.0, 0.0])
    H = ep.hessian(lam, weights)
    fd2 = np.column_stack(
        [weights @ (ep(lam + h * e)[1] - ep(lam - h * e)[1]) / (2 * h) for e in steps]
    )
    np.testing.assert_allclose(H, fd2, atol=1e-6 * max(1.0, np.abs(H).max()))
    assert np.abs(H).max() > 1e-3
