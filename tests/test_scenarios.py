"""Every shipped scenario plans to tolerance, verified by independent re-integration."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from conftest import SCENARIOS
from reintegrate import PRINTED, custom_rhs_factory, reintegrate, symbolic_manipulator_rhs

from stratcli.continuity import mode_order
from stratcli.records.result import result_document
from stratcli.scenario import load_scenario
from stratcli.stratified import plan_sequence


def _plan(path, **changes):
    task = load_scenario(path)
    if changes:
        from dataclasses import replace

        task.settings = replace(task.settings, **changes)
    if not task.legs:  # auto mode: re-integrate the sequence it chose
        from stratcli.api import plan_auto

        outcome = plan_auto(task, check=False)
        task.legs = list(outcome.comparison.best.candidate.legs)
        return task, result_document(outcome.best.result, task.scenario.name, task.model_name)
    result = plan_sequence(task.system, task.start, task.legs, task.settings)
    return task, result_document(result, task.scenario.name, task.model_name)


def _rhs(task, doc):
    if doc["model"] in PRINTED:
        f = PRINTED[doc["model"]]
        return lambda stratum, q, u: f(q, u)
    if doc["model"] == "planar-manipulator":
        f = symbolic_manipulator_rhs(task.system.robot)
        return lambda stratum, q, u: f(q, u)
    per_stratum = custom_rhs_factory(tomllib.loads(task.text)["model"])
    return lambda stratum, q, u: per_stratum[stratum](q, u)


def verify(task, doc):
    """The properties the result.json contract promises, checked from the document alone."""
    assert doc["status"] == "ok", doc["message"]
    assert len(doc["legs"]) == len(task.legs)
    tol = doc["tolerance"]
    replay = reintegrate(doc, _rhs(task, doc))
    previous_end = np.array(doc["start"], dtype=float)
    for leg, again in zip(doc["legs"], replay, strict=True):
        # legs chain: each starts where the previous one ended
        np.testing.assert_allclose(leg["start"], previous_end, atol=1e-9)
        goal = np.array([np.nan if g is None else g for g in leg["goal"]])
        targeted = ~np.isnan(goal)
        locked = [doc["coordinates"].index(c) for c in leg["locked"]]
        targeted[locked] = False
        # reaches its goal within tolerance when re-integrated independently
        error = np.linalg.norm(again["end"][targeted] - goal[targeted])
        assert error <= tol * (1 + 1e-6) + 1e-9, (leg["stratum"], error)
        # the recorded end point is the true one
        np.testing.assert_allclose(leg["end"], again["end"], atol=1e-8)
        # locked coordinates do not move
        np.testing.assert_allclose(again["end"][locked], again["start"][locked], atol=1e-12)
        # recorded energy = recomputed energy
        assert leg["energy"] == pytest.approx(again["energy"], rel=1e-6, abs=1e-9)
        previous_end = np.array(leg["end"])
    assert doc["total_energy"] == pytest.approx(sum(r["energy"] for r in replay), rel=1e-6)
    order = mode_order(doc["continuity"])
    for sw in doc["switches"]:
        # l-modes promise continuity of the inputs the next leg uses; lr-modes of all inputs
        nxt = doc["legs"][sw["after_leg"] + 1]["active_inputs"]
        promised = doc["inputs"] if doc["continuity"].startswith("lr") else nxt
        if order >= 0:
            assert max(abs(sw["jump"][u]) for u in promised) <= 1e-9
        if order >= 1:
            assert max(abs(sw["jump_derivative"][u]) for u in promised) <= 1e-9


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_shipped_scenario_plans_and_reintegrates(path):
    task, doc = _plan(path)
    verify(task, doc)


def test_lr_mode_ends_unused_inputs_at_zero_and_l_mode_lets_them_jump(scenarios_dir):
    """Sim 1: under l-C1, u1 (unused on the last leg) may jump to 0; under lr-C1 it may not."""
    _, lr = _plan(scenarios_dir / "sim1_lr_c1.toml", objective="newton")
    _, left = _plan(scenarios_dir / "sim1_l_c1.toml", objective="newton")
    assert abs(lr["switches"][1]["jump"]["u1"]) <= 1e-9
    # l-C1 imposes nothing at the end of leg 2, so u1 generally ends away from zero
    assert abs(left["switches"][1]["jump"]["u1"]) > 1e-6


def test_soft_start_and_full_stop_hold(scenarios_dir):
    _, doc = _plan(scenarios_dir / "sim2_soft.toml")
    from reintegrate import controls

    first, last = doc["legs"][0]["pieces"][0], doc["legs"][-1]["pieces"][-1]
    for d in (False, True):
        assert np.abs(controls(first, doc["inputs"], 0.0, d)).max() <= 1e-9
        assert np.abs(controls(last, doc["inputs"], last["duration"], d)).max() <= 1e-9


@pytest.mark.parametrize("name", ["sim4_task_d", "sim4_task_b", "sim2"])
def test_tight_tolerance_1e9(scenarios_dir, name):
    task, doc = _plan(scenarios_dir / f"{name}.toml", tolerance=1e-9)
    assert all(leg["error"] <= 1e-9 for leg in doc["legs"])
    verify(task, doc)


@pytest.mark.parametrize("mode", ["none", "l-C0", "l-C1", "lr-C0", "lr-C1"])
def test_every_continuity_mode_on_sim1(scenarios_dir, mode):
    task, doc = _plan(scenarios_dir / "sim1_lr_c1.toml", continuity=mode, objective="newton")
    assert doc["continuity"] == mode
    verify(task, doc)


def test_planning_is_deterministic(scenarios_dir):
    _, a = _plan(scenarios_dir / "sim4_task_a.toml")
    _, b = _plan(scenarios_dir / "sim4_task_a.toml")
    assert a["total_energy"] == b["total_energy"]
    assert a["legs"][1]["pieces"] == b["legs"][1]["pieces"]
