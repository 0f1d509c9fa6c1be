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


def test_strata_of_a_robot_of_ten_or_more_joints_have_names_of_their_own():
    """Locking joint 12 and locking joints 1 and 2 were both S12 (77 strata of 78, silently);
    now S12 and S1_2. Below 10 joints names are as before (S12: joints 1 and 2)."""
    twelve = parse_scenario(chain_scenario(12)).system
    assert len(twelve.strata) == 12 + 66
    assert twelve.stratum("S12").locked == (11,) and twelve.stratum("S1_2").locked == (0, 1)
    assert twelve.stratum("S1_12").locked == (0, 11) and "S3" in twelve.strata
    assert parse_scenario(chain_scenario(4)).system.stratum("S12").locked == (0, 1)


@pytest.mark.parametrize(
    ("strata", "expected"),
    [
        ("[[2, 2]]", r"model\.strata\[0\]: lock set \[2, 2\] names a joint twice"),
        ("[[1], [2], [1]]", r"model\.strata\[2\]: lock set \[1\] repeats model\.strata\[0\]"),
        (
            "[[1], [3]]",
            r"model\.strata\[1\]: lock set \[3\]: no joint 3 \(this robot's joints are 1\.\.2",
        ),
        ("[[1, 2]]", r"model\.strata\[0\]: lock set \[1, 2\] locks every joint"),
        ("[[]]", r"model\.strata\[0\]: an empty lock set"),
    ],
)
def test_a_lock_set_naming_a_joint_twice_or_given_twice_is_refused(strata, expected):
    """[[2, 2]] was read as S2 and [[1], [1]] as one stratum, without a word; a joint the
    robot does not have was "must name 1..1 distinct joints out of 1..2"."""
    text = PLANAR.replace("base = { mass = 10 }", "base = { mass = 10, a = 1, b = 0.6 }")
    with pytest.raises(InputError, match=expected):
        parse_scenario(text.replace("[task]", f"strata = {strata}\n[task]"))
