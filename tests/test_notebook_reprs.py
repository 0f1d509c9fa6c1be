"""What a notebook shows for the public values: a cell ending in one of them prints its repr,
which was the dataclass's for most of them, many kB (a Task's symbolic fields padded to the
width of their longest entry, a sweep's every row: some 200 kB for the 441 tasks of
scenarios/sweeps/sim4_goal_map.toml). Each says in one line what it is instead."""

from __future__ import annotations

import tomllib

import pytest
from conftest import ROOT
from sweep_files import GRID, write

import stratcli

UNICYCLE = tomllib.loads((ROOT / "scenarios" / "unicycle.toml").read_text())
TASK_D = ROOT / "scenarios" / "sim4_task_d.toml"
SHORT = 200  # characters: one line in a notebook


@pytest.fixture(scope="module")
def task():
    return stratcli.load_scenario(TASK_D)


@pytest.fixture(scope="module")
def plan():
    return stratcli.plan(UNICYCLE, check=False)


def test_a_task_and_its_model_say_name_model_legs_start_and_goal(task):
    text = repr(task)
    assert len(text) < SHORT, text
    assert text == (
        "Task('sim4_task_d': one-arm model, legs (S3, S1), energy objective, "
        "start [0, 0.7854, 0, 0], goal [-1.047, 1.047, 0.7854, -0.2618])"
    )
    newton = task.with_changes({"planner": {"objective": "newton"}})  # told apart
    assert repr(newton).startswith("Task('sim4_task_d': one-arm model, legs (S3, S1), newton ")
    limited = task.with_changes({"constraints": {"joint_limits": [-2.5, 2.5]}})
    assert ", energy objective, [constraints], start [0, " in repr(limited)
    assert repr(task.system) == (
        "PresetSystem('one-arm': coordinates q1, q2, q3, theta; inputs u1, u2, u3; "
        "strata S1, S2, S3)"
    )
    auto = task.with_changes(
        {"legs": None, "decompose": {"max_length": 2}, "task": {"goal": [-1, 1, "*", 0]}}
    )
    assert repr(auto).startswith("Task('sim4_task_d': one-arm model, auto mode, energy ")
    assert repr(auto).endswith("goal [-1, 1, *, 0])")  # "*": any value will do


def test_a_leg_and_a_trajectory_leave_their_arrays_out(plan):
    leg = plan.legs[0]
    assert repr(leg) == (
        f"LegPlan(leg 1 on drive, newton: SUCCESS, error {leg.error:.2g}, "
        f"energy {leg.energy:.6g}, t 0 to 2 s, 1 piece)"
    )
    trajectory = plan.sample(50)
    assert repr(trajectory) == (
        "Trajectory(50 samples, t 0 to 2 s, 3 coordinates, 2 inputs, legs (drive))"
    )


def test_a_failed_plan_says_how_many_of_its_legs_were_planned(task):
    hopeless = task.with_changes(
        {"planner": {"objective": "newton", "tolerance": 1e-12, "max_iterations": 1}}
    )
    hopeless = hopeless.with_changes({"planner": {"restarts": 0}})
    failed = stratcli.plan(hopeless, check=False)
    assert not failed.ok and len(failed.legs) == 1 and failed.planned_legs == 2
    assert ", 1 of 2 legs (S3), 1 s)" in repr(failed)


def test_decomposition_and_check_are_one_line(task):
    auto = task.with_changes({"legs": None, "decompose": {"max_length": 3}})
    decomposition = stratcli.decompose(auto)
    text = repr(decomposition)
    assert len(text) < SHORT, text
    assert text.startswith("DecompositionOutcome('sim4_task_d': 18 candidate sequences: (S1, S2)")
    assert text.endswith(", ...)")
    report = stratcli.check_controllability(task, samples=5)
    assert repr(report).startswith(
        "CheckReport(sim4_task_d (one-arm model): controllable; strata S3, S1, "
    )


def test_a_sweep_says_how_far_it_got_not_every_row(tmp_path):
    out = tmp_path / "o"
    outcome = stratcli.run_sweep(write(tmp_path, GRID), out, jobs=1)
    assert (
        repr(outcome)
        == f"SweepOutcome('small' in {str(out)!r}: 6 of 6 tasks (ok 6), 6 planned here)"
    )
    assert repr(stratcli.read_sweep(out)) == (
        f"SweepReport('small' in {str(out)!r}: 6 of 6 tasks (ok 6), finished)"
    )


def test_an_unfinished_sweep_read_back_lists_the_tasks_it_misses(tmp_path):
    """Its summary said `missing: 4` beside `missing_tasks: []`: sweep.json's own list."""
    out = tmp_path / "o"
    stratcli.run_sweep(write(tmp_path, GRID), out, jobs=1)
    lines = (out / "rows.jsonl").read_text().splitlines()
    (out / "rows.jsonl").write_text("\n".join(lines[1:3]) + "\n")  # as if killed
    (out / "sweep.json").unlink()
    report = stratcli.read_sweep(out)
    kept = sorted(report.rows)
    assert not report.finished and len(kept) == 2
    assert report.summary["missing"] == 4
    assert report.summary["missing_tasks"] == [k for k in range(6) if k not in kept]
    assert repr(report).endswith(": 2 of 6 tasks (ok 2), unfinished)")


def test_a_check_that_fails_says_so_and_how_often():
    from test_api_planning import TURN_ONLY

    report = stratcli.check_controllability(TURN_ONLY, samples=3)
    assert repr(report).startswith(
        "CheckReport(turn-only (custom model): NOT controllable (1 problem); strata turn, "
    )


def test_a_comparisons_parts_are_one_line_each(task):
    """`outcome.comparison` printed 16 kB (every outcome with its plan and legs' arrays),
    `outcome.decomposition` 8 kB."""
    auto = task.with_changes(
        {"legs": None, "decompose": {"max_length": 2}, "planner": {"objective": "newton"}}
    )
    outcome = stratcli.compare_sequences(auto, jobs=1)
    comparison, best = outcome.comparison, outcome.comparison.best
    assert repr(comparison) == f"Comparison(6 sequences by energy: {comparison.choice()})"
    assert repr(best) == (
        f"Outcome({best.candidate.label} conservative: rank 1, ok, energy {best.energy:.6g})"
    )
    assert repr(best.candidate) == f"Candidate({best.candidate.label} conservative)"
    assert repr(outcome.decomposition) == (
        "Decomposition(6 candidates of up to 2 strata from S1, S2, S3; conservative)"
    )
    assert all(len(repr(o)) < SHORT for o in comparison.outcomes)


def test_a_piece_and_an_optimisation_say_what_they_hold_in_one_line():
    """`plan.legs[0].pieces[0]` printed every coefficient and `plan.optimisation` ran to
    700 characters for two starts (the dataclasses' reprs)."""
    planned = stratcli.plan(TASK_D)
    piece = planned.legs[0].pieces[0]
    rows, cols = piece.coefficients.shape
    assert repr(piece) == f"Piece(t0 0 s, 1 s, coefficients {rows} inputs x {cols})"
    text = repr(planned.optimisation)
    assert len(text) < SHORT, text
    kinds = [s.kind for s in planned.optimisation.starts]
    assert text.startswith(f"Optimisation({len(kinds)} starts: {kinds[0]} ")
    assert text.endswith(f"; best start {planned.optimisation.best + 1})")


def test_a_leg_spec_and_a_model_ref_say_what_they_are_in_one_line(task):
    """A LegSpec printed its goal's array, a ModelRef the whole [model] table."""
    assert repr(task.legs[0]) == "LegSpec(S3 to [-1.047, 1.047, 0, -0.2618], newton, 1 s)"
    free = task.with_changes({"legs[0].goal.theta": "*"}).legs[0]
    assert repr(free) == "LegSpec(S3 to [-1.047, 1.047, 0, *], newton, 1 s)"
    assert repr(stratcli.plan(task).model) == "ModelRef('one-arm')"
