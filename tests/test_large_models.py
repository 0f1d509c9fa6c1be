"""Bounded work on large models: the controllability check of a 20-link chain."""

from __future__ import annotations

import time

import numpy as np
import pytest

import stratcli.liealgebra as lie
from stratcli.api.check import check_document
from stratcli.errors import InputError
from stratcli.models.presets import preset
from stratcli.scenario import parse_scenario


def _chain(links: int) -> str:
    link = "{ mass = 1.0, length = 0.5 }"
    n = links + 1
    return f"""name = "chain"
[model]
kind = "planar-manipulator"
base = {{ mass = 10.0, a = 1.0, b = 0.6 }}
[[model.arms]]
mount = [0.3, 0.0]
links = [{", ".join([link] * links)}]
[task]
start = [{", ".join(["0"] * n)}]
goal = [{", ".join(["0"] + ["0.1"] * (n - 1))}]
[[legs]]
stratum = "S1"
"""


@pytest.mark.parametrize("name", ["one-arm", "two-arm"])
def test_numeric_third_order_brackets_match_the_symbolic_ones(name):
    system = preset(name)
    rng = np.random.default_rng(1)
    Q = rng.uniform(-3, 3, (10, system.n))
    Q[0] = 0.0  # where every degree-2 bracket vanishes
    for stratum in system.strata.values():
        exact = lie._build(system, stratum, 3)
        numeric = lie._manipulator_basis(system, stratum, 3)
        assert numeric.labels == exact.labels
        assert np.abs(numeric.evaluate(Q) - exact.evaluate(Q)).max() < 1e-8


def test_check_of_a_20_link_chain_is_quick_and_right():
    task = parse_scenario(_chain(20))
    t0 = time.perf_counter()
    doc = check_document(task.system, ["S1"], task.start, legs=task.legs)
    assert time.perf_counter() - t0 < 30
    (stratum,) = doc["strata"]
    assert stratum["rank_at_requested_degree"] == 19 and stratum["degree_at"] == 3
    assert doc["controllable"] and stratum["strong"]


def test_more_than_24_links_is_an_input_error():
    with pytest.raises(InputError, match="at most 24"):
        parse_scenario(_chain(25))
