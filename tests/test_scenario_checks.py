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
