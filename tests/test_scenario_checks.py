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


@pytest.mark.parametrize(
    ("change", "line"),
    [
        ({"name": "задача_д"}, "name: must be ASCII letters, digits, '_', '.' and '-' only"),
        ({"name": "a" * 120}, "name: must be at most 100 characters long (got "),
        ({"reference": {"energy": -5.0}}, "reference.energy: must be at least 0 (got -5"),
    ],
)
def test_schema_messages_say_the_rule_in_words(change, line):
    raw = tomllib.loads(TASK_D.read_text())
    raw.update(change)
    with pytest.raises(InputError) as info:
        load_scenario(raw)
    lines = [f"{p.path}: {p.message}" for p in info.value.problems]
    assert any(x.startswith(line) for x in lines), lines


def test_a_custom_models_coordinate_name_rule_is_in_words():
    raw = tomllib.loads((TASK_D.parent / "unicycle.toml").read_text())
    raw["model"]["states"] = ["x", "y", "θ"]
    with pytest.raises(InputError) as info:
        load_scenario(raw)
    messages = [p.message for p in info.value.problems]
    assert any(m.startswith("must be a name of ASCII letters, digits and '_'") for m in messages)


@pytest.mark.parametrize(
    ("start", "line"),
    [  # named as written, where they were task.start[3] (and "*" three lines of syntax)
        ({"attitude": [1e300, 0, 0]}, "task.start.attitude[0]: must be at most 10000"),
        ({"attitude": "*"}, 'task.start.attitude: "*" (free) is for goals and vias; the start'),
        ({"j2": "*"}, 'task.start.j2: "*" (free) is for goals and vias'),
    ],
)
def test_a_urdf_configuration_by_name_has_its_problems_named_as_written(start, line):
    path = TASK_D.parent / "spatial" / "arm3_reorient.toml"
    raw = tomllib.loads(path.read_text())
    raw["task"]["start"] = {**raw["task"]["start"], **start}
    raw["model"]["path"] = str(path.parent / raw["model"]["path"])
    with pytest.raises(InputError) as info:
        load_scenario(raw)
    lines = [f"{p.path}: {p.message}" for p in info.value.problems]
    assert len(lines) == 1 and lines[0].startswith(line), lines


def test_a_value_just_outside_a_limit_is_printed_with_the_digits_that_show_it():
    """'joint_4 = -2.094 is outside its limits [-2.0944, 2.0944]' read as inside."""
    raw = tomllib.loads((TASK_D.parent / "sim4_task_d_constrained.toml").read_text())
    raw["task"]["goal"][1] = 2.50000001
    with pytest.raises(InputError) as info:
        load_scenario(raw)
    assert "q2 = 2.50000001 is outside its limits [-2.5, 2.5]" in str(info.value)
