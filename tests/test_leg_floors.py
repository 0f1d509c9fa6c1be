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


def test_floor_is_below_the_energy_of_random_plans_of_a_physical_robot():
    """A planar-manipulator model (its connection from the physics, evaluated in closed form
    by the planner, symbolically here): the floors exist and hold too."""
    robot = load_scenario(ROOT / "scenarios" / "rods_three_link.toml").system
    rng = np.random.default_rng(11)
    ratios = []
    for k in range(12):
        stratum = ("S1", "S2", "S3")[k % 3]
        start = rng.uniform(-np.pi, np.pi, robot.n)
        end, energy = run(robot, stratum, start, controls(rng, 2, loop=k % 2 == 0))
        floor = leg_floor(robot, stratum, start, end, T)
        assert 0.0 <= floor <= energy * (1 + 1e-9)
        ratios.append(floor / energy)
    assert max(ratios) > 0.05


def _circle(r: float, half: bool = False):
    """Controls tracing a circle of radius r in the inputs' integrals at constant speed from
    angle π (a half circle, to angle 0, when `half`), and their energy."""
    turn = np.pi if half else 2 * np.pi
    speed = turn * r / T

    def u(t):
        phase = np.pi - turn * t / T if half else turn * t / T
        return speed * (np.array([np.sin(phase), -np.cos(phase)]) if half else
                        np.array([-np.sin(phase), np.cos(phase)]))  # fmt: skip

    return u, speed**2 * T


def _peak(system, stratum: str, start: np.ndarray, joints: tuple[int, int]):
    """Where |F| peaks on the torus of `joints` (others at `start`), from the model's
    symbolic fields (not the planner's numerics): F = ∂A_2/∂q_a - ∂A_1/∂q_b for inputs
    that drive joints a and b at rate +1."""
    q = system.symbols
    G = system.fields_on(system.stratum(stratum))
    a, b = joints
    F = sp.diff(G[-1, 1], q[a]) - sp.diff(G[-1, 0], q[b])
    f = sp.lambdify(q, F, "numpy")
    grid = np.linspace(-np.pi, np.pi, 361)
    X, Y = np.meshgrid(grid, grid, indexing="ij")
    values = np.zeros_like(X)
    for i in range(len(grid)):
        point = [np.full(len(grid), v) for v in start]
        point[a], point[b] = X[i], Y[i]
        values[i] = np.broadcast_to(f(*point), X[i].shape)
    i, j = np.unravel_index(np.argmax(np.abs(values)), values.shape)
    return X[i, j], Y[i, j]


def test_floor_of_a_small_loop_where_the_curvature_peaks_is_nearly_its_energy(one_arm):
    """A circle of radius 0.05 where |F| peaks encloses about |F| π r² of base rotation for
    an energy of 4π² r² / T: the floor is that energy times F there / max|F| with its
    margin (0.9 here). A floor that overstated |F|'s area (4π -> 8π) or understated max|F|
    would exceed the energy; one that had lost the curvature would be far below."""
    r = 0.05
    base = np.array([0.0, 0.4, 0.0, 0.0])
    c1, c3 = _peak(one_arm, "S2", base, (0, 2))  # S2 drives q1 and q3
    start = base.copy()
    start[0], start[2] = c1 + r, c3  # on the circle, at angle 0
    u, energy = _circle(r)
    end, integrated = run(one_arm, "S2", start, u)
    assert integrated == pytest.approx(energy, rel=1e-8)
    ratio = leg_floor(one_arm, "S2", start, end, T) / energy
    assert 0.8 < ratio <= 1.0


def test_floor_of_a_half_loop_takes_off_its_chord(one_arm):
    """A half circle from one end of a diameter to the other, where |F| peaks: the loop
    closed by the chord is longer than the path by the chord, so the floor is about half
    the energy; without taking the chord off it would be 1.8 times the energy."""
    r = 0.05
    base = np.array([0.0, 0.4, 0.0, 0.0])
    c1, c3 = _peak(one_arm, "S2", base, (0, 2))
    start = base.copy()
    start[0], start[2] = c1 - r, c3  # at angle π
    u, energy = _circle(r, half=True)
    end, _ = run(one_arm, "S2", start, u)
    assert end[0] == pytest.approx(c1 + r, abs=1e-9) and end[2] == pytest.approx(c3, abs=1e-9)
    ratio = leg_floor(one_arm, "S2", start, end, T) / energy
    assert 0.3 < ratio <= 1.0


def test_an_input_that_drives_its_joint_backwards_counts_with_its_sign():
    """z' = sin(x + y) (u1 + u2) with x' = -u1, y' = u2: in the inputs' integrals the
    curvature is -2 cos(x + y) (it would vanish with the signs ignored). A small loop where
    it peaks gets a floor near its energy."""
    system = load_scenario(
        {
            "name": "backwards",
            "model": {
                "kind": "custom",
                "states": ["x", "y", "z"],
                "inputs": ["u1", "u2"],
                "fields": {"u1": [-1, 0, "sin(x + y)"], "u2": [0, 1, "sin(x + y)"]},
                "strata": [{"name": "both", "active": ["u1", "u2"]}],
            },
            "task": {"start": [0, 0, 0], "goal": [0, 0, 0.1]},
            "planner": {"continuity": "none", "leg_duration": 1.0},
            "legs": [{"stratum": "both"}],
        }
    ).system
    r = 0.05
    u, energy = _circle(r)
    start = np.array([-r, 0.0, 0.0])  # the circle's centre at x = y = 0, where |F| = 2
    end, _ = run(system, "both", start, u)
    assert abs(end[2]) == pytest.approx(2 * np.pi * r**2, rel=1e-2)
    ratio = leg_floor(system, "both", start, end, T) / energy
    assert 0.8 < ratio <= 1.0


def test_a_plan_within_the_tolerance_of_the_goal_stays_above_the_floor(one_arm):
    """`slack`: a plan may end up to the tolerance short of the goal; the floor at the goal
    allows for it (a straight leg's floor without it equals the plan's energy)."""
    start = np.array([0.2, 0.5, -0.3, 0.1])
    rates = np.array([1.1, -0.7])
    end, energy = run(one_arm, "S2", start, lambda t: rates)
    goal = end.copy()
    goal[[0, 2]] += 1e-3 * rates / np.linalg.norm(rates)  # 1e-3 past where the plan ended
    assert leg_floor(one_arm, "S2", start, goal, T) > energy
    assert leg_floor(one_arm, "S2", start, goal, T, slack=1e-3) <= energy * (1 + 1e-9)


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
