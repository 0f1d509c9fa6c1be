"""SO(3) helpers: exp/log inverse, Jacobians by finite differences, quaternions, RPY."""

import numpy as np
import pytest

from stratcli import so3


@pytest.fixture
def phis():
    rng = np.random.default_rng(3)
    v = rng.normal(size=(20, 3))
    v *= rng.uniform(1e-9, 3.1, size=(20, 1)) / np.linalg.norm(v, axis=1, keepdims=True)
    return np.vstack([v, [[0, 0, 0], [1e-6, 0, 0], [0, 0, np.pi - 1e-9]]])


def test_log_inverts_exp(phis):
    R = so3.exp(phis)
    assert so3.orthogonality_error(R) < 1e-14
    np.testing.assert_allclose(so3.log(R), phis, atol=1e-12, rtol=0)


def test_right_jacobian_by_finite_differences(phis):
    h = 1e-6
    for phi in phis[:-1]:
        Jr = so3.right_jacobian(phi)
        R = so3.exp(phi)
        fd = np.column_stack(
            [
                so3.log(R.T @ so3.exp(phi + h * e)) - so3.log(R.T @ so3.exp(phi - h * e))
                for e in np.eye(3)
            ]
        ) / (2 * h)
        np.testing.assert_allclose(Jr, fd, atol=1e-8)
        np.testing.assert_allclose(so3.right_jacobian_inverse(phi) @ Jr, np.eye(3), atol=1e-12)


def test_quaternion_round_trip(phis):
    R = so3.exp(phis)
    q = so3.quaternion_from_matrix(R)
    assert np.all(q[:, 0] >= 0)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)
    np.testing.assert_allclose(so3.matrix_from_quaternion(q), R, atol=1e-14)


def test_rpy_is_fixed_axes_x_then_y_then_z():
    r, p, y = 0.3, -0.2, 1.1
    R = so3.rpy_to_matrix([r, p, y])
    expected = so3.exp([0, 0, y]) @ so3.exp([0, p, 0]) @ so3.exp([r, 0, 0])
    np.testing.assert_allclose(R, expected, atol=1e-15)
    # URDF: roll about x first: a roll alone is exp([r, 0, 0])
    np.testing.assert_allclose(so3.rpy_to_matrix([r, 0, 0]), so3.exp([r, 0, 0]), atol=1e-15)


def test_cross_is_numpys_bit_for_bit(phis):
    a, b = phis, np.roll(phis, 1, axis=0) * 1.7
    np.testing.assert_array_equal(so3.cross(a, b), np.cross(a, b))
    np.testing.assert_array_equal(so3.cross(a[0], b[3]), np.cross(a[0], b[3]))


def test_quaternions_of_few_and_of_many_matrices_agree_bit_for_bit(phis):
    """The Python-float path (up to 8 matrices) and the vectorised one (more) run the same
    arithmetic, every Shepperd case included (angles up to π, about every axis)."""
    R = so3.exp(np.vstack([phis, np.pi * np.eye(3), -2.5 * np.eye(3)]))
    many = so3.quaternion_from_matrix(R)
    few = np.array([so3.quaternion_from_matrix(Ri) for Ri in R])
    np.testing.assert_array_equal(few, many)
    np.testing.assert_allclose(so3.matrix_from_quaternion(many), R, atol=1e-15)
