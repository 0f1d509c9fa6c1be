"""The spatial end-point map: the golden case of docs/spatial_model.md, 4th order, an independent
integration on (joints, quaternion) and the Jacobian by finite differences."""

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pinocchio")

from scipy.integrate import solve_ivp

from stratcli import so3
from stratcli.controls import FourierBasis
from stratcli.models.spatial import load_spatial

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
GOLDEN = {  # docs/spatial_model.md: final base rotation vector and position after the joint cycle
    (1, 2): ([0.0, -0.006566044, 0.0], [0.001976985, 0.0, -0.002182199]),
    (0, 1): ([0.094376884, 0.002846003, 0.037572737], [-0.001147343, 0.015700905, 0.001692659]),
}


@pytest.fixture(scope="module")
def arm3():
    return load_spatial(ROBOTS / "arm3.urdf")


def _cycle(system, i, j, steps=None):
    """+a e_i, +a e_j, −a e_i, −a e_j at 0.5 rad/s for 1 s each, on the stratum locking the
    third joint; returns the final configuration."""
    other = ({0, 1, 2} - {i, j}).pop()
    cs = system.compiled(f"S{other + 1}")
    basis = FourierBasis(harmonics=1, period=2.0)
    y = np.zeros(6)
    for joint, sign in ((i, 1), (j, 1), (i, -1), (j, -1)):
        L = np.zeros((2, 3))
        L[list(cs.act).index(joint), 0] = 0.5 * sign
        ep = cs.endpoint(y, basis, 1.0)
        ep.steps_override = steps
        y, _ = ep(L.ravel(), jacobian=False)
    return y


@pytest.mark.parametrize("cycle", sorted(GOLDEN))
def test_golden_case(arm3, cycle):
    rotation, position = GOLDEN[cycle]
    y = _cycle(arm3, *cycle)
    np.testing.assert_allclose(y[:3], 0.0, atol=1e-15)
    np.testing.assert_allclose(y[3:], rotation, atol=1e-8, rtol=0)
    c0 = arm3.spatial.com_in_base(np.zeros(3))[0]  # the base starts at the origin
    moved = c0 - so3.exp(y[3:]) @ c0
    np.testing.assert_allclose(moved, position, atol=1e-8, rtol=0)


def test_fourth_order(arm3):
    """Halving the step divides the error by ~16 (the wrong commutator sign gives 4)."""
    exact = _cycle(arm3, 0, 1, steps=256)[3:]
    e1 = np.linalg.norm(_cycle(arm3, 0, 1, steps=2)[3:] - exact)
    e2 = np.linalg.norm(_cycle(arm3, 0, 1, steps=4)[3:] - exact)
    assert 10 < e1 / e2 < 24, (e1, e2)


def _quaternion_reference(system, cs, q0, basis, duration, lam):
    """solve_ivp on (joints, quaternion), renormalised, rtol 1e-12 (no Magnus, no log map)."""
    k, L = cs.k, lam.reshape(len(cs.act), basis.size)
    robot = system.spatial

    def rhs(t, y):
        u = cs.C_explicit @ (L @ basis.values(t))
        quat = y[k:] / np.linalg.norm(y[k:])
        S, _ = robot.connection(y[:k][None])
        w, x, yq, z = quat
        xi = S[0, 3:] @ u
        # q' = 1/2 q ⊗ (0, ξ): body-frame rate
        dq = 0.5 * np.array(
            [
                -x * xi[0] - yq * xi[1] - z * xi[2],
                w * xi[0] + yq * xi[2] - z * xi[1],
                w * xi[1] + z * xi[0] - x * xi[2],
                w * xi[2] + x * xi[1] - yq * xi[0],
            ]
        )
        return np.concatenate([u, dq])

    y0 = np.concatenate([q0[:k], so3.quaternion_from_matrix(so3.exp(q0[k:]))])
    sol = solve_ivp(rhs, (0, duration), y0, method="DOP853", rtol=1e-12, atol=1e-14)
    assert sol.success
    quat = sol.y[k:, -1] / np.linalg.norm(sol.y[k:, -1])
    return sol.y[:k, -1], so3.matrix_from_quaternion(quat)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_endpoint_matches_independent_integration(arm3, seed):
    rng = np.random.default_rng(seed)
    basis = FourierBasis(harmonics=3, period=2.17)
    cs = arm3.compiled(["S1", "S2", "S3"][seed])
    q0 = np.concatenate([rng.uniform(-1, 1, 3), rng.uniform(-0.5, 0.5, 3)])
    lam = rng.normal(0.0, 0.6, len(cs.act) * basis.size)
    end, _ = cs.endpoint(q0, basis, 2.0)(lam, jacobian=False)
    joints, R = _quaternion_reference(arm3, cs, q0, basis, 2.0, lam)
    np.testing.assert_allclose(end[:3], joints, atol=1e-11, rtol=0)
    group_error = np.linalg.norm(so3.log(R.T @ so3.exp(end[3:])))
    assert group_error < 1e-9, group_error


def test_jacobian_matches_finite_differences(arm3):
    rng = np.random.default_rng(7)
    basis = FourierBasis(harmonics=2, period=2.17)
    cs = arm3.compiled("S2")
    q0 = np.array([0.2, -0.1, 0.4, 0.1, -0.2, 0.3])
    ep = cs.endpoint(q0, basis, 1.5)
    ep.steps_override = 64  # a fixed discretisation: the Jacobian is its exact derivative
    lam = rng.normal(0.0, 0.5, ep.n_coefficients)
    _, J = ep(lam)
    h = 1e-6
    fd = np.column_stack(
        [
            (ep(lam + h * e, False)[0] - ep(lam - h * e, False)[0]) / (2 * h)
            for e in np.eye(lam.size)
        ]
    )
    np.testing.assert_allclose(J, fd, atol=1e-8, rtol=0)


def test_seven_joint_arm_matches_independent_integration():
    """Fewer steps where the arm turns the bus less (`MagnusEndpoint.coupling`): still 1e-9."""
    arm7 = load_spatial(ROBOTS / "bus_arm7.urdf")
    rng = np.random.default_rng(5)
    basis = FourierBasis(harmonics=3, period=2.17)
    cs = arm7.compiled("S4")
    q0 = np.concatenate([rng.uniform(-1, 1, 7), rng.uniform(-0.5, 0.5, 3)])
    lam = rng.normal(0.0, 0.6, len(cs.act) * basis.size)
    end, _ = cs.endpoint(q0, basis, 2.0)(lam, jacobian=False)
    joints, R = _quaternion_reference(arm7, cs, q0, basis, 2.0, lam)
    np.testing.assert_allclose(end[:7], joints, atol=1e-11, rtol=0)
    assert np.linalg.norm(so3.log(R.T @ so3.exp(end[7:]))) < 1e-9


def test_far_from_the_goal_the_map_is_coarse_but_accurate_to_its_error(arm3):
    basis = FourierBasis(harmonics=3, period=2.17)
    cs = arm3.compiled("S3")
    q0 = np.array([0.3, -0.2, 0.0, 0.1, 0.0, -0.1])
    lam = np.random.default_rng(3).normal(0.0, 0.3, 2 * basis.size)
    ep = cs.endpoint(q0, basis, 2.0)
    exact = ep.refined(lam)
    targets = np.arange(6)
    far = exact.copy()
    far[3:] += 0.3  # a goal 0.5 rad away
    ep.residual(exact, None, far[targets], targets)
    calls = []
    march = ep._march
    ep._march = lambda L, jac, steps=None: calls.append(steps) or march(L, jac, steps)
    end, _ = ep(lam, jacobian=False)
    assert calls[0] < ep.steps(lam.reshape(2, -1)) // 2  # coarse
    gap = np.linalg.norm(so3.log(so3.exp(exact[3:]).T @ so3.exp(end[3:])))
    assert gap <= 1e-3 * 0.5


@pytest.mark.parametrize("far", [False, True])
def test_a_jacobian_added_later_is_the_one_evaluated_with_the_end(arm3, far):
    """Value first, Jacobian afterwards (`jacobian_of_last`): bitwise what one evaluation
    with both gives, also on coarse steps far from the goal; a repeated call is remembered."""
    basis = FourierBasis(harmonics=3, period=2.17)
    cs = arm3.compiled("S3")
    q0 = np.array([0.3, -0.2, 0.0, 0.1, 0.0, -0.1])
    lam = np.random.default_rng(5).normal(0.0, 0.3, 2 * basis.size)
    targets = np.arange(6)
    both, later = cs.endpoint(q0, basis, 2.0), cs.endpoint(q0, basis, 2.0)
    if far:  # a goal 0.5 rad away: coarse steps (else the full ones, no goal known yet)
        goal = both.refined(lam) + 0.3
        for ep in (both, later):
            ep.residual(goal, None, goal[targets] + 1e-3, targets)
    steps = []
    march = later._march
    later._march = lambda L, jac, n=None: steps.append(n) or march(L, jac, n)
    end, J = both(lam, True)
    end_only, none = later(lam, False)
    assert none is None
    full = later.steps(lam.reshape(2, -1))
    assert (steps[-1] < full // 2) if far else (steps[-1] == full)
    end_later, J_later = later.jacobian_of_last(lam)
    np.testing.assert_array_equal(end_only, end)
    np.testing.assert_array_equal(end_later, end)
    np.testing.assert_array_equal(J_later, J)
    calls = len(steps)
    again, J_again = later(lam, True)
    assert len(steps) == calls  # not marched again
    np.testing.assert_array_equal(again, end)
    np.testing.assert_array_equal(J_again, J)


def test_newton_with_jacobians_added_later_takes_the_same_steps(arm3):
    """`damped_gauss_newton` with `jacobian_after` (Jacobians only of accepted steps) ends
    bitwise where it ends with every full step's Jacobian evaluated eagerly."""
    from stratcli.planners.base import damped_gauss_newton

    basis = FourierBasis(harmonics=2, period=2.0)
    cs = arm3.compiled("S3")
    q0 = np.zeros(6)
    targets = np.arange(6)
    goal = np.array([0.4, -0.3, 0.0, 0.02, -0.01, 0.03])
    results = []
    for deferred in (False, True):
        ep = cs.endpoint(q0, basis, 2.0)
        last = []

        def evaluate(z, jacobian, ep=ep, last=last):
            last[:] = [z]
            end, J = ep(z, jacobian)
            r, Jt = ep.residual(end, J, goal[targets], targets)
            return -r, Jt, (z, end)

        def jacobian_after(ep=ep, last=last):
            end, J = ep.jacobian_of_last(last[0])
            return ep.residual(end, J, goal[targets], targets)[1]

        z0 = np.random.default_rng(2).normal(0.0, 0.1, 2 * basis.size)
        results.append(
            damped_gauss_newton(
                evaluate,
                z0,
                tolerance=1e-9,
                max_iterations=30,
                mu=1e-3,
                jacobian_after=jacobian_after if deferred else None,
            )
        )
    eager, deferred = results
    assert eager.error <= 1e-9
    assert eager.iterations == deferred.iterations
    np.testing.assert_array_equal(deferred.z, eager.z)


def test_the_attitude_error_and_its_jacobian_on_the_group():
    """The residual of a fully targeted attitude is log(R_goalᵀ R(φ)) (the goal's frame: the
    rotation left to do, not R R_goalᵀ), with its Jacobian J_r⁻¹(e) J_r(φ) ∂φ/∂λ equal to
    finite differences, far from the goal as near it."""
    from stratcli.magnus import residual_on_group

    rng = np.random.default_rng(5)
    k, n, p = 2, 5, 7  # two joints, then the attitude (rx, ry, rz); seven coefficients
    end0, J = rng.normal(size=n), rng.normal(size=(n, p))
    targets = np.arange(n)
    for goal_attitude in (rng.normal(size=3) * 1.2, end0[k:] + 1e-3):
        aim = np.concatenate([rng.normal(size=k), goal_attitude])
        r, Jr = residual_on_group(end0, J, aim, targets, k)
        e = so3.log(so3.exp(goal_attitude).T @ so3.exp(end0[k:]))
        np.testing.assert_allclose(r[k:], e, atol=1e-12)
        np.testing.assert_allclose(r[:k], end0[:k] - aim[:k], atol=1e-15)
        h = 1e-6
        numeric = np.column_stack([
            (residual_on_group(end0 + h * J[:, j], None, aim, targets, k)[0]
             - residual_on_group(end0 - h * J[:, j], None, aim, targets, k)[0]) / (2 * h)
            for j in range(p)
        ])  # fmt: skip
        np.testing.assert_allclose(Jr, numeric, atol=1e-7)
