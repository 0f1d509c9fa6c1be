"""Scenario checks a new user's files met with repeated or wrong lines."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from stratcli.errors import InputError
from stratcli.scenario import load_scenario

TASK_D = Path(__file__).resolve().parents[1] / "scenarios" / "sim4_task_d.toml"


def _lines(**planner) -> list[str]:
    raw = tomllib.loads(TASK_D.read_text())
    raw["planner"].update(planner)
    with pytest.raises(InputError) as info:
        load_scenario(raw)
    return [f"{p.path}: {p.message}" for p in info.value.problems]


def test_too_many_basis_periods_is_said_once_and_alone():
    """Both 1 s legs gave the same line, and the degenerate basis's conditions a third,
    blaming full_stop where none was set."""
    lines = _lines(basis={"harmonics": 3, "period": 1e-9})
    assert lines == [
        "planner.basis.period: a leg of 1 s spans 1e+09 basis periods (at most 1000); use a "
        "longer period or a shorter leg"
    ]


def test_a_goal_on_a_joint_limit_is_refused_before_planning():
    """The search keeps its margins 0.002 inside at every node, the leg's end among them: a
    goal y = 1 under limits of ±1 stalled after 4.4 s (three bases tried)."""
    raw = tomllib.loads((TASK_D.parent / "unicycle.toml").read_text())
    raw["constraints"] = {"joint_limits": [-1, 1]}
    assert raw["task"]["goal"][1] == 1
    with pytest.raises(InputError) as info:
        load_scenario(raw)
    (problem,) = info.value.problems
    assert problem.path == "task.goal" and problem.message.startswith(
        "y = 1 is 0 from its limit 1: a plan keeps 0.002 inside the limits"
    )
    raw["constraints"] = {"joint_limits": [-1.01, 1.01]}  # 0.01 inside: planned as before
    assert load_scenario(raw).constraints is not None
