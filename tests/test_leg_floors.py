"""The screen's leg floors (`stratcli.leg_floors`): below the energy of every plan of the leg,
whatever its controls, on an independent integration; exact for a straight leg; joints only
where the connection is not periodic."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from stratcli.leg_floors import leg_floor
from stratcli.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
T = 1.0


@pytest.fixture(scope="module")
def one_arm():
    return load_scenario(ROOT / "scenarios" / "sim4_auto.toml").system


def flow(system, stratum: str):
    """q̇ = G(q) u on `stratum`, from the model's symbolic fields (not stratplan's numerics)."""
    G = sp.lambdify(system.symbols, system.fields_on(system.stratum(stratum)), "numpy")
    return lambda q, u: np.asarray(G(*q), dtype=float) @ u


def controls(rng, m: int, loop: bool):
    """Random smooth controls on [0, T]: a few harmonics (a closed loop of the inputs'
    integrals when `loop`: no constant part) plus, if not, a constant."""
    k = np.arange(1, 4)
    a, phase = rng.normal(size=(m, 3)) * 3.0 / k, rng.uniform(0, 2 * np.pi, (m, 3))
    bias = np.zeros(m) if loop else rng.normal(size=m) * 1.5

    def u(t):
        return bias + (a * np.cos(2 * np.pi * k * t / T + phase)).sum(axis=1)

    return u


def run(system, stratum, start, u):
    """The end of the leg and its energy ∫|u|², both by scipy at tight tolerances."""
    f = flow(system, stratum)
    m = len(system.stratum(stratum).active)

    def rhs(t, y):
        ut = u(t)
        return np.concatenate([f(y[:-1], ut), [ut @ ut]])

    sol = solve_ivp(rhs, (0, T), np.concatenate([start, [0.0]]), rtol=1e-11, atol=1e-12)
    assert sol.success and m > 0
    return sol.y[:-1, -1], sol.y[-1, -1]


@pytest.mark.parametrize("stratum", ["S1", "S2", "S3"])
def test_floor_is_below_the_energy_of_random_plans(one_arm, stratum):
    rng = np.random.default_rng(sum(map(ord, stratum)))
    m = len(one_arm.stratum(stratum).active)
    ratios = []
    for k in range(12):
        start = rng.uniform(-np.pi, np.pi, one_arm.n)
        end, energy = run(one_arm, stratum, start, controls(rng, m, loop=k % 2 == 0))
        floor = leg_floor(one_arm, stratum, start, end, T)
        assert 0.0 <= floor <= energy * (1 + 1e-9)
        ratios.append(floor / energy)
    assert max(ratios) > 0.05  # the floors are not all trivially 0


def test_floor_of_a_closed_loop_comes_from_the_base(one_arm):
    """The joints return where they started; the base does not: only the curvature bound
    can be positive, and it is."""
    rng = np.random.default_rng(3)
    start = np.array([0.3, -0.4, 0.8, 0.0])
    end, energy = run(one_arm, "S2", start, controls(rng, 2, loop=True))
    active = [0, 2]  # S2 drives q1 and q3
    assert np.allclose(end[active], start[active], atol=1e-9) and abs(end[3] - start[3]) > 1e-3
    floor = leg_floor(one_arm, "S2", start, end, T)
    assert 0.0 < floor <= energy


def test_floor_of_a_straight_leg_is_its_energy(one_arm):
    """Constant joint rates: the straight segment itself, energy |Δq|²/T, and the floor."""
    start = np.array([0.2, 0.5, -0.3, 0.1])
    rates = np.array([1.1, -0.7])
    end, energy = run(one_arm, "S2", start, lambda t: rates)
    assert energy == pytest.approx(rates @ rates * T, rel=1e-9)
    assert leg_floor(one_arm, "S2", start, end, T) == pytest.approx(energy, rel=1e-5)


def test_free_goal_entries_drop_what_they_bound(one_arm):
    start = np.array([0.2, 0.5, -0.3, 0.1])
    rng = np.random.default_rng(5)
    end, _ = run(one_arm, "S2", start, controls(rng, 2, loop=True))
    full = leg_floor(one_arm, "S2", start, end, T)
    free_base = end.copy()
    free_base[3] = np.nan
    assert leg_floor(one_arm, "S2", start, free_base, T) <= full
    assert leg_floor(one_arm, "S2", start, free_base, T) == pytest.approx(0.0, abs=1e-9)


def heisenberg():
    """x, y driven at unit rate, z̃ = (x ẏ - y ẋ)/2: curvature 1 everywhere, not periodic."""
    return load_scenario(
        {
            "name": "heisenberg",
            "model": {
                "kind": "custom",
                "states": ["x", "y", "z"],
                "inputs": ["u1", "u2"],
                "fields": {"u1": [1, 0, "-y/2"], "u2": [0, 1, "x/2"]},
                "strata": [{"name": "both", "active": ["u1", "u2"]}],
            },
            "task": {"start": [0, 0, 0], "goal": [0, 0, 1]},
            "planner": {"continuity": "none", "leg_duration": 1.0},
            "legs": [{"stratum": "both"}],
        }
    ).system


def test_without_a_periodic_connection_only_the_joints_bound():
    system = heisenberg()
    start = np.zeros(3)
    # a loop enclosing area 1 (z = 1): the base's bound would be positive, but |F| is
    # unknown over the unbounded plane, so only the joints count (they return: 0)
    assert leg_floor(system, "both", start, np.array([0.0, 0.0, 1.0]), T) == 0.0
    # a straight move: the joints' bound |Δq|²/T
    assert leg_floor(system, "both", start, np.array([3.0, 4.0, 0.0]), T) == pytest.approx(
        25.0 / T, rel=1e-5
    )


def test_no_floor_where_the_joints_cannot_get_there(one_arm):
    """S1 drives q2 and q3, not q1: a goal that moves q1 gets no floor (the search reports
    the leg); one that moves q3 gets the joints' bound at least."""
    start = np.zeros(4)
    assert leg_floor(one_arm, "S1", start, np.array([1.0, 0.0, 0.0, 0.0]), T) == 0.0
    assert leg_floor(one_arm, "S1", start, np.array([0.0, 0.0, 1.0, 0.0]), T) >= 1.0 - 1e-5
