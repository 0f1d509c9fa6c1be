"""The connection θ' = A(q)·q' of planar free-floating manipulators (models.connection).

The tests check the module against three references:

* the paper's printed eq. 6 and eq. 11, re-typed here independently as coefficient tables;
* the docs/planar_model.md §4 test vectors and the §5 uniform-rod table;
* conservation of angular momentum in the world frame, using test-local forward kinematics.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp

from stratcli.models.connection import (
    connection,
    connection_A,
    connection_gradient,
    connection_hessian,
    f_theta_and_f,
)
from stratcli.models.connection_symbolic import connection_symbolic, derive_symbolic
from stratcli.models.planar import (
    Arm,
    Base,
    Link,
    PlanarManipulator,
    link_geometry,
    paper_one_arm,
    paper_two_arm,
)

EQ6 = {  # one-arm model, M = 13, printed scale 12·M = 156
    "f1": (-1, {"1": 90, "2": 378, "3": 138, "12": 54, "23": 126, "123": 18, "": 636}),
    "f2": (-1, {"2": 189, "3": 138, "12": 54, "23": 63, "123": 18, "": 308}),
    "f3": (-1, {"3": 69, "23": 63, "123": 18, "": 88}),
    "ft": (1, {"1": 180, "2": 378, "3": 138, "12": 108, "23": 126, "123": 36, "": "845.2"}),
}


EQ11 = {  # two-arm model, M = 19, printed scale 12·M = 228
    "f1": (
        -1,
        {"1": 171, "2": 210, "12": 57, "13": 27, "123": 9, "134": 9, "1234": 3, "": 464},
    ),
    "f2": (-1, {"2": 105, "12": 57, "123": 9, "1234": 3, "": 130}),
    "f3": (
        1,
        {"3": 171, "13": 27, "123": 9, "4": 210, "34": 57, "134": 9, "1234": 3, "": 464},
    ),
    "f4": (1, {"4": 105, "34": 57, "134": 9, "1234": 3, "": 130}),
    "ft": (
        1,
        {
            "1": 342, "2": 210, "3": 342, "4": 210, "12": 114, "13": 54, "34": 114,
            "123": 18, "134": 18, "1234": 6, "": 1726,
        },
    ),
}  # fmt: skip


PAPER = {
    "one-arm": (paper_one_arm, EQ6, 3, 156),
    "two-arm": (paper_two_arm, EQ11, 4, 228),
}


def printed_numeric(eq, q):
    """Printed f_θ (...) and f (..., n) as plain numpy, q of shape (..., n)."""
    n = q.shape[-1]

    def poly(entry):
        sign, table = entry
        total = np.zeros(q.shape[:-1])
        for key, coeff in table.items():
            arg = sum((q[..., int(i) - 1] for i in key), np.zeros(q.shape[:-1]))
            total = total + float(Fraction(str(coeff))) * np.cos(arg)
        return sign * total

    return poly(eq["ft"]), np.stack([poly(eq[f"f{j}"]) for j in range(1, n + 1)], axis=-1)


def printed_A(eq, q):
    ft, f = printed_numeric(eq, q)
    return f / ft[..., None]


def printed_symbolic(eq, qs):
    """Printed f_θ and [f_j] as exact sympy expressions."""

    def poly(entry):
        sign, table = entry
        terms = (
            sp.Rational(str(coeff)) * sp.cos(sum(qs[int(i) - 1] for i in key))
            for key, coeff in table.items()
        )
        return sign * sp.Add(*terms)

    return poly(eq["ft"]), [poly(eq[f"f{j}"]) for j in range(1, len(qs) + 1)]


@pytest.fixture(scope="module")
def symbolic_paper():
    """derive_symbolic for both paper robots, computed once (about 0.4 s each)."""
    out = {}
    for name, (make, _, n, _) in PAPER.items():
        qs = sp.symbols(f"q1:{n + 1}", real=True)
        out[name] = (qs, *derive_symbolic(make(), qs))
    return out


def is_zero_trig(expr) -> bool:
    """Exact zero test for trigonometric polynomials: an expanded Laurent polynomial in e^{iq}."""
    return sp.expand(sp.sympify(expr).rewrite(sp.exp)) == 0


def random_three_arm(seed: int = 7) -> PlanarManipulator:
    """Three arms (2, 3 and 1 uniform-rod links) at off-axis mounts with odd zero angles."""
    rng = np.random.default_rng(seed)
    arms = []
    for n_links, sense in ((2, 1), (3, -1), (1, 1)):
        links = tuple(Link(rng.uniform(0.5, 2.0), rng.uniform(0.5, 1.5)) for _ in range(n_links))
        mount = tuple(rng.uniform(-1.0, 1.0, 2))
        arms.append(Arm(mount, rng.uniform(-math.pi, math.pi), sense, links))
    return PlanarManipulator(Base(rng.uniform(4.0, 8.0), rng.uniform(0.5, 2.0)), tuple(arms))


def small_generic() -> PlanarManipulator:
    """Two arms with off-axis mounts, π-multiple zero angles and explicit CM offsets/inertias."""
    arm1 = Arm((0.4, 0.25), math.pi / 3, 1, (Link(1.2, 0.9, 0.3, 0.05), Link(0.7, 1.1)))
    arm2 = Arm((-0.2, -0.5), -3 * math.pi / 4, -1, (Link(0.8, 0.6, 0.45, 0.02),))
    return PlanarManipulator(Base(6.5, 1.7), (arm1, arm2))


ROBOTS = {
    "one-arm": paper_one_arm,
    "two-arm": paper_two_arm,
    "three-arm": random_three_arm,
    "small-generic": small_generic,
}


def central_jacobian(func, q, h):
    """∂func_j/∂q_k by central differences, shape (..., n, n)."""
    n = q.shape[-1]
    cols = [(func(q + h * e) - func(q - h * e)) / (2 * h) for e in np.eye(n)]
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("name", PAPER)
def test_connection_equals_printed(name):
    make, eq, n, scale = PAPER[name]
    robot = make()
    q = np.random.default_rng(1).uniform(-np.pi, np.pi, (10_000, n))
    A, dA = connection(robot, q)
    assert A.shape == (10_000, n) and dA.shape == (10_000, n, n)
    assert np.max(np.abs(A - printed_A(eq, q))) <= 1e-14
    np.testing.assert_allclose(connection_A(robot, q), A, rtol=0, atol=1e-15)
    # The printed f are 12·M times the physical ones.
    ft, f = f_theta_and_f(robot, q)
    ft_p, f_p = printed_numeric(eq, q)
    assert np.max(np.abs(scale * ft - ft_p)) <= 1e-11
    assert np.max(np.abs(scale * f - f_p)) <= 1e-11


@pytest.mark.parametrize("name", PAPER)
def test_dA_equals_finite_differences_of_printed(name):
    make, eq, n, _ = PAPER[name]
    q = np.random.default_rng(2).uniform(-np.pi, np.pi, (10_000, n))
    _, dA = connection(make(), q)
    fd = central_jacobian(lambda x: printed_A(eq, x), q, 1e-5)
    assert np.max(np.abs(dA - fd)) <= 1e-8


@pytest.mark.parametrize("name", ["three-arm", "small-generic"])
def test_dA_equals_finite_differences_generic(name):
    robot = ROBOTS[name]()
    q = np.random.default_rng(3).uniform(-np.pi, np.pi, (2_000, robot.n_joints))
    _, dA = connection(robot, q)
    fd = central_jacobian(lambda x: connection_A(robot, x), q, 1e-5)
    assert np.max(np.abs(dA - fd)) <= 1e-8


def long_two_arm_chain() -> PlanarManipulator:
    """Two arms of 7 and 5 unequal links, so every distal/proximal case of the sums occurs."""
    rng = np.random.default_rng(11)

    def links(k):
        return tuple(
            Link(rng.uniform(0.2, 1.0), rng.uniform(0.2, 0.6), rng.uniform(0.05, 0.3))
            for _ in range(k)
        )

    arms = (Arm((0.5, 0.1), 0.4, 1, links(7)), Arm((-0.3, -0.4), 2.6, -1, links(5)))
    return PlanarManipulator(Base(9.0, 2.2), arms)


def single_link_arms() -> PlanarManipulator:
    """Three arms of one link each: no joint is proximal to another."""
    arms = tuple(
        Arm((0.4 * np.cos(a), 0.4 * np.sin(a)), a, 1 if i % 2 else -1, (Link(0.6 + 0.2 * i, 0.8),))
        for i, a in enumerate((0.3, 2.2, 4.1))
    )
    return PlanarManipulator(Base(5.0, 1.1), arms)


SECOND = {**ROBOTS, "two-arm-12": long_two_arm_chain, "single-link-arms": single_link_arms}


@pytest.mark.parametrize("name", SECOND)
def test_contracted_second_derivatives_equal_finite_differences(name):
    """Σ_j v_j ∂²A_j/∂q_k∂q_l in closed form equals central differences of the (tested) dA,
    with different weights at every point; each term of it is well above the tolerance."""
    robot = SECOND[name]()
    n = robot.n_joints
    rng = np.random.default_rng(5)
    q = rng.uniform(-np.pi, np.pi, (400, n))
    v = rng.normal(size=(400, n))
    A, dA, H = connection_hessian(robot, q, v)
    A0, dA0 = connection(robot, q)
    np.testing.assert_array_equal(A, A0)
    np.testing.assert_allclose(dA, dA0, rtol=0, atol=1e-15)
    fd = central_jacobian(
        lambda x: np.einsum("...j,...jk->...k", v, connection(robot, x)[1]), q, 1e-5
    )
    assert np.max(np.abs(H - fd)) <= 1e-8 * max(1.0, np.abs(H).max())
    assert np.max(np.abs(H - np.swapaxes(H, -1, -2))) <= 1e-14 * np.abs(H).max()
    assert np.median(np.abs(H)) > 1e-4  # real curvature, not zeros compared with zeros


@pytest.mark.parametrize("name", SECOND)
def test_contracted_first_derivatives_equal_dA(name):
    """Σ_j v_j ∂A_j/∂q_k in O(n) per point equals the full dA contracted."""
    robot = SECOND[name]()
    rng = np.random.default_rng(6)
    q = rng.uniform(-np.pi, np.pi, (3, 50, robot.n_joints))
    v = rng.normal(size=q.shape)
    A, g = connection_gradient(robot, q, v)
    A0, dA0 = connection(robot, q)
    np.testing.assert_array_equal(A, A0)
    np.testing.assert_allclose(g, np.einsum("...j,...jk->...k", v, dA0), rtol=0, atol=1e-14)


def test_models_md_test_vectors():
    r1, r2 = paper_one_arm(), paper_two_arm()
    # f_θ values are printed with 6 decimals in docs/planar_model.md §4.
    assert f_theta_and_f(r1, np.zeros(3))[0] == pytest.approx(11.610256, abs=5e-7)
    assert f_theta_and_f(r2, np.zeros(4))[0] == pytest.approx(13.833333, abs=5e-7)
    cases = [
        (r1, [0, 0, 0], [-0.795053003534, -0.425132508834, -0.131404593640]),
        (r1, [0.3, -0.7, 1.1], [-0.777481163549, -0.394981683014, -0.118548672416]),
        (
            r2,
            [0, 0, 0, 0],
            [-0.301204819277, -0.096385542169, 0.301204819277, 0.096385542169],
        ),
        (
            r2,
            [0.3, -0.7, 1.1, 0.5],
            [-0.317955781714, -0.101273832075, 0.274463475749, 0.081780403150],
        ),
    ]
    for robot, q, expected in cases:
        A, _ = connection(robot, np.array(q, dtype=float))
        np.testing.assert_allclose(A, expected, rtol=0, atol=1e-9)


def test_vectorised_over_leading_axes():
    robot = random_three_arm()
    q = np.random.default_rng(4).uniform(-3, 3, (2, 5, robot.n_joints))
    A, dA = connection(robot, q)
    geo = link_geometry(robot, q)
    assert A.shape == (2, 5, 6) and dA.shape == (2, 5, 6, 6)
    assert geo["com"].shape == (2, 5, 6, 2) and geo["system_com"].shape == (2, 5, 2)
    for idx in np.ndindex(2, 5):
        a, d = connection(robot, q[idx])
        np.testing.assert_allclose(a, A[idx], rtol=0, atol=1e-15)
        np.testing.assert_allclose(d, dA[idx], rtol=0, atol=1e-15)
        np.testing.assert_allclose(link_geometry(robot, q[idx])["distal"], geo["distal"][idx])
    # Long inputs are evaluated in blocks; the result must not depend on that.
    big = np.random.default_rng(5).uniform(-3, 3, (1_500, robot.n_joints))
    A_big, dA_big = connection(robot, big)
    a, d = connection(robot, big[1_234])
    np.testing.assert_allclose(A_big[1_234], a, rtol=0, atol=1e-15)
    np.testing.assert_allclose(dA_big[1_234], d, rtol=0, atol=1e-15)


def test_mirror_symmetry():
    """A mirror-image arm pair gives A_arm2(q) = −A_arm1(swapped q) (docs/planar_model.md §2)."""
    rng = np.random.default_rng(6)
    links = tuple(Link(*rng.uniform(0.5, 1.5, 2)) for _ in range(3))
    x, y, alpha = 0.7, 0.2, 0.4  # mirror about the base's y axis
    robot = PlanarManipulator(
        Base(5.0, 1.3),
        (Arm((x, y), alpha, 1, links), Arm((-x, y), math.pi - alpha, -1, links)),
    )
    q = rng.uniform(-np.pi, np.pi, (500, 6))
    swapped = np.concatenate([q[:, 3:], q[:, :3]], axis=1)
    A, A_sw = connection_A(robot, q), connection_A(robot, swapped)
    np.testing.assert_allclose(A[:, 3:], -A_sw[:, :3], rtol=0, atol=1e-14)
    # Mirror-symmetric motions (equal joint rates on both arms) leave the base still.
    sym = np.concatenate([q[:, :3], q[:, :3]], axis=1)
    A_sym = connection_A(robot, sym)
    np.testing.assert_allclose(A_sym[:, :3] + A_sym[:, 3:], 0.0, rtol=0, atol=1e-14)
    # The same holds for the paper's model 2.
    q2 = rng.uniform(-np.pi, np.pi, (500, 2))
    A2 = connection_A(paper_two_arm(), np.concatenate([q2, q2], axis=1))
    np.testing.assert_allclose(A2[:, :2] + A2[:, 2:], 0.0, rtol=0, atol=1e-14)


@pytest.mark.parametrize("name", PAPER)
def test_derive_symbolic_equals_printed_exactly(name, symbolic_paper):
    _, eq, _, scale = PAPER[name]
    qs, f_theta, f = symbolic_paper[name]
    ft_p, f_p = printed_symbolic(eq, qs)
    for derived, printed in zip([f_theta, *f], [ft_p, *f_p], strict=True):
        assert all(x.is_Rational for x in derived.atoms(sp.Number))
        assert is_zero_trig(scale * derived - printed)
        # The canonical form is the paper's form, so plain expansion already cancels.
        assert sp.expand(scale * derived - printed) == 0


def test_connection_symbolic_matches_numeric():
    robot = small_generic()
    qs = sp.symbols("q1:4", real=True)
    A_sym = connection_symbolic(robot, qs)
    dA_sym = [[sp.diff(a, qk) for qk in qs] for a in A_sym]
    A_fun = sp.lambdify(qs, A_sym, "numpy")
    dA_fun = sp.lambdify(qs, dA_sym, "numpy")
    q = np.random.default_rng(8).uniform(-np.pi, np.pi, (500, 3))
    A, dA = connection(robot, q)
    A_ref = np.stack(A_fun(*q.T), axis=-1)
    dA_ref = np.moveaxis(np.array(dA_fun(*q.T)), -1, 0)
    assert np.max(np.abs(A - A_ref)) <= 1e-13
    assert np.max(np.abs(dA - dA_ref)) <= 1e-13


def test_uniform_rod_constant_terms():
    """docs/planar_model.md §5: rod links (I = m l²/12) change only the constant terms."""
    rods = {
        "one-arm": ([-519, -230, -49], Fraction("728.2")),
        "two-arm": ([-350, -73, 350, 73], Fraction(1498)),
    }
    for name, (make, eq, n, scale) in PAPER.items():
        paper = make()
        rod = PlanarManipulator(
            paper.base,
            tuple(
                Arm(arm.mount, arm.zero_angle, arm.sense, tuple(Link(1, 1) for _ in arm.links))
                for arm in paper.arms
            ),
        )
        assert all(link.inertia == pytest.approx(1 / 12) for link in rod.links)
        qs = sp.symbols(f"q1:{n + 1}", real=True)
        ft, f = derive_symbolic(rod, qs)
        ft_p, f_p = printed_symbolic(eq, qs)
        f_consts, ft_const = rods[name]
        for derived, printed, const in zip(
            [ft, *f], [ft_p, *f_p], [ft_const, *f_consts], strict=True
        ):
            scaled, printed = sp.expand(scale * derived), sp.expand(printed)
            constant = scaled.as_independent(*qs, as_Add=True)[0]
            assert constant == sp.Rational(const.numerator, const.denominator)
            # Only the constant changes: the cosine terms are the paper's.
            printed_constant = printed.as_independent(*qs, as_Add=True)[0]
            assert is_zero_trig(scaled - constant - (printed - printed_constant))


def world_state(robot: PlanarManipulator, q: np.ndarray, theta: np.ndarray):
    """Independent forward kinematics: world CM positions r (..., bodies, 2) and absolute
    angles φ (..., bodies) of all bodies (base first), with the system CM at the origin."""
    pos, ang = [np.zeros((*q.shape[:-1], 2))], [np.zeros(q.shape[:-1])]
    j = 0
    for arm in robot.arms:
        joint = np.broadcast_to(np.array(arm.mount, dtype=float), (*q.shape[:-1], 2))
        angle = np.full(q.shape[:-1], arm.zero_angle)
        for link in arm.links:
            angle = angle + arm.sense * q[..., j]
            u = np.stack([np.cos(angle), np.sin(angle)], axis=-1)
            pos.append(joint + link.com * u)
            ang.append(angle)
            joint = joint + link.length * u
            j += 1
    p = np.stack(pos, axis=-2)
    masses = np.array([robot.base.mass] + [link.mass for link in robot.links])
    pc = np.einsum("k,...kd->...d", masses, p) / masses.sum()
    rel = p - pc[..., None, :]
    c, s = np.cos(theta)[..., None], np.sin(theta)[..., None]
    r = np.stack([c * rel[..., 0] - s * rel[..., 1], s * rel[..., 0] + c * rel[..., 1]], -1)
    return r, theta[..., None] + np.stack(ang, axis=-1)


@pytest.mark.parametrize("name", ["one-arm", "two-arm", "three-arm"])
def test_angular_momentum_is_conserved(name):
    robot = ROBOTS[name]()
    n = robot.n_joints
    rng = np.random.default_rng(9)
    q0, amp, omega, phase = (rng.uniform(-1.5, 1.5, (2, n)) for _ in range(4))
    q0, omega = q0[0], np.abs(omega) + 0.5

    def q_of(t):  # smooth joint motion and its exact velocity
        arg = omega * t[..., None, None] + phase
        q = q0 + np.sum(amp * np.sin(arg), axis=-2)
        return q, np.sum(amp * omega * np.cos(arg), axis=-2)

    # θ(t) = θ0 + ∫_0^t A(q)·q' dτ, by 40-point Gauss–Legendre quadrature on [0, t].
    nodes, weights = np.polynomial.legendre.leggauss(40)
    theta0 = 0.3

    def theta_of(t):
        tau = 0.5 * t[..., None] * (nodes + 1.0)
        q, qd = q_of(tau)
        rate = np.sum(connection_A(robot, q) * qd, axis=-1)
        return theta0 + 0.5 * t * np.sum(weights * rate, axis=-1)

    # 4th-order central differences of world positions and angles.
    h = 1e-3
    stencil = np.array([-2.0, -1.0, 1.0, 2.0]) * h
    t = np.linspace(0.1, 1.5, 15)
    ts = t[:, None] + stencil  # (T, 4)
    masses = np.array([robot.base.mass] + [link.mass for link in robot.links])
    inertias = np.array([robot.base.inertia] + [link.inertia for link in robot.links])
    fd = np.array([1.0, -8.0, 8.0, -1.0]) / (12 * h)

    def momentum(theta_t, theta_s):
        r, _ = world_state(robot, q_of(t)[0], theta_t)
        r_s, phi_s = world_state(robot, q_of(ts)[0], theta_s)
        v = np.einsum("s,tskd->tkd", fd, r_s)
        phi_dot = np.einsum("s,tsk->tk", fd, phi_s)
        cross = r[..., 0] * v[..., 1] - r[..., 1] * v[..., 0]
        linear = np.einsum("k,tkd->td", masses, v)
        return cross @ masses + phi_dot @ inertias, linear

    L, linear = momentum(theta_of(t), theta_of(ts))
    assert np.max(np.abs(L)) <= 1e-8
    assert np.max(np.abs(linear)) <= 1e-8
    # Without the base reaction (θ' = 0) the momentum is clearly not conserved.
    L_fixed, _ = momentum(np.full_like(t, theta0), np.full_like(ts, theta0))
    assert np.max(np.abs(L_fixed)) > 1e-2

    # link_geometry agrees with the independent kinematics (base frame, θ = 0).
    q = q_of(t)[0]
    geo = link_geometry(robot, q)
    r, phi = world_state(robot, q, np.zeros_like(t))
    np.testing.assert_allclose(geo["com"] - geo["system_com"][:, None], r[:, 1:], atol=1e-14)
    np.testing.assert_allclose(-geo["system_com"], r[:, 0], atol=1e-14)
    np.testing.assert_allclose(geo["angle"], phi[:, 1:], atol=1e-14)
    seg = geo["distal"] - geo["proximal"]
    lengths = np.array([link.length for link in robot.links])
    np.testing.assert_allclose(np.hypot(seg[..., 0], seg[..., 1]), lengths + 0 * t[:, None])
