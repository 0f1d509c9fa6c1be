"""stratcli.odeint.dop853 is scipy's DOP853: same states at the same times."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from stratcli.odeint import OutOfSteps, dop853


def _pendulum(t, y):
    return np.array([y[1], -np.sin(y[0]) + 0.3 * np.cos(2.0 * t)])


def _rotation_with_drift(t, y):
    return np.array([-y[1] + 0.1 * np.sin(5 * t), y[0], 0.5 * y[0] * y[1]])


@pytest.mark.parametrize(
    "fun, y0, t_end",
    [(_pendulum, [1.0, 0.0], 7.3), (_rotation_with_drift, [1.0, 0.0, 0.2], 3.0)],
    ids=["pendulum", "rotation"],
)
@pytest.mark.parametrize("rtol, atol", [(1e-10, 1e-12), (1e-6, 1e-9)])
def test_same_states_as_scipy(fun, y0, t_end, rtol, atol):
    t_eval = np.unique(np.r_[0.0, np.sort(np.random.default_rng(0).uniform(0, t_end, 57)), t_end])
    ours = dop853(fun, t_end, np.array(y0), t_eval, rtol=rtol, atol=atol)
    ref = solve_ivp(fun, (0.0, t_end), y0, method="DOP853", t_eval=t_eval, rtol=rtol, atol=atol)
    assert ref.success
    np.testing.assert_allclose(ours, ref.y.T, rtol=1e-12, atol=1e-14)
    assert np.array_equal(ours[0], y0)


def test_a_solution_that_blows_up_stops_with_out_of_steps():
    """y' = y², y(0) = 1 reaches infinity at t = 1."""
    with pytest.raises(OutOfSteps):
        dop853(lambda t, y: y**2, 2.0, np.array([1.0]), np.array([0.5, 2.0]), 1e-10, 1e-12)


def test_dense_output_in_batches_gives_the_same_states(monkeypatch):
    """Points are interpolated a batch of steps at a time; any batch size, the same numbers."""
    import stratcli.odeint as odeint

    t_eval = np.linspace(0.0, 7.3, 301)
    whole = dop853(_pendulum, 7.3, np.array([1.0, 0.0]), t_eval, 1e-10, 1e-12)
    monkeypatch.setattr(odeint, "_BATCH", 7)
    batched = dop853(_pendulum, 7.3, np.array([1.0, 0.0]), t_eval, 1e-10, 1e-12)
    assert np.array_equal(batched, whole) and np.isfinite(whole).all()
