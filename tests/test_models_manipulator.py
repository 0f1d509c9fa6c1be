"""Manipulator systems from physical parameters, as the planner sees them."""

from __future__ import annotations

import numpy as np
import pytest

from stratcli.controls import FourierBasis
from stratcli.endpoint import QuadratureEndpoint
from stratcli.models.manipulator import ManipulatorSystem
from stratcli.models.planar import Arm, Base, Link, PlanarManipulator, paper_one_arm, paper_two_arm
from stratcli.models.presets import preset

BASIS = FourierBasis()


@pytest.mark.parametrize(
    ("robot", "name", "strata"),
    [(paper_one_arm(), "one-arm", ["S1", "S3"]), (paper_two_arm(), "two-arm", ["S2", "S13"])],
)
def test_physical_model_plans_like_the_printed_preset(robot, name, strata):
    """Same end point and Jacobian from the derived model as from the printed equations."""
    physical, printed = ManipulatorSystem(robot), preset(name)
    assert list(physical.strata) == list(printed.strata)
    rng = np.random.default_rng(7)
    for s in strata:
        q0 = rng.uniform(-np.pi, np.pi, physical.n)
        a = QuadratureEndpoint(physical.compiled(s), q0, BASIS, 1.0)
        b = QuadratureEndpoint(printed.compiled(s), q0, BASIS, 1.0)
        lam = rng.normal(0, 2.0, a.n_coefficients)
        (ea, Ja), (eb, Jb) = a(lam), b(lam)
        np.testing.assert_allclose(ea, eb, atol=1e-13)
        np.testing.assert_allclose(Ja, Jb, atol=1e-12)


def test_default_strata_are_single_locks_and_pairs_from_four_joints():
    rod = Link(1.0, 1.0)
    three = ManipulatorSystem(PlanarManipulator(Base(5, 1), (Arm((0.5, 0), 0, 1, (rod,) * 3),)))
    assert list(three.strata) == ["S1", "S2", "S3"]
    arm = Arm((0.5, 0), 0, 1, (rod,) * 11)
    eleven = ManipulatorSystem(PlanarManipulator(Base(5, 1), (arm,)))
    assert "S1_11" in eleven.strata and "S1_2" in eleven.strata  # (10 joints on: separated)
    assert len(eleven.strata) == 11 + 55 and "S12" not in eleven.strata  # (no joint 12)
    assert eleven.strata["S1_11"].locked == (0, 10) and eleven.strata["S11"].locked == (10,)


def test_rod_links_change_the_model():
    """Real rods (I = m l²/12) are a different robot from the paper's (I = 1/3)."""
    paper = paper_one_arm()
    rods = PlanarManipulator(
        paper.base,
        tuple(Arm(a.mount, a.zero_angle, a.sense, (Link(1, 1),) * 3) for a in paper.arms),
    )
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (2000, 4))
    Ap = ManipulatorSystem(paper).compiled("S1").quadrature_terms(q, 0)[0]
    Ar = ManipulatorSystem(rods).compiled("S1").quadrature_terms(q, 0)[0]
    assert np.abs(Ap - Ar).max() > 0.1  # docs/planar_model.md §5: up to 0.23


def test_contracted_terms_equal_the_full_derivatives():
    """The strata's one-contraction terms (what end-point Jacobians and Hessians use) equal
    the full first and second derivatives of the θ row contracted the same way."""
    cs = ManipulatorSystem(paper_two_arm()).compiled("S2")  # joint 2 locked
    rng = np.random.default_rng(4)
    q = rng.uniform(-np.pi, np.pi, (60, 5))
    V = rng.normal(size=(60, 1, 3))
    G, dG, ddG = cs.quadrature_terms(q, 2)
    GQ, Du = cs.quadrature_jacobian(q, V)
    dGQ, H = cs.quadrature_hessian(q, V)
    np.testing.assert_array_equal(GQ, G)
    np.testing.assert_allclose(dGQ, dG, rtol=0, atol=1e-15)
    np.testing.assert_allclose(Du, np.einsum("kra,krae->kre", V, dG), rtol=0, atol=1e-14)
    np.testing.assert_allclose(H, np.einsum("kra,kraef->kef", V, ddG), rtol=0, atol=1e-13)
    h = 1e-5  # and the full second derivatives are those of the first
    fd = [
        (cs.quadrature_terms(q + h * e, 1)[1] - cs.quadrature_terms(q - h * e, 1)[1]) / (2 * h)
        for e in np.eye(5)[:4]
    ]
    np.testing.assert_allclose(ddG, np.stack(fd, axis=-1), rtol=0, atol=1e-8)
