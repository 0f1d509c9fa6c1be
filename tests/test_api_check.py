"""The controllability check's document: presets, a 20-link chain."""

from __future__ import annotations

import time

import numpy as np
import pytest
from conftest import (
    chain_scenario,
    weak_stratum_scenario,
)

from stratcli.api.check import check_document
from stratcli.models.presets import preset
from stratcli.scenario import parse_scenario


def test_presets_are_strongly_controllable():
    for name in ("one-arm", "two-arm"):
        system = preset(name)
        doc = check_document(system, list(system.strata), np.zeros(system.n), samples=20)
        assert doc["strongly_controllable"] and doc["stratified_controllable"], name
        assert doc["controllable"] and not doc["problems"]
        # at q = 0 every first derivative of A vanishes: third-order brackets are needed there
        assert all(s["rank_at_requested_degree"] < s["dimension"] for s in doc["strata"])
        assert all(s["degree_at"] == 3 for s in doc["strata"])


def test_check_of_a_20_link_chain_is_quick_and_right():
    task = parse_scenario(chain_scenario(20))
    t0 = time.perf_counter()
    doc = check_document(task.system, ["S1"], task.start, legs=task.legs)
    assert time.perf_counter() - t0 < 30
    (stratum,) = doc["strata"]
    assert stratum["rank_at_requested_degree"] == 19 and stratum["degree_at"] == 3
    assert doc["controllable"] and stratum["strong"]


@pytest.mark.parametrize(
    "strata, degree", [(("S12", "S34"), 2), (("S1", "S2"), 2), (("S12", "S3"), 3)]
)
def test_a_manipulators_closure_across_strata_equals_the_symbolic_one(strata, degree):
    """Closed form (one stratum with every input of the strata) against sympy's brackets of
    the fields of each stratum: same labels, same fields (degree 3: fourth-order differences)."""
    from stratcli import crossbasis as c

    system = parse_scenario(weak_stratum_scenario()).system
    Q = np.random.default_rng(0).uniform(-3, 3, (30, system.n))
    fast = c.cross_basis(system, strata, degree)
    slow = c.symbolic_cross_basis(system, strata, degree)
    assert fast.labels == slow.labels
    np.testing.assert_allclose(fast.evaluate(Q), slow.evaluate(Q), rtol=0, atol=1e-11)


@pytest.mark.parametrize("path", ["sim4_task_d.toml", "biped.toml", "sim3_hybrid.toml"])
def test_remembered_samples_give_the_very_same_document(path, monkeypatch):
    """Checks share the seeded samples through a per-system row cache; the document is the
    one computed on all rows at once, bit for bit, for a new start as for a repeated one."""
    from stratcli import controllability
    from stratcli.api.inspection import check_strata
    from stratcli.scenario import load_scenario

    task = load_scenario(f"scenarios/{path}")
    system, strata, legs = task.system, check_strata(task), task.legs or None
    starts = [np.asarray(task.start, dtype=float), np.asarray(task.start) + 0.1]
    remembered = [check_document(system, strata, q, legs=legs) for q in [*starts, starts[0]]]
    assert system.__dict__["_row_cache"]  # the samples' rows were remembered
    monkeypatch.setattr(controllability, "_rows", lambda system, what, Q, compute: compute(Q))
    for q, doc in zip([*starts, starts[0]], remembered, strict=True):
        assert doc == check_document(system, strata, q, legs=legs)


def test_a_badly_scaled_model_is_told_why_it_reads_as_unspanned():
    """Fields (1, 0) and (0, 1e-9) span the plane, but the rank is relative (1e-9 of the
    largest singular value): refused as "span only 1 of the 2", with no word of scale. The
    refusal says the singular value is small, not zero, and how to plan anyway; fields that
    truly span one direction only get no such word."""
    import stratcli

    def task(w):
        return stratcli.load_scenario({
            "name": "scaled",
            "model": {
                "kind": "custom", "states": ["x", "y"], "inputs": ["v", "w"],
                "fields": {"v": [1, 0], "w": w},
                "strata": [{"name": "all", "active": ["v", "w"]}],
            },
            "task": {"start": [0, 0], "goal": [1, 1e-9]},
            "legs": [{"stratum": "all"}],
        })  # fmt: skip

    (scaled,) = stratcli.check_controllability(task([0, 1e-9])).problems
    assert "span only 1 of the 2" in scaled
    assert "smallest singular value there is 1.0e-09, not zero" in scaled
    assert "plan with --no-check" in scaled
    (parallel,) = stratcli.check_controllability(task([2, 0])).problems
    assert "span only 1 of the 2" in parallel and "singular value" not in parallel
