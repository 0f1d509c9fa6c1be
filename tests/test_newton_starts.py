"""The energy search's starts made of Newton plans (`stratcli.newton_starts`): the lowest legs
of robots without exact second derivatives."""

from pathlib import Path

import numpy as np
import pytest

ARM3 = Path(__file__).resolve().parents[1] / "robots" / "arm3.urdf"


@pytest.fixture(scope="module")
def arm3_turns():
    """arm3 turned 30° about x on S3, then about y on S1 (a user's task, its first two legs):
    the plain Newton plan's first leg costs about twice the lowest of six."""
    pytest.importorskip("pinocchio")
    import stratcli

    still = {"j1": 0, "j2": 0, "j3": 0}
    task = stratcli.load_scenario(
        {
            "name": "arm3_turns",
            "model": {"kind": "urdf", "path": str(ARM3)},
            "task": {
                "start": {**still, "attitude": [0, 0, 0]},
                "goal": {**still, "attitude": ["*", 0.5, "*"]},
            },
            "planner": {"continuity": "lr-C1", "leg_duration": 2.0, "tolerance": 1e-6},
            "legs": [
                {"stratum": "S3", "goal": {**still, "attitude": ["30deg", 0, 0]}},
                {"stratum": "S1"},
            ],
        }
    )
    from stratcli.stratified import chain_legs

    newton = chain_legs(task.system, task.start, task.legs, task.settings)
    assert newton.ok
    return task, newton


def test_the_lowest_legs_chain_each_leg_the_lowest_of_its_newton_plans(arm3_turns):
    """Each leg is the lowest-energy of its Newton plans that reach the goal, the plain plan's
    leg among them: the first leg costs no more than the plain one, every leg reaches its
    goal, starts where the one before ends and takes up its controls (lr-C1)."""
    from stratcli.newton_starts import lowest_legs

    task, newton = arm3_turns
    low = lowest_legs(task.system, task.start, task.legs, task.settings, newton)
    assert low is not None and low.ok
    assert low.legs[0].energy < newton.legs[0].energy  # (24.45, the plain plan's 45.57)
    assert all(leg.converged and leg.error <= task.settings.tolerance for leg in low.legs)
    np.testing.assert_allclose(low.legs[1].start, low.legs[0].end, rtol=0, atol=1e-12)
    for switch in low.switches:
        assert np.abs(switch.jump).max() <= 1e-9
        assert np.abs(switch.jump_derivative).max() <= 1e-9
    # one plan a leg is the plain Newton plan: nothing new
    assert lowest_legs(task.system, task.start, task.legs, task.settings, newton, 1) is None


def _arm3_turned_on_s3_then_s2():
    """A random arm3 task (`benchmarks/bench_urdf_starts.py`, seed 101) whose lowest legs end
    lower than the Newton plan's search (74.22 against 105.40)."""
    import stratcli

    def at(j1, j2, j3, attitude):
        return {"j1": j1, "j2": j2, "j3": j3, "attitude": attitude}

    return stratcli.load_scenario(
        {
            "name": "arm3_s3_s2",
            "model": {"kind": "urdf", "path": str(ARM3)},
            "task": {
                "start": at(
                    0.4556886591519633, 0.14604509636705887, -0.32907430208491495, [0, 0, 0]
                ),
                "goal": at(
                    1.4214837274779768,
                    0.73697556785277,
                    -1.0797855492032995,
                    [0.26039250531470726, -0.06055294363505821, 0.05874123767438984],
                ),
            },
            "planner": {"continuity": "lr-C1", "leg_duration": 2.0, "tolerance": 1e-6},
            "legs": [
                {
                    "stratum": "S3",
                    "goal": at(
                        1.1320497574286263,
                        0.73697556785277,
                        -0.32907430208491495,
                        [0.1419530443898682, -0.08264270077946063, 0.09164876037843664],
                    ),
                },
                {"stratum": "S2"},
            ],
        }
    )


def test_the_energy_search_races_the_lowest_legs_after_the_newton_plan():
    """URDF robots' legs have no exact second derivatives: the search runs from the Newton
    plan and races the lowest legs after it, which win where they end lower. They stand in
    for the pulled start, so `starts = 1` leaves them out."""
    pytest.importorskip("pinocchio")
    from dataclasses import replace

    from stratcli.objectives import plan_sequence
    from stratcli.planners.energy import LOWEST_LEGS
    from stratcli.within_limits import _from_a_later_start

    task = _arm3_turned_on_s3_then_s2()
    plan = plan_sequence(task.system, task.start, task.legs, task.settings)
    assert [s.kind for s in plan.optimisation.starts] == ["newton", LOWEST_LEGS]
    newton, low = plan.optimisation.starts
    assert plan.ok and plan.optimisation.best == 1 and low.feasible
    assert low.energy < newton.energy * (1 - 1e-6)
    assert plan.total_energy == pytest.approx(low.energy, rel=1e-6)
    # under [constraints] the search's own minimum is not searched for again: it is this one
    assert not _from_a_later_start(plan)
    one = plan_sequence(task.system, task.start, task.legs, replace(task.settings, starts=1))
    assert [s.kind for s in one.optimisation.starts] == ["newton"]
    assert one.total_energy == pytest.approx(newton.energy, rel=1e-6)
