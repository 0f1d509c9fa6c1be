"""A leg planner of one's own held to its contract (`stratcli.planner_contract`): what it
returns is checked before anything is recorded of it. A user's plugin that returned no
controls, controls that break the continuity conditions, NaNs or the wrong durations had its
plan recorded ok (or crashed inside stratplan)."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest
from conftest import ROOT

import stratcli
from stratcli.planner_contract import PlannerContractError
from stratcli.planners import PLANNERS, LegPlanner, NewtonPlanner
from stratcli.scenario import load_scenario
from stratcli.status import Status

NAME = "contract-check"


def _task_d(**planner):
    """Sim 4 task D (lr-C1), its second leg by the planner under test; its first by Newton."""
    task = load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")
    legs = [
        {"stratum": "S3", "goal": ["-pi/3", "pi/3", 0, "-pi/12"]},
        {"stratum": "S1", "method": NAME},
    ]
    return task.with_changes({"legs": legs, "planner": {"objective": "newton", **planner}})


@pytest.fixture
def own():
    """Register a planner of one's own whose `plan` is the function given (for one test)."""

    def make(plan, **methods):
        def missing(self, problem):
            return NewtonPlanner().missing_coefficients(problem)

        body = {"method": NAME, "plan": plan, "missing_coefficients": missing, **methods}
        return type("Own", (LegPlanner,), body)

    yield make
    PLANNERS.pop(NAME, None)


def _newton(problem, **changes):
    return NewtonPlanner().plan(replace(problem, **changes))


def _with_pieces(**piece_changes):
    """Newton's plan with each piece changed (a callable value: of the piece)."""

    def plan(self, problem):
        out = _newton(problem)
        pieces = []
        for p in out.pieces:
            changes = {k: v(p) if callable(v) else v for k, v in piece_changes.items()}
            pieces.append(replace(p, **changes))
        return replace(out, pieces=tuple(pieces))

    return plan


BROKEN = {  # what the planner returns -> the TypeError's message (after the planner's name)
    "no pieces, ok": (
        lambda self, p: replace(_newton(p), pieces=()),
        r" reported its goal reached with no controls \(pieces\)$",
    ),
    "status as text": (
        lambda self, p: replace(_newton(p), status="success"),
        r": status must be a stratcli.Status \(Status.SUCCESS, ...\), not str 'success'$",
    ),
    "NaN coefficients": (
        _with_pieces(coefficients=lambda p: np.full_like(p.coefficients, np.nan)),
        r": piece 0 has coefficients that are not finite$",
    ),
    "infinite duration": (_with_pieces(duration=np.inf), r": piece 0 lasts inf s: a piece "),
    "negative duration": (_with_pieces(duration=-1.0), r": piece 0 lasts -1 s: a piece "),
    "half the leg": (
        lambda self, p: _newton(p, duration=p.duration / 2),
        r": its pieces last 0.5 s, not the leg's 1 s$",
    ),
}


@pytest.mark.parametrize("case", BROKEN)
def test_an_outcome_that_breaks_the_contract_is_a_type_error_naming_the_planner(own, case):
    plan, message = BROKEN[case]
    own(plan)
    where = r" \(planning leg 2 on S1\)"  # (one planner may plan several legs)
    message = message.replace("$", where + "$") if message.endswith("$") else message
    with pytest.raises(
        PlannerContractError, match=rf"^leg planner '{NAME}' \(Own.plan\)" + message
    ):
        stratcli.plan(_task_d())


@pytest.mark.parametrize(
    ("planner", "dropped", "broken"),
    [  # (the worst condition broken is named)
        ({}, {"continuity": "none", "previous": None, "next_active": None}, "(0) continues"),
        ({"full_stop": True}, {"full_stop": False}, "full stop: u"),
    ],
)
def test_controls_that_break_the_boundary_conditions_fail_the_leg(own, planner, dropped, broken):
    """Newton's own search on the leg without (some of) its boundary conditions reaches the
    goal, with a jump at the switch (5.7 on a helper's run) or not at rest at the end: the
    leg fails naming the condition, and the same search with them passes (the check is the
    conditions', not a planner's)."""
    own(lambda self, problem: _newton(problem, **dropped))
    plan = stratcli.plan(_task_d(**planner))
    leg = plan.legs[1]
    assert not plan.ok and leg.status is Status.NOT_CONVERGED
    head = f"leg planner '{NAME}' (Own.plan) returned controls that break the leg's boundary "
    assert leg.message.startswith(f"{head}conditions: ") and broken in leg.message
    PLANNERS.pop(NAME)
    own(lambda self, problem: _newton(problem))  # the same search, conditions kept
    kept = stratcli.plan(_task_d(**planner))
    assert kept.ok and kept.legs[1].status is Status.SUCCESS
    assert max(np.abs(s.jump).max() for s in kept.switches) <= 1e-9


def test_a_bug_in_making_the_planner_or_in_its_check_is_noted_with_its_name(own):
    """An exception in a user's `from_settings` (its `__init__`) or `missing_coefficients`
    came out of stratplan's checks with no note: the command line showed stratplan's
    traceback instead of one line naming the planner."""

    def refusing(cls, settings, leg, **overrides):
        raise ValueError("no settings for me")

    own(lambda self, p: _newton(p), from_settings=classmethod(refusing))
    with pytest.raises(ValueError) as caught:
        _task_d()
    assert caught.value.__notes__ == [
        f"raised by leg planner '{NAME}' (Own.from_settings) checking leg 2 on S1"
    ]
    PLANNERS.pop(NAME)

    def missing(self, problem):
        raise KeyError("free")

    own(lambda self, p: _newton(p), missing_coefficients=missing)
    with pytest.raises(KeyError) as caught:
        _task_d()
    assert caught.value.__notes__ == [
        f"raised by leg planner '{NAME}' (Own.missing_coefficients) checking leg 2 on S1"
    ]


@pytest.mark.parametrize("duration", [0.0, float("nan"), -1.0])
def test_a_problem_duration_that_is_no_time_is_refused_naming_it(own, duration):
    """A Lie-like planner's `problem_duration` of 0 or NaN failed deep in the end-point map
    ("cannot convert float NaN to integer"), blamed on its `plan`."""
    own(lambda self, p: _newton(p), problem_duration=lambda self, leg_duration: duration)
    with pytest.raises(PlannerContractError) as caught:
        _task_d()
    assert str(caught.value) == (
        f"leg planner '{NAME}' (Own.problem_duration) returned {duration!r}: a leg lasts a "
        "positive time"
    )


def test_optimised_durations_with_a_planner_of_ones_own_name_it(own):
    """`durations = "optimise"` with a plugin's leg said "needs Newton legs (a Lie leg sets
    its own)", of a sequence with no Lie leg."""
    from stratcli.errors import InputError

    own(lambda self, p: _newton(p))
    with pytest.raises(InputError) as caught:
        _task_d(objective="energy", durations="optimise", total_duration=2.0)
    assert [p.message for p in caught.value.problems] == [
        f'"optimise" needs Newton legs (not {NAME})'
    ]


def test_regress_names_the_file_of_a_contract_error(own, tmp_path):
    """`regress` over a folder printed the planner's contract error without the scenario
    file it came from."""
    from stratcli.api.regression import regress

    own(_with_pieces(coefficients=lambda p: np.full_like(p.coefficients, np.nan)))
    text = (ROOT / "scenarios" / "sim4_task_d.toml").read_text()
    (tmp_path / "mine.toml").write_text(
        text.replace('stratum = "S1"', f'stratum = "S1"\nmethod = "{NAME}"')
    )
    with pytest.raises(PlannerContractError, match=rf"^mine.toml: leg planner '{NAME}' "):
        regress(tmp_path, tmp_path / "b.json", update=True)


def test_an_unknown_method_among_many_planners_is_one_short_line():
    """With 30 planners of one's own registered the message listed all 30 names."""
    from stratcli.errors import InputError

    names = [f"many-{k}" for k in range(7)]
    try:
        for name in names:
            type(
                "Many", (LegPlanner,), {"method": name, "plan": None, "missing_coefficients": None}
            )
        with pytest.raises(InputError) as caught:
            task = load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")
            task.with_changes({"legs": [{"stratum": "S3", "method": "many-9"}]})
    finally:
        for name in names:
            PLANNERS.pop(name, None)
    (problem,) = caught.value.problems  # (other tests' planners may be registered too)
    assert re.match(
        r"must be 'lie', 'newton' or one of \d+ of your own \('[^']+', \.\.\.\) \(got "
        r"'many-9': did you mean 'many-\d'\?\)$",
        problem.message,
    ), problem.message


def test_a_sweep_whose_tasks_break_a_planner_is_refused_naming_the_task(own, tmp_path):
    """A planner of one's own whose `missing_coefficients` raised while a sweep's tasks were
    checked ended the sweep with a traceback naming no task; it is one problem per task."""
    from sweep_files import write

    from stratcli.errors import InputError
    from stratcli.sweep.spec import load_sweep

    def missing(self, problem):
        raise KeyError("free")

    own(lambda self, p: _newton(p), missing_coefficients=missing)
    text = (ROOT / "scenarios" / "sim4_task_d.toml").read_text()
    base = tmp_path / "mine.toml"
    base.write_text(text.replace('stratum = "S1"', f'stratum = "S1"\nmethod = "{NAME}"'))
    grid = '[sweep.grid]\n"goal.q1" = [-1.0, -0.9]\n'
    with pytest.raises(InputError) as caught:
        load_sweep(write(tmp_path, grid, scenario=base))
    lines = [f"{p.path}: {p.message}" for p in caught.value.problems]
    assert lines and all(
        f"KeyError: 'free' (raised by leg planner '{NAME}' (Own.missing_coefficients) "
        "checking leg 2 on S1)" in line
        for line in lines
    ), lines


def test_a_problem_duration_of_a_numpy_number_is_a_time(own):
    """(A real number of numpy's is accepted as one of Python's is.)"""
    own(lambda self, p: _newton(p), problem_duration=lambda self, d: np.float32(d))
    assert stratcli.plan(_task_d()).ok
