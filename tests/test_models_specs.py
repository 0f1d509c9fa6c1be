"""Model sections of a scenario: physical parameters checked, bounded sizes."""

from __future__ import annotations

import pytest
from conftest import (
    chain_scenario,
)

from stratcli.errors import InputError
from stratcli.scenario import parse_scenario

PLANAR = """
name = "p"
[model]
kind = "planar-manipulator"
base = { mass = 10 }
arms = [{ mount = [0.3, 0], links = [{ mass = 1, length = 1 }, { mass = 1, length = 1 }] }]
[task]
start = [0, 0, 0]
goal = [0, 0.5, 0.1]
[[legs]]
stratum = "S1"
"""


def test_planar_model_needs_base_inertia_or_size():
    with pytest.raises(InputError, match=r"model\.base: give either inertia or the rectangle"):
        parse_scenario(PLANAR)
    task = parse_scenario(PLANAR.replace("mass = 10 }", "mass = 10, a = 1, b = 0.6 }"))
    assert task.model_name == "planar-manipulator" and task.system.n == 3


def test_more_than_24_links_is_an_input_error():
    with pytest.raises(InputError, match="at most 24"):
        parse_scenario(chain_scenario(25))
