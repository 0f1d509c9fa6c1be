"""The SQP step's dense pieces (planners.active_set): non-negative least squares, the QP by
least distance (its optimality conditions), and the convexified model Hessian."""

from __future__ import annotations

import numpy as np
import pytest

from stratcli.planners.active_set import convexified, least_distance, nnls


@pytest.mark.parametrize("seed", range(5))
def test_nnls_meets_the_optimality_conditions(seed):
    rng = np.random.default_rng(seed)
    E, f = rng.normal(size=(8, 15)), rng.normal(size=8)
    x = nnls(E, f)
    w = E.T @ (f - E @ x)  # minus the gradient of ½|Ex - f|²
    assert x.min() >= 0
    assert np.all(w <= 1e-10)  # no descent into the feasible set
    assert np.abs(w[x > 0]).max(initial=0.0) <= 1e-10  # stationary where free


@pytest.mark.parametrize("seed", range(5))
def test_least_distance_is_the_closest_point_of_the_polyhedron(seed):
    rng = np.random.default_rng(seed)
    n, m = 6, 40
    A, inside = rng.normal(size=(m, n)), rng.normal(size=n)
    b = A @ inside - rng.exponential(size=m)  # a polyhedron around `inside`
    w, nu = least_distance(A, b)
    slack = A @ w - b
    assert slack.min() >= -1e-10
    assert nu.min() >= 0
    assert np.allclose(w, A.T @ nu, atol=1e-10)  # stationarity of ½|w|² - νᵀ(Aw - b)
    assert np.abs(nu * slack).max() <= 1e-10  # complementarity


@pytest.mark.parametrize("seed", range(5))
def test_a_warm_start_gives_the_cold_solution_in_fewer_iterations(seed):
    """The NNLS started from a passive set (the true one perturbed: columns added, one
    dropped) ends where it ends from zero, and from the true set at once."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(60, 6))
    b = A @ rng.normal(size=6) - rng.exponential(size=60)  # least distance's NNLS, as used
    E, f = np.vstack([A.T, b]), np.eye(7)[-1]
    cold = nnls(E, f)
    true = cold > 0
    assert 2 <= true.sum() < 7  # a real active set (not all or none of the columns)
    guess = true | (rng.random(60) < 0.2)
    guess[np.flatnonzero(true)[0]] = False
    assert np.allclose(nnls(E, f, passive=guess), cold, atol=1e-12)
    assert np.allclose(nnls(E, f, max_iterations=1, passive=true), cold, atol=1e-12)
    assert not np.allclose(nnls(E, f, max_iterations=1), cold, atol=1e-6)  # cold: one is not


def test_least_distance_says_when_no_point_meets_the_constraints():
    A = np.array([[1.0, 0.0], [-1.0, 0.0]])
    assert least_distance(A, np.array([1.0, 1.0])) is None  # x ≥ 1 and x ≤ -1


def test_convexified_keeps_the_curvature_on_the_null_space_of_the_active_gradients():
    rng = np.random.default_rng(3)
    n = 7
    Q = np.linalg.qr(rng.normal(size=(n, n)))[0]
    B = Q[:2].copy()  # two active gradients
    N = Q[2:].T
    inner = np.diag([3.0, 1.0, 0.5, 4.0, 2.0])  # positive definite on the null space
    R = N @ inner @ N.T - 30.0 * (B.T @ B) + 5.0 * (B.T @ N.T[:2] + N.T[:2].T @ B)
    out = convexified(R, B, floor=1e-2)
    assert np.linalg.eigvalsh(out).min() > 0
    assert np.allclose(N.T @ out @ N, N.T @ R @ N)
    flat = convexified(-np.eye(3), np.zeros((0, 3)), floor=1e-2)  # nothing active: floored
    assert np.allclose(flat, 2e-2 * np.eye(3))
